// Relighting bases (METHODS.md §4): R_c = Σ_j a_{c,j} B_j(l), PTM (6 terms), HSH (order²
// terms) and RBF (k terms tabulated over the light disc in maps.basis_table, fit/rbf_fit.cc). Maps:
// coefficients, plane c·k + j (or j alone for grey stacks), k = basis_terms. The basis values are
// computed once per light (Prepare); a run is k axpys per channel. With maps.basis_srgb the sum is
// an sRGB-encoded value: R_c = decode(clamp(Σ_j a_{c,j} B_j(l), 0, 1)) (the table decode of
// core/color.h, here and in every evaluator).
#include <cmath>

#include "core/color.h"
#include "core/model/model_impl.h"
#include "core/shading/relight_basis.h"

namespace matfit::model_impl {
namespace {

MATFIT_MODEL_CLONES
void BasisKernel(const float* const* coef, const float* basis, int k, int64_t p0, int n,
                 float* __restrict out) {
  for (int t = 0; t < n; ++t) out[t] = 0.0f;
  for (int j = 0; j < k; ++j) {
    const float b = basis[j];
    const float* __restrict a = coef[j] + p0;
    for (int t = 0; t < n; ++t) out[t] += b * a[t];
  }
}

// Four lights at once: the same sums as BasisKernel (0, then + b_j a_j for j = 0 … k − 1, no
// fused multiply-add), for 16 texels at a time held in registers, so each coefficient is loaded
// once for the four lights instead of once per light, and no partial sum goes to memory.
MATFIT_MODEL_CLONES
void BasisKernel4(const float* const* coef, const float* const* basis, int k, int64_t p0, int n,
                  float* const* out) {
  constexpr int kW = 16;
  const float *b0 = basis[0], *b1 = basis[1], *b2 = basis[2], *b3 = basis[3];
  int t0 = 0;
  for (; t0 + kW <= n; t0 += kW) {
    float s0[kW] = {}, s1[kW] = {}, s2[kW] = {}, s3[kW] = {};
    for (int j = 0; j < k; ++j) {
      const float* a = coef[j] + p0 + t0;
      for (int u = 0; u < kW; ++u) s0[u] += b0[j] * a[u];
      for (int u = 0; u < kW; ++u) s1[u] += b1[j] * a[u];
      for (int u = 0; u < kW; ++u) s2[u] += b2[j] * a[u];
      for (int u = 0; u < kW; ++u) s3[u] += b3[j] * a[u];
    }
    for (int u = 0; u < kW; ++u)
      out[0][t0 + u] = s0[u], out[1][t0 + u] = s1[u], out[2][t0 + u] = s2[u],
                  out[3][t0 + u] = s3[u];
  }
  for (int l = 0; l < 4 && t0 < n; ++l) {
    for (int t = t0; t < n; ++t) {
      float sum = 0.0f;
      for (int j = 0; j < k; ++j) sum += basis[l][j] * coef[j][p0 + t];
      out[l][t] = sum;
    }
  }
}

enum class BasisKind { kPtm, kHsh, kRbf };

// The rbf table's limits: G nodes per side (RbfTableBasis needs ≥ 2; fits write 64).
inline constexpr int kMinRbfTable = 2, kMaxRbfTable = 1024;

// v ← decode(v) over a run (SrgbCurveLookup, written out so the clones vectorise it: clamp,
// index, two gathers, one lerp).
MATFIT_MODEL_CLONES
void DecodeSrgbRun(float* __restrict v, size_t n) {
  const float* decode = SrgbCurves().decode;
  constexpr int kSteps = SrgbCurveTable::kSteps;
  for (size_t q = 0; q < n; ++q) {
    const float x = v[q] > 0.0f ? (v[q] < 1.0f ? v[q] : 1.0f) : 0.0f;
    const float f = x * float(kSteps);
    int i = int(f);
    i = i < kSteps - 1 ? i : kSteps - 1;
    const float a = decode[i], b = decode[i + 1];
    v[q] = a + (f - float(i)) * (b - a);
  }
}

template <BasisKind kKind>
class BasisModel final : public ModelBase<BasisModel<kKind>> {
  static constexpr bool kPtm = kKind == BasisKind::kPtm, kRbf = kKind == BasisKind::kRbf;

