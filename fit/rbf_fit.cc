// rbf (issue 19 item 5): a data-driven relighting basis interpolated over the light directions,
// the kind of model RTI tools ship as "RBF" (relight, OpenLIME). With y_t ∈ R^N the samples of one
// texel and channel over the N lights (p_i / I_i, or its sRGB encode for rbf-srgb):
//  1. PCA: E (N × K) = the K leading eigenvectors of Σ_t y_t y_tᵀ over sampled texels and
//     channels whose every sample is valid (uncentred: the mean is in the first component);
//  2. each column E_j is interpolated over the unit light directions l_i by Gaussian radial
//     functions plus a linear polynomial: B_j(l) = Σ_i α_ij φ(|l − l_i|) + β_0j + β_1j l_x
//     + β_2j l_y, φ(r) = exp(−r² / (2σ²)), from [Φ + λI, P; Pᵀ, 0] [α; β] = [E_j; 0]; σ and λ
//     minimise the leave-one-light-out error of that interpolation, Σ_j w_j Σ_i e_ij² with
//     e_ij = α_ij / (A⁻¹)_ii (Rippa 1999, "An algorithm for selecting a good value for the
//     parameter c in radial basis function interpolation") and w_j E_j's eigenvalue;
//  3. B is tabulated on a kRbfTableSize² grid (shading::RbfTableBasis) and the per-texel
//     coefficients fitted by least squares against the *tabulated* basis, exactly as ptm/hsh
//     (fit/linear_basis.h), so the fit, the CPU evaluators and the shaders use one function.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "core/color.h"
#include "core/parallel.h"
#include "core/shading/relight_basis.h"
#include "core/stack_band.h"
#include "fit/fit_common.h"
#include "fit/linear_basis.h"
#include "fit/methods.h"

