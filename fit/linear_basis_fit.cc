// Relighting bases fitted like Lambert: `ptm` (6 polynomial terms) and `hsh2`/`hsh3`
// (hemispherical harmonics, 4 / 9 terms). The N × k basis matrix B is the same for every texel,
// so one pseudo-inverse (B⁺, k × N) serves all of them: coefficients = B⁺ · p per channel.
// A texel with a clipped or non-finite sample is fitted again from its valid lights V alone
// (fit/valid_refit.h): coefficients = (B_Vᵀ B_V)⁻¹ B_Vᵀ p_V, when B_V still has rank k.
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <vector>

#include "core/color.h"
#include "core/shading/relight_basis.h"
#include "fit/fit_common.h"
#include "fit/linear_basis.h"
#include "fit/methods.h"
#include "fit/row_kernels.h"
#include "fit/valid_refit.h"

namespace matfit::fit {
namespace {

// B(i, j) = basis_j(l_i): the N × k basis matrix over the lights.
Eigen::MatrixXd BasisMatrix(const std::vector<LightSample>& lights, int K, const BasisFn& basis) {
  Eigen::MatrixXd B(int(lights.size()), K);
  for (size_t i = 0; i < lights.size(); ++i) {
    double b[shading::kMaxHshTerms];
    basis(lights[i].direction, b);
    for (int j = 0; j < K; ++j) B(int(i), j) = b[j];
  }
  return B;
}

// Coefficients of one texel from its valid lights: normal equations G = B_Vᵀ B_V (k × k),
// refused when λ_min(G) / λ_max(G) ≤ 1e-12 (σ_min / σ_max of B_V ≤ 1e-6, the whole-set test).
// srgb: the observations are sRGB-encoded before the fit and the preview albedo decoded.
uint8_t BasisSubsetFit(const TexelSamples& t, const Eigen::MatrixXd& B, const double* front,
                       bool srgb, FitResult* r) {
  const int K = int(B.cols()), C = t.channels;
  if (t.valid_count < K) return kTexelTooFewLights;
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(K, K), rhs = Eigen::MatrixXd::Zero(K, C);
  for (int i = 0; i < t.n; ++i) {
    if (!t.valid[i]) continue;
    const auto b = B.row(i).transpose();
    G.selfadjointView<Eigen::Lower>().rankUpdate(b);
    for (int c = 0; c < C; ++c)
      rhs.col(c) +=
          b * (srgb ? double(SrgbCurveLookup(SrgbCurves().encode, float(t.obs[i * C + c])))
                    : t.obs[i * C + c]);
  }
  G = G.selfadjointView<Eigen::Lower>();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(G);
  const auto& ev = eig.eigenvalues();  // ascending
  if (!(ev[K - 1] > 0 && ev[0] > 1e-12 * ev[K - 1])) return kTexelIllConditioned;
  const Eigen::MatrixXd X = eig.eigenvectors() * (eig.eigenvalues().cwiseInverse().asDiagonal() *
                                                  (eig.eigenvectors().transpose() * rhs));  // K × C
  if (!X.allFinite()) return kTexelNonFinite;
  for (int c = 0; c < C; ++c)
    for (int j = 0; j < K; ++j) r->maps.coefficients.Plane(c * K + j)[t.p] = float(X(j, c));
  for (int c = 0; c < 3; ++c) {
    double v = 0;
    for (int j = 0; j < K; ++j) v += front[j] * X(j, C == 1 ? 0 : c);
    r->maps.albedo.Plane(c)[t.p] = srgb ? SrgbCurveLookup(SrgbCurves().decode, float(v)) : float(v);
  }
  r->maps.normal.Plane(2)[t.p] = 1.0f;
  return kTexelOk;
}

}  // namespace

StatusOr<FitResult> FitLinearBasis(const LightStack& s, const FitOptions& o,
                                   const std::string& name, std::string_view model, int K,
                                   const BasisFn& basis, bool srgb) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  const int n = s.num_images(), C = s.channels(), W = s.width();
  if (n < K)
    return InvalidArgument(name + ": " + std::to_string(n) + " light(s) for " + std::to_string(K) +
                           " coefficients per channel; capture at least " + std::to_string(K) +
                           " light directions or use a smaller basis");
  const Eigen::MatrixXd B = BasisMatrix(s.lights(), K, basis);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(B, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const auto sv = svd.singularValues();
  if (!(sv[K - 1] > 1e-6 * sv[0]))
    return InvalidArgument(name + ": the light directions do not determine the " +
                           std::to_string(K) + " basis terms (basis matrix rank < " +
                           std::to_string(K) +
                           ", e.g. every light at one elevation); use lights at several θ or the "
                           "lambert model");
  const Eigen::MatrixXd P = svd.solve(Eigen::MatrixXd::Identity(n, n));  // K × n
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitResult(s, model, name, &r);
  r.maps.coefficients = Image(s.width(), s.height(), K * C);
  r.maps.basis_terms = K;
  r.maps.basis_srgb = srgb;
  r.parameters["basis_condition_number"] = sv[0] / sv[K - 1];
  const std::vector<float> inv = InverseIntensities(s);
  std::vector<float> pinv(size_t(K) * n);
  for (int j = 0; j < K; ++j)
    for (int i = 0; i < n; ++i) pinv[size_t(j) * n + i] = float(P(j, i));
  // The frontal-light value of the basis, as a preview albedo.
  double front[shading::kMaxHshTerms];
  basis(Vec3(0, 0, 1), front);

  const bool clip = StackMayBeClipped(s);
  // srgb on an integer stack under unit intensities: each sample's encode depends on its code
  // alone, so one table per code (enc[code] = encode(lut[code]); for an 8-bit sRGB file, code /
  // 255 up to the curve table's 2e-5) replaces the decode, scale and encode per sample.
  bool unit = true;
  for (float v : inv) unit &= v == 1.0f;
  std::vector<float> code_enc;
  if (srgb && unit && !s.is_float()) {
    code_enc.resize(s.lut().size());
    for (size_t k = 0; k < code_enc.size(); ++k)
      code_enc[k] = SrgbCurveLookup(SrgbCurves().encode, s.lut()[k]);
  }
  // Per strip: coefficients_c = B⁺ · p_c, one row-kernel call per plane segment, accumulated
  // straight into the (zero-initialised) coefficient planes; the per-texel work after it runs
  // plane by plane over the strip, contiguously.
  const bool ok = ForEachTile(s, o, [&](const Tile& t) {
    const int64_t first = int64_t(t.y0) * W, m = t.texels();
    std::vector<float> peak(m, 0.0f);
    float* ap[kMaxRowTerms];
    StripReader reader(s);
    float w[kMaxRowPlanes * kMaxRowTerms];
    // srgb: the group's rows encoded (v · 1/I, clamped) into `enc`; the peak stays the raw one.
    std::vector<float> enc(srgb ? size_t(kMaxRowPlanes) * StripReader::kChunk : 0);
    std::vector<float> enc_peak(srgb ? StripReader::kChunk : 0);
    const float* encode = SrgbCurves().encode;
    auto coef = [&](int q) { return r.maps.coefficients.Plane(q).data() + first; };
    for (int c = 0; c < C; ++c) {
      for (int j = 0; j < K; ++j) ap[j] = coef(c * K + j);
      for (int i0 = 0; i0 < n; i0 += kMaxRowPlanes) {
        const int planes = std::min(kMaxRowPlanes, n - i0);
        for (int q = 0; q < planes; ++q) {
          const int i = i0 + q;
          for (int j = 0; j < K; ++j)
            w[q * K + j] = pinv[size_t(j) * n + i] * (srgb ? 1.0f : inv[i * C + c]);
        }
        if (!code_enc.empty()) {  // the code-table path: no decoded value is formed
          auto run = [&](auto tag) {
            using T = decltype(tag);
            const T* codes[kMaxRowPlanes];
            for (int q = 0; q < planes; ++q) codes[q] = s.Codes<T>(i0 + q, c).data() + first;
            const float* lut = s.lut().data();
            for (int64_t x0 = 0; x0 < m; x0 += StripReader::kChunk) {
              const int64_t l = std::min<int64_t>(StripReader::kChunk, m - x0);
              const float* e[kMaxRowPlanes];
              float* pk = peak.data() + x0;
              for (int q = 0; q < planes; ++q) {
                const T* cq = codes[q] + x0;
                float* out = enc.data() + size_t(q) * StripReader::kChunk;
                for (int64_t u = 0; u < l; ++u)
                  out[u] = code_enc[cq[u]], pk[u] = std::max(pk[u], lut[cq[u]]);
                e[q] = out;
              }
              float* a[kMaxRowTerms];
              for (int j = 0; j < K; ++j) a[j] = ap[j] + x0;
              RowAccumulate(e, planes, l, K, w, a, enc_peak.data());
            }
          };
          if (s.sample_type() == SampleType::kUint8)
            run(uint8_t{});
          else
            run(uint16_t{});
          continue;
        }
        reader.Group(i0, planes, c, first, m, [&](const float* const* src, int64_t x, int64_t len) {
          float* a[kMaxRowTerms];
          for (int j = 0; j < K; ++j) a[j] = ap[j] + x;
          if (!srgb) return RowAccumulate(src, planes, len, K, w, a, peak.data() + x);
          // In chunks of the reader's size (a float stack hands over the whole strip).
          for (int64_t x0 = 0; x0 < len; x0 += StripReader::kChunk) {
            const int64_t l = std::min<int64_t>(StripReader::kChunk, len - x0);
            const float* e[kMaxRowPlanes];
            float* pk = peak.data() + x + x0;
            for (int q = 0; q < planes; ++q) {
              const float* v = src[q] + x0;
              float* out = enc.data() + size_t(q) * StripReader::kChunk;
              const float scale = inv[(i0 + q) * C + c];
              for (int64_t u = 0; u < l; ++u) {
                pk[u] = std::max(pk[u], v[u]);  // NaN is caught by the finite check below
                const float y = v[u] * scale;   // a lost sample stays lost (NaN/Inf flags it)
                out[u] = std::isfinite(y) ? SrgbCurveLookup(encode, y) : y;
              }
              e[q] = out;
            }
            for (int j = 0; j < K; ++j) a[j] = ap[j] + x + x0;
            RowAccumulate(e, planes, l, K, w, a, enc_peak.data());
          }
        });
      }
    }
    uint8_t* status = r.status.data() + first;
    ApplyPeakStatus(peak.data(), first, m, clip, r.status.data());
    // Texels masked or flagged so far get no coefficients; the others are flagged when a
    // coefficient is not finite (Σ 0·c is 0 only when every c is finite) but keep their maps.
    // The preview albedo is the frontal-light value Σ_j front_j c_j. Contiguous float loops.
    std::vector<float> check(m, 0.0f), value(size_t(C) * m, 0.0f);
    for (int c = 0; c < C; ++c)
      for (int j = 0; j < K; ++j) {
        const float* cq = coef(c * K + j);
        const float fj = float(front[j]);
        float* v = value.data() + size_t(c) * m;
        for (int64_t k = 0; k < m; ++k) check[k] += 0.0f * cq[k], v[k] += fj * cq[k];
      }
    bool all_fitted = true;
    for (int64_t k = 0; k < m; ++k) all_fitted &= status[k] == kTexelOk;
    std::vector<uint8_t> fitted(m, 1);
    if (!all_fitted) {
      for (int64_t k = 0; k < m; ++k) fitted[k] = status[k] == kTexelOk;
      for (int q = 0; q < K * C; ++q) {
        float* cq = coef(q);
        for (int64_t k = 0; k < m; ++k)
          if (!fitted[k]) cq[k] = 0.0f;
      }
    }
    for (int64_t k = 0; k < m; ++k)
      if (fitted[k] && check[k] != 0.0f) status[k] = kTexelNonFinite;  // NaN compares unequal
    float* nz = r.maps.normal.Plane(2).data() + first;
    for (int c = 0; c < 3; ++c) {
      const float* v = value.data() + size_t(C == 1 ? 0 : c) * m;
      float* albedo = r.maps.albedo.Plane(c).data() + first;
      const float* decode = SrgbCurves().decode;
      for (int64_t k = 0; k < m; ++k)
        if (fitted[k]) albedo[k] = srgb ? SrgbCurveLookup(decode, v[k]) : v[k], nz[k] = 1.0f;
    }
  });
  if (ok)
    RefitFromValidSamples(
        s, {},
        [&](const TexelSamples& t, FitResult* out) {
          return BasisSubsetFit(t, B, front, srgb, out);
        },
        &r);
  return FinishFit(ok, t0, std::move(r));
}

double RelightBasisCondition(const std::vector<LightSample>& lights, std::string method) {
  if (method.size() > 5 && method.ends_with("-srgb")) method.resize(method.size() - 5);
  int K = 0;
  BasisFn basis;
  if (method == "ptm") {
    K = shading::kPtmTerms, basis = [](const Vec3& l, double* b) { shading::PtmBasis(l, b); };
  } else if (method.size() == 4 && method.rfind("hsh", 0) == 0 && method[3] >= '1' &&
             method[3] <= '4') {
    const int order = method[3] - '0';
    K = order * order;
    basis = [order](const Vec3& l, double* b) { shading::HshBasis(order, l, b); };
  } else {
    return 0;
  }
  const int n = int(lights.size());
  if (n < K) return std::numeric_limits<double>::infinity();
  const auto sv = Eigen::JacobiSVD<Eigen::MatrixXd>(BasisMatrix(lights, K, basis)).singularValues();
  return sv[K - 1] > 0 ? sv[0] / sv[K - 1] : std::numeric_limits<double>::infinity();
}

StatusOr<FitResult> FitPtm(const LightStack& s, const FitOptions& o, bool srgb) {
  return FitLinearBasis(
      s, o, srgb ? "ptm-srgb" : "ptm", "ptm", shading::kPtmTerms,
      [](const Vec3& l, double* b) { shading::PtmBasis(l, b); }, srgb);
}

StatusOr<FitResult> FitHsh(const LightStack& s, const FitOptions& o, int order, bool srgb) {
  if (order < 1 || order > 4)
    return InvalidArgument("hsh order must be 1 to 4, got " + std::to_string(order));
  return FitLinearBasis(
      s, o, "hsh" + std::to_string(order) + (srgb ? "-srgb" : ""), "hsh", order * order,
      [order](const Vec3& l, double* b) { shading::HshBasis(order, l, b); }, srgb);
}

}  // namespace matfit::fit