 public:
  ShadingModel id() const override {
    return kPtm ? ShadingModel::kPtm : kRbf ? ShadingModel::kRbf : ShadingModel::kHsh;
  }
  const char* name() const override { return kPtm ? "ptm" : kRbf ? "rbf" : "hsh"; }
  std::vector<std::pair<const char*, const Image*>> ParameterMaps(
      const MaterialMaps& m) const override {
    if (kRbf)
      return {{"coefficients", &m.coefficients}, {"interpolation_error", &m.interpolation_error}};
    return {{"coefficients", &m.coefficients}};
  }
  bool writes_normal_map() const override { return !kPtm; }
  bool gltf_baked() const override { return true; }
  const char* rti_basis() const override { return kPtm ? "ptm" : kRbf ? nullptr : "hsh"; }
  bool has_truth_normal() const override { return false; }
  bool has_truth_albedo() const override { return false; }
  static void Basis(const MaterialMaps& m, const Vec3f& l, double* b) {
    if (kPtm)
      shading::PtmBasis(Vec3(l), b);
    else if (kRbf)
      shading::RbfTableBasis(m.basis_table.data().data(), m.basis_table.width(), m.basis_terms,
                             Vec3(l), b);
    else
      shading::HshBasis(int(std::lround(std::sqrt(double(m.basis_terms)))), Vec3(l), b);
  }
  float Evaluate(const MaterialMaps& m, int64_t i, int c, const Vec3f& l,
                 const Vec3f&) const override {
    double b[shading::kMaxHshTerms];
    Basis(m, l, b);
    const int k = m.basis_terms;
    const int base = (m.coefficients.channels() == k ? 0 : c) * k;
    double r = 0;
    for (int j = 0; j < k; ++j) r += b[j] * m.coefficients.Plane(base + j)[i];
    return m.basis_srgb ? SrgbCurveLookup(SrgbCurves().decode, float(r)) : float(r);
  }
  // rbf: the table is square, ≥ 2 nodes a side, with one plane per basis term.
  static Status CheckTable(const MaterialMaps& m) {
    const Image& t = m.basis_table;
    if (t.empty())
      return DataError(
          "an rbf material needs its basis table (maps/basis_table.exr); the pack "
          "lists none");
    if (t.width() != t.height() || t.width() < kMinRbfTable || t.width() > kMaxRbfTable ||
        t.channels() != m.basis_terms)
      return DataError("the rbf basis table is " + std::to_string(t.width()) + " x " +
                       std::to_string(t.height()) + " with " + std::to_string(t.channels()) +
                       " channel(s); it must be square, " + std::to_string(kMinRbfTable) + " to " +
                       std::to_string(kMaxRbfTable) + " a side, with basis_terms (" +
                       std::to_string(m.basis_terms) + ") channels");
    for (float v : t.data())
      if (!std::isfinite(v)) return DataError("the rbf basis table has a non-finite value");
    return Status::Ok();
  }
  void Prepare(const MaterialMaps& m, const Vec3f& l, const Vec3f& v,
               ModelLight* out) const override {
    ModelDescriptor::Prepare(m, l, v, out);
    double b[shading::kMaxHshTerms];
    Basis(m, l, b);
    for (int j = 0; j < m.basis_terms && j < ModelLight::kMaxBasis; ++j)
      out->basis[j] = float(b[j]);
  }
  void EvaluateBatch(const MaterialMaps& m, const ModelLight& light, int64_t p0, int n,
                     int channels, float* out) const override {
    EvaluateLights(m, &light, 1, p0, n, channels, out);  // one light: BasisKernel per channel
  }
  int light_group() const override { return 4; }
  void EvaluateLights(const MaterialMaps& m, const ModelLight* lights, int count, int64_t p0, int n,
                      int channels, float* out) const override {
    const int k = m.basis_terms;
    const float* planes[ModelLight::kMaxBasis];
    for (int c = 0; c < channels; ++c) {
      const int base = (m.coefficients.channels() == k ? 0 : c) * k;
      for (int j = 0; j < k; ++j) planes[j] = m.coefficients.Plane(base + j).data();
      int l = 0;
      for (; l + 4 <= count; l += 4) {
        const float* basis[4];
        float* dst[4];
        for (int q = 0; q < 4; ++q)
          basis[q] = lights[l + q].basis, dst[q] = out + (size_t(l + q) * channels + c) * n;
        BasisKernel4(planes, basis, k, p0, n, dst);
      }
      for (; l < count; ++l)
        BasisKernel(planes, lights[l].basis, k, p0, n, out + (size_t(l) * channels + c) * n);
    }
    if (m.basis_srgb) DecodeSrgbRun(out, size_t(count) * channels * n);
  }
  Status WritePackMaps(const MaterialMaps& m, const PutPackMapFn& put) const override {
    MATFIT_RETURN_IF_ERROR(put({"coefficients", "coefficients.exr", &m.coefficients,
                                MapEncoding::kFloat, "relighting coefficients, channel c*k + j"}));
    if (!kRbf) return Status::Ok();
    MATFIT_RETURN_IF_ERROR(put({"interpolation_error", "interpolation_error.exr",
                                &m.interpolation_error, MapEncoding::kFloat,
                                "leave-one-light-out RMS of the prediction (linear), floors the "
                                "confidence bound"}));
    return put({"basis_table", "basis_table.exr", &m.basis_table, MapEncoding::kFloat,
                "rbf basis B_j tabulated over the light disc (theta/90deg)(cos phi, sin phi), "
                "channel j, row y from -1 (first) to +1"});
  }
  void PackParameters(const MaterialMaps& m, std::map<std::string, double>* out) const override {
    if (m.basis_terms > 0) (*out)["basis_terms"] = m.basis_terms;
    if (m.basis_srgb) (*out)["basis_srgb"] = 1;
  }
  Status ReadPackMaps(const LoadPackMapFn& load, const std::map<std::string, double>& params,
                      MaterialMaps* m) const override {
    MATFIT_RETURN_IF_ERROR(load("coefficients", &m->coefficients));
    auto k = params.find("basis_terms");
    if (k == params.end())
      return DataError(std::string("model.parameters.basis_terms is missing for a ") + name() +
                       " pack");
    // Range first: converting NaN or a huge value to int is undefined.
    const double terms = k->second;
    if (!(std::isfinite(terms) && terms >= 1 && terms <= ModelLight::kMaxBasis &&
          terms == std::floor(terms)))
      return DataError(std::string("model.parameters.basis_terms is ") + std::to_string(terms) +
                       " for a " + name() + " pack; it must be a whole number from 1 to " +
                       std::to_string(ModelLight::kMaxBasis));
    m->basis_terms = int(terms);
    if (auto e = params.find("basis_srgb"); e != params.end()) {
      if (e->second != 0 && e->second != 1)
        return DataError("model.parameters.basis_srgb is " + std::to_string(e->second) +
                         "; it must be 1 (the basis sum is sRGB-encoded) or 0 (linear)");
      m->basis_srgb = e->second == 1;
    }
    const int order = int(std::lround(std::sqrt(double(m->basis_terms))));
    const bool integral = k->second == double(m->basis_terms);
    const bool valid =
        kPtm   ? m->basis_terms == shading::kPtmTerms
        : kRbf ? integral && m->basis_terms >= 1 && m->basis_terms <= ModelLight::kMaxBasis
               : integral && order >= 1 && order <= 4 && order * order == m->basis_terms;
    if (!valid)
      return DataError(std::string("model.parameters.basis_terms is ") + std::to_string(k->second) +
                       " for a " + name() + " pack; it must be " +
                       (kPtm   ? "6"
                        : kRbf ? "1 to 16"
                               : "1, 4, 9 or 16 (HSH order²)"));
    if (kRbf) {
      MATFIT_RETURN_IF_ERROR(load("basis_table", &m->basis_table));
      MATFIT_RETURN_IF_ERROR(load("interpolation_error", &m->interpolation_error));
      const Image& ie = m->interpolation_error;
      if (!ie.empty() && (ie.width() != m->coefficients.width() ||
                          ie.height() != m->coefficients.height() || ie.channels() != 1))
        return DataError("the rbf interpolation_error map is " + std::to_string(ie.width()) +
                         " x " + std::to_string(ie.height()) + " with " +
                         std::to_string(ie.channels()) +
                         " channel(s); it must be one channel the coefficients' size (" +
                         std::to_string(m->coefficients.width()) + " x " +
                         std::to_string(m->coefficients.height()) + ")");
      if (Status st = CheckTable(*m); !st.ok()) return st;
    }
    if (m->coefficients.width() != m->width || m->coefficients.height() != m->height)
      return DataError("the coefficients map is " + std::to_string(m->coefficients.width()) +
                       " x " + std::to_string(m->coefficients.height()) +
                       "; it must be the material's size (" + std::to_string(m->width) + " x " +
                       std::to_string(m->height) + ")");
    const int ch = m->coefficients.channels();
    if (ch != m->basis_terms && ch != 3 * m->basis_terms)
      return DataError("the coefficients map has " + std::to_string(ch) + " channel(s); a " +
                       name() + " pack with basis_terms " + std::to_string(m->basis_terms) +
                       " needs " + std::to_string(m->basis_terms) + " (grey) or " +
                       std::to_string(3 * m->basis_terms) + " (RGB)");
    return Status::Ok();
  }
  bool AddShaderPlanes(const MaterialMaps& m, ShaderPlaneSink* s) const override {
    if (kRbf) {
      if (!CheckTable(m).ok()) return false;
      s->basis_table = &m.basis_table;
    }
    s->terms = m.basis_terms;
    s->basis_srgb = m.basis_srgb;
    s->coef_channels = s->terms > 0 ? m.coefficients.channels() / s->terms : 0;
    if (s->terms < 1 || s->terms > 16 || (s->coef_channels != 1 && s->coef_channels != 3))
      return false;
    return s->Add(m.coefficients, s->terms * s->coef_channels, "coefficients");
  }
};

}  // namespace

const ModelDescriptor& PtmDescriptor() {
  static const BasisModel<BasisKind::kPtm> model;
  return model;
}
const ModelDescriptor& HshDescriptor() {
  static const BasisModel<BasisKind::kHsh> model;
  return model;
}
const ModelDescriptor& RbfDescriptor() {
  static const BasisModel<BasisKind::kRbf> model;
  return model;
}

}  // namespace matfit::model_impl