namespace matfit::fit {
namespace {

// At most this many texels feed the PCA (a grid over the image): N² work each.
constexpr int64_t kMaxPcaTexels = 8192;

// The second-moment matrix of sampled texel-channel vectors y (N entries each, all valid).
// Returns the number of vectors used.
int64_t SampleMoments(const LightStack& s, bool srgb, Eigen::MatrixXd* moment) {
  const int N = s.num_images(), C = s.channels();
  // A grid over the whole stack; a band of a distributed stack takes its rows of it.
  const int64_t texels = s.full_plane_size();
  const int64_t band_first = int64_t(s.band.row0) * s.width(), own = s.texels();
  const int64_t stride = std::max<int64_t>(1, texels / kMaxPcaTexels);
  const std::vector<float> inv = InverseIntensities(s);
  const bool clip = StackMayBeClipped(s);
  const float* encode = SrgbCurves().encode;
  std::vector<int64_t> picks;
  for (int64_t g = stride / 2; g < texels; g += stride) {
    const int64_t p = g - band_first;
    if (p >= 0 && p < own && (!s.has_mask() || s.mask[size_t(p)])) picks.push_back(p);
  }
  // Per picked texel and channel: a usable flag (1 or 0) and y, N + 1 values. The bands' lists
  // are joined in grid order, so every rank sums the moment in the blocks and the order one
  // process does (a PCA of nearly equal eigenvalues turns with the last bits of the sum).
  const size_t width = size_t(N) + 1;
  std::vector<double> ys(picks.size() * C * width, 0.0);
  ParallelFor(0, int64_t(picks.size()), [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int c = 0; c < C; ++c) {
        double* y = ys.data() + (size_t(k) * C + c) * width;
        bool valid = true;
        double energy = 0;
        for (int i = 0; i < N && valid; ++i) {
          const float raw = s.Sample(i, c, picks[size_t(k)]);
          const float v = raw * inv[size_t(i) * C + c];
          valid = std::isfinite(v) && !(clip && raw >= kClipLevel);
          y[1 + i] = srgb ? SrgbCurveLookup(encode, v) : v, energy += y[1 + i] * y[1 + i];
        }
        y[0] = valid && energy > 0;
      }
  });
  ys = ConcatOverBands(s, ys);
  const int64_t count = int64_t(ys.size() / (C * width));  // picks over the whole stack
  // Per thread block: a partial moment, summed at the end.
  const int64_t blocks = std::min<int64_t>(count, 8);
  std::vector<Eigen::MatrixXd> part(size_t(std::max<int64_t>(blocks, 1)),
                                    Eigen::MatrixXd::Zero(N, N));
  std::vector<int64_t> used(part.size(), 0);
  // Vectors are gathered as the columns of Y (N × kBatch) and added as one blocked Y Yᵀ.
  constexpr int kBatch = 256;
  ParallelFor(0, blocks, [&](int64_t b0, int64_t b1) {
    Eigen::MatrixXd Y(N, kBatch);
    for (int64_t b = b0; b < b1; ++b) {
      const size_t first = size_t(b) * size_t(count) / size_t(blocks);
      const size_t last = size_t(b + 1) * size_t(count) / size_t(blocks);
      int cols = 0;
      auto flush = [&] {
        if (cols > 0) part[size_t(b)].selfadjointView<Eigen::Lower>().rankUpdate(Y.leftCols(cols));
        used[size_t(b)] += cols, cols = 0;
      };
      for (size_t k = first; k < last; ++k)
        for (int c = 0; c < C; ++c) {
          const double* y = ys.data() + (k * C + c) * width;
          if (y[0] == 0) continue;
          for (int i = 0; i < N; ++i) Y(i, cols) = y[1 + i];
          if (++cols == kBatch) flush();
        }
      flush();
    }
  });
  *moment = Eigen::MatrixXd::Zero(N, N);
  int64_t n = 0;
  for (size_t b = 0; b < part.size(); ++b) *moment += part[b], n += used[b];
  *moment = moment->selfadjointView<Eigen::Lower>();
  return n;
}

struct RbfInterpolant {
  double sigma = 0, lambda = 0, loo_error = std::numeric_limits<double>::infinity();
  Eigen::MatrixXd alpha;  // N × K
  Eigen::MatrixXd beta;   // 3 × K: 1, l_x, l_y
  Eigen::MatrixXd loo;    // N × K: e_ij, E_ij minus its interpolation from the other lights
};

// The augmented system A = [Φ + λI, P; Pᵀ, 0] for Gaussian width σ.
Eigen::MatrixXd AugmentedSystem(const std::vector<Vec3>& dirs, double sigma, double lambda) {
  const int N = int(dirs.size());
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(N + 3, N + 3);
  const double g = 1 / (2 * sigma * sigma);
  for (int i = 0; i < N; ++i) {
    for (int k = 0; k < N; ++k) A(i, k) = std::exp(-g * Dot(dirs[i] - dirs[k], dirs[i] - dirs[k]));
    A(i, i) += lambda;
    const double p[3] = {1, dirs[i].x, dirs[i].y};
    for (int q = 0; q < 3; ++q) A(i, N + q) = A(N + q, i) = p[q];
  }
  return A;
}

// σ over multiples of the median nearest-neighbour distance between lights, λ over a few
// decades; the pair with the smallest energy-weighted leave-one-out error.
StatusOr<RbfInterpolant> ChooseInterpolant(const std::vector<Vec3>& dirs, const Eigen::MatrixXd& E,
                                           const Eigen::VectorXd& weight) {
  const int N = int(dirs.size()), K = int(E.cols());
  std::vector<double> nearest(size_t(N), std::numeric_limits<double>::infinity());
  for (int i = 0; i < N; ++i)
    for (int k = 0; k < N; ++k)
      if (k != i) nearest[size_t(i)] = std::min(nearest[size_t(i)], Length(dirs[i] - dirs[k]));
  std::nth_element(nearest.begin(), nearest.begin() + N / 2, nearest.end());
  const double spacing = nearest[size_t(N / 2)];
  if (!(spacing > 1e-6) || !std::isfinite(spacing))
    return InvalidArgument("rbf: two or more lights share one direction (nearest-light spacing " +
                           std::to_string(spacing) +
                           "); merge repeated directions or use a basis model (ptm, hsh2)");
  const double sigmas[] = {0.5, 0.75, 1.0, 1.5, 2.0, 3.0};
  const double lambdas[] = {1e-6, 1e-3, 1e-2, 1e-1};
  constexpr int kS = int(std::size(sigmas)), kL = int(std::size(lambdas));
  std::vector<RbfInterpolant> tried(size_t(kS * kL));
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(N + 3, K);
  rhs.topRows(N) = E;
  ParallelFor(0, kS * kL, [&](int64_t c0, int64_t c1) {
    for (int64_t c = c0; c < c1; ++c) {
      RbfInterpolant& r = tried[size_t(c)];
      r.sigma = sigmas[c / kL] * spacing, r.lambda = lambdas[c % kL];
      const Eigen::MatrixXd A = AugmentedSystem(dirs, r.sigma, r.lambda);
      const Eigen::PartialPivLU<Eigen::MatrixXd> lu(A);
      const Eigen::MatrixXd Ainv = lu.inverse();
      const Eigen::MatrixXd coef = Ainv * rhs;
      if (!Ainv.allFinite() || !coef.allFinite()) continue;
      double err = 0;
      Eigen::MatrixXd loo(N, K);
      for (int i = 0; i < N; ++i) {
        const double d = Ainv(i, i);
        if (!(std::abs(d) > 1e-300)) err = std::numeric_limits<double>::infinity();
        for (int j = 0; j < K; ++j)
          loo(i, j) = coef(i, j) / d, err += weight[j] * loo(i, j) * loo(i, j);
      }
      if (!std::isfinite(err)) continue;
      r.loo_error = err, r.alpha = coef.topRows(N), r.beta = coef.bottomRows(3);
      r.loo = std::move(loo);
    }
  });
  const auto best = std::min_element(tried.begin(), tried.end(), [](const auto& a, const auto& b) {
    return a.loo_error < b.loo_error;
  });
  if (!std::isfinite(best->loo_error))
    return InvalidArgument(
        "rbf: the light directions do not determine the interpolation (every light on one line "
        "of the light disc?); use lights spread in azimuth or the lambert model");
  return *best;
}

// B_j at every node of the G × G table (RbfTableBasis's grid; nodes outside the horizon take
// the horizon's value, as lookups there clamp to it).
Image Tabulate(const std::vector<Vec3>& dirs, const RbfInterpolant& f, int G) {
  const int N = int(dirs.size()), K = int(f.alpha.cols());
  Image table(G, G, K);
  const double g = 1 / (2 * f.sigma * f.sigma);
  ParallelFor(0, G, [&](int64_t j0, int64_t j1) {
    std::vector<double> kernel(static_cast<size_t>(N));
    for (int64_t j = j0; j < j1; ++j)
      for (int i = 0; i < G; ++i) {
        double x = -1 + 2.0 * i / (G - 1), y = -1 + 2.0 * double(j) / (G - 1);
        double rho = std::hypot(x, y);
        if (rho > 1) x /= rho, y /= rho, rho = 1;
        const double theta = rho * std::numbers::pi / 2, phi_az = std::atan2(y, x);
        const Vec3 l(std::sin(theta) * std::cos(phi_az), std::sin(theta) * std::sin(phi_az),
                     std::cos(theta));
        for (int k = 0; k < N; ++k)
          kernel[size_t(k)] = std::exp(-g * Dot(l - dirs[k], l - dirs[k]));
        for (int q = 0; q < K; ++q) {
          double v = f.beta(0, q) + f.beta(1, q) * l.x + f.beta(2, q) * l.y;
          for (int k = 0; k < N; ++k) v += f.alpha(k, q) * kernel[size_t(k)];
          table.Plane(q)[j * G + i] = float(v);
        }
      }
  });
  return table;
}

// Per texel, the RMS over lights and channels of the change in its prediction at each light
// when that light's basis values are the interpolation from the other lights (B_ij − e_ij
// instead of B_ij), in linear radiance per unit light: how far the texel's relighting can be
// off between its samples, which its residuals at the samples do not show (ComputeConfidence
// floors the residual RMS with it). Linear domain: (1 / NC) Σ_c a_cᵀ (eᵀe) a_c; sRGB domain:
// the decoded difference light by light, over ≤ 64 of the lights.
Image InterpolationError(const LightStack& s, const Image& table, const Eigen::MatrixXd& e,
                         bool srgb, const FitResult& r) {
  const int N = int(e.rows()), K = int(e.cols()), C = r.maps.coefficients.channels() / K;
  Image out(s.width(), s.height(), 1, 0.0f);
  // sRGB domain: the RMS over at most 64 lights spread through the list (one decode pair each).
  const int stride = (N + 63) / 64, M = (N + stride - 1) / stride;
  Eigen::MatrixXf B(M, K), Bloo(M, K);
  for (int m = 0; m < M; ++m) {
    const int i = m * stride;
    double b[shading::kMaxHshTerms];
    shading::RbfTableBasis(table.data().data(), table.width(), K,
                           Normalize(s.lights()[i].direction), b);
    for (int j = 0; j < K; ++j) B(m, j) = float(b[j]), Bloo(m, j) = float(b[j] - e(i, j));
  }
  const Eigen::MatrixXf gram = (e.transpose() * e).cast<float>() / float(N);
  const float* decode = SrgbCurves().decode;
  ParallelFor(
      0, s.texels(),
      [&](int64_t p0, int64_t p1) {
        Eigen::VectorXf a(K), pred(M), pred_loo(M);
        for (int64_t p = p0; p < p1; ++p) {
          if (r.status[size_t(p)] != kTexelOk) continue;
          double sum = 0;
          for (int c = 0; c < C; ++c) {
            for (int j = 0; j < K; ++j) a[j] = r.maps.coefficients.Plane(c * K + j)[p];
            if (!srgb) {
              sum += double(a.dot(gram * a));
              continue;
            }
            pred.noalias() = B * a, pred_loo.noalias() = Bloo * a;
            double ss = 0;
            for (int i = 0; i < M; ++i) {
              const float d =
                  SrgbCurveLookup(decode, pred[i]) - SrgbCurveLookup(decode, pred_loo[i]);
              ss += double(d) * d;
            }
            sum += ss / M;
          }
          out.Plane(0)[p] = float(std::sqrt(sum / C));
        }
      },
      1024);
  return out;
}

}  // namespace

