#include "fit/method.h"

#include <functional>

#include "fit/methods.h"
#include "fit/near_fit.h"
#include "fit/per_view_fit.h"

namespace matfit::fit {
namespace {

class FunctionMethod : public FitMethod {
 public:
  FunctionMethod(std::string name, std::string description, int params, int bytes, int light_params,
                 int per_channel, FitFn fn)
      : name_(std::move(name)),
        description_(std::move(description)),
        params_(params),
        bytes_(bytes),
        light_params_(light_params),
        per_channel_(per_channel),
        fn_(std::move(fn)) {}
  std::string name() const override { return name_; }
  std::string description() const override { return description_; }
  int parameters_per_texel() const override { return params_; }
  int bytes_per_texel() const override { return bytes_; }
  int light_parameters() const override { return light_params_; }
  int parameters_per_channel() const override { return per_channel_; }
  StatusOr<FitResult> Fit(const LightStack& s, const FitOptions& o) const override {
    if (s.is_multi_view()) {
      if (name_ != "svbrdf")
        return InvalidArgument(
            name_ + " fits images of one view, but this stack holds " +
            std::to_string(ViewGroups(s).size()) +
            " views; read one view (--view THETA,PHI), fit every view jointly with --model "
            "svbrdf, or each view on its own with --model per-view:" +
            name_);
      if (s.has_light_positions())
        return InvalidArgument(
            "svbrdf: near lights (light_positions.txt) over several views are "
            "not supported; use --distant-lights");
    }
    return s.has_light_positions() ? FitNearLights(name_, fn_, s, o) : fn_(s, o);
  }

 private:
  std::string name_, description_;
  int params_, bytes_, light_params_, per_channel_;
  FitFn fn_;
};

}  // namespace

std::vector<std::string> MethodNames() {
  return {"mean",        "lambert",       "lambert-robust", "heinrich",  "ptm", "ptm-srgb",
          "hsh2",        "hsh2-srgb",     "hsh3",           "hsh3-srgb", "rbf", "rbf-srgb",
          "blinn-phong", "cook-torrance", "lafortune1",     "lafortune2"};
}

std::vector<std::string> MultiViewMethodNames() { return {"svbrdf"}; }

std::vector<std::string> PerViewMethodNames() {
  std::vector<std::string> names;
  for (const std::string& n : MethodNames()) names.push_back(kPerViewPrefix + n);
  return names;
}

std::unique_ptr<FitMethod> MakeMethod(const std::string& name) {
  if (name.starts_with(kPerViewPrefix))
    return MakePerViewMethod(name.substr(std::string_view(kPerViewPrefix).size()));
  // Bytes per texel as packed: 8-bit sRGB colour (3), 16-bit normal (6), 8-bit ambient (3),
  // 16-bit normal scale (2), 8-bit specular colour (3); the exponent is one per material;
  // PTM coefficients as 16-bit half floats (18 × 2).
  if (name == "mean")
    return std::make_unique<FunctionMethod>(name, "per-texel mean colour", 3, 3, 1, 1, FitMean);
  if (name == "lambert")
    return std::make_unique<FunctionMethod>(name, "photometric stereo: normal + albedo", 5, 9, 3, 1,
                                            FitLambert);
  if (name == "lambert-robust")
    return std::make_unique<FunctionMethod>(
        name, "photometric stereo rejecting shadows, highlights, clipped and NaN samples per texel",
        5, 9, 3, 1, FitLambertRobust);
  if (name == "heinrich")
    return std::make_unique<FunctionMethod>(
        name, "seed method A: mean texture, unnormalised normal, grey ambient, specular map", 12,
        17, 5, 2, FitHeinrich);
  if (name == "hsh2" || name == "hsh3" || name == "hsh2-srgb" || name == "hsh3-srgb") {
    const int order = name[3] - '0';
    const bool srgb = name.ends_with("-srgb");
    return std::make_unique<FunctionMethod>(
        name,
        "hemispherical harmonics, " + std::to_string(order * order) + " coefficients per channel" +
            (srgb ? ", fitted to the sRGB-encoded values (as RTI tools do)" : ""),
        3 * order * order, 6 * order * order, order * order, order * order,
        [order, srgb](const LightStack& s, const FitOptions& o) {
          return FitHsh(s, o, order, srgb);
        });
  }
  if (name == "blinn-phong")
    return std::make_unique<FunctionMethod>(
        name, "per-texel LM: normal, albedo, k_s (exponent shared per material)", 6, 10, 4, 1,
        FitBlinnPhong);
  if (name == "cook-torrance")
    return std::make_unique<FunctionMethod>(
        name, "per-texel LM: normal, albedo, F0 (GGX roughness shared per material)", 6, 10, 4, 1,
        FitCookTorrance);
  if (name == "svbrdf")
    return std::make_unique<FunctionMethod>(
        name,
        "per-texel LM over every view x light: normal, albedo, F0 and GGX roughness (Smith "
        "masking, Schlick Fresnel)",
        7, 11, 4, 1, FitSvbrdf);
  if (name == "lafortune1" || name == "lafortune2") {
    const int lobes = name == "lafortune1" ? 1 : 2;
    return std::make_unique<FunctionMethod>(
        name, std::to_string(lobes) + " isotropic Lafortune lobe(s): normal, albedo, amplitudes",
        5 + lobes, 9 + 2 * lobes, 3 + lobes, 1,
        [lobes](const LightStack& s, const FitOptions& o) { return FitLafortune(s, o, lobes); });
  }
  if (name == "ptm" || name == "ptm-srgb") {
    const bool srgb = name == "ptm-srgb";
    return std::make_unique<FunctionMethod>(
        name,
        std::string("polynomial texture map, 6 coefficients per channel") +
            (srgb ? ", fitted to the sRGB-encoded values (as RTI tools do)" : ""),
        18, 36, 6, 6,
        [srgb](const LightStack& s, const FitOptions& o) { return FitPtm(s, o, srgb); });
  }
  if (name == "rbf" || name == "rbf-srgb") {
    const bool srgb = name == "rbf-srgb";
    const int k = kRbfComponents;
    return std::make_unique<FunctionMethod>(
        name,
        "radial-basis interpolation over the lights of " + std::to_string(k) + " PCA components, " +
            std::to_string(k) + " coefficients per channel" +
            (srgb ? ", fitted to the sRGB-encoded values (as RTI tools do)" : ""),
        3 * k, 6 * k, k, k,
        [srgb](const LightStack& s, const FitOptions& o) { return FitRbf(s, o, srgb); });
  }
  return nullptr;
}

}  // namespace matfit::fit