StatusOr<FitResult> FitRbf(const LightStack& s, const FitOptions& o, bool srgb) {
  const std::string name = srgb ? "rbf-srgb" : "rbf";
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  // K components, fewer when the lights cannot carry them: beside the interpolation's linear part
  // (3 terms), K ≤ N − 3, and two lights per component, K ≤ N / 2 (psm, 12 lights, leave-one-out:
  // held-out RMSE 0.0355 → 0.0310 on gray, 0.0407 → 0.0363 on the cat against K = N − 3).
  // Lights below the surface plane (a leaf lit from behind) have no place on the table's disc
  // (lookups there clamp to the horizon): they are not interpolation nodes.
  std::vector<int> above;
  std::vector<Vec3> dirs;
  for (int i = 0; i < s.num_images(); ++i)
    if (const Vec3 d = Normalize(s.lights()[size_t(i)].direction); d.z > 1e-6)
      above.push_back(i), dirs.push_back(d);
  const int N = int(above.size()), K = std::min(kRbfComponents, std::min(N - 3, N / 2));
  if (K < 1)
    return InvalidArgument(name + ": " + std::to_string(N) +
                           " light(s) above the surface; the interpolation needs at least 4 light "
                           "directions there (capture more lights or use lambert)");
  Eigen::MatrixXd moment;
  const int64_t vectors = SampleMoments(s, srgb, &moment);
  if (vectors < K)
    return InvalidArgument(name + ": only " + std::to_string(vectors) +
                           " texel channel(s) have every sample finite, unclipped and non-zero; "
                           "the basis needs at least " +
                           std::to_string(K) + " (is the mask or the exposure right?)");
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(moment);
  if (eig.info() != Eigen::Success)
    return InvalidArgument(name + ": the PCA of the samples did not converge (non-finite values?)");
  // Eigenvalues ascend: the K leading ones are the last columns.
  const Eigen::MatrixXd E = eig.eigenvectors().rightCols(K).rowwise().reverse();
  const Eigen::VectorXd weight = eig.eigenvalues().tail(K).reverse().cwiseMax(0.0);
  Eigen::MatrixXd E_above(N, K);
  for (int k = 0; k < N; ++k) E_above.row(k) = E.row(above[size_t(k)]);
  auto f = ChooseInterpolant(dirs, E_above, weight);
  if (!f.ok()) return f.status();
  const Image table = Tabulate(dirs, *f, kRbfTableSize);
  auto r = FitLinearBasis(
      s, o, name, "rbf", K,
      [&table, K](const Vec3& l, double* b) {
        shading::RbfTableBasis(table.data().data(), kRbfTableSize, K, l, b);
      },
      srgb);
  if (!r.ok()) return r.status();
  r->maps.basis_table = table;
  Eigen::MatrixXd loo = Eigen::MatrixXd::Zero(s.num_images(), K);  // 0: not a node
  for (int k = 0; k < N; ++k) loo.row(above[size_t(k)]) = f->loo.row(k);
  r->maps.interpolation_error = InterpolationError(s, table, loo, srgb, *r);
  r->parameters["rbf_sigma"] = f->sigma;
  r->parameters["rbf_lambda"] = f->lambda;
  r->parameters["rbf_pca_vectors"] = double(vectors);
  const double total = eig.eigenvalues().cwiseMax(0.0).sum();
  r->parameters["rbf_pca_energy"] = total > 0 ? weight.sum() / total : 1.0;
  return r;
}

}  // namespace matfit::fit
