#include "fit/per_view_pca.h"

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>

#include "core/parallel.h"
#include "fit/fit_common.h"

namespace matfit::fit {

namespace {

constexpr int kRun = 256;  // texels per work unit

// Texels [p0, p0 + len) of view `g` as columns of x (D = |g| · C rows, intensity-normalised),
// image a's channel c in row a·C + c.
void LoadViewRun(const LightStack& s, const std::vector<int>& g, const std::vector<float>& inv,
                 int64_t p0, int len, Eigen::MatrixXd* x, std::vector<float>* scratch) {
  const int C = s.channels();
  for (size_t a = 0; a < g.size(); ++a)
    for (int c = 0; c < C; ++c) {
      const float* row = s.Texels(g[a], c, p0, len, scratch->data());
      const double in = inv[size_t(g[a]) * C + c];
      for (int t = 0; t < len; ++t) (*x)(int(a) * C + c, t) = double(row[t]) * in;
    }
}

// One view's PCA: the mean and covariance of its texels' sample vectors (texels with status ≠ 0
// or a non-finite sample left out), eigenpairs ascending. Parallel over texels, double sums.
struct ViewPca {
  Eigen::VectorXd mean, lambda;
  Eigen::MatrixXd basis;  // eigenvectors as columns, ascending eigenvalue
  double n = 0;           // texels used
};

ViewPca FitViewPca(const LightStack& s, const std::vector<int>& g, const std::vector<float>& inv,
                   const std::vector<uint8_t>& status, bool vectors) {
  const int D = int(g.size()) * s.channels();
  const int64_t T = s.plane_size();
  Eigen::MatrixXd cross = Eigen::MatrixXd::Zero(D, D);
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(D);
  ViewPca v;
  std::mutex merge;
  ParallelFor(0, (T + kRun - 1) / kRun, [&](int64_t r0, int64_t r1) {
    Eigen::MatrixXd x(D, kRun), part_cross = Eigen::MatrixXd::Zero(D, D);
    Eigen::VectorXd part_sum = Eigen::VectorXd::Zero(D);
    std::vector<float> scratch(kRun);
    double part_n = 0;
    for (int64_t r = r0; r < r1; ++r) {
      const int64_t p0 = r * kRun;
      const int len = int(std::min<int64_t>(kRun, T - p0));
      LoadViewRun(s, g, inv, p0, len, &x, &scratch);
      int kept = 0;  // texels to use, packed to the front
      for (int t = 0; t < len; ++t) {
        if (!status.empty() && status[size_t(p0 + t)] != 0) continue;
        if (!x.col(t).allFinite()) continue;
        if (kept != t) x.col(kept) = x.col(t);
        ++kept;
      }
      if (kept == 0) continue;
      const auto used = x.leftCols(kept);
      part_cross.selfadjointView<Eigen::Lower>().rankUpdate(used);
      part_sum += used.rowwise().sum();
      part_n += kept;
    }
    std::lock_guard<std::mutex> lock(merge);
    cross += part_cross, sum += part_sum, v.n += part_n;
  });
  if (v.n < 2) return v;
  // Covariance (lower triangle filled by rankUpdate), its eigenpairs ascending.
  v.mean = sum / v.n;
  Eigen::MatrixXd cov = cross.selfadjointView<Eigen::Lower>();
  cov = cov / v.n - v.mean * v.mean.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(
      cov, vectors ? Eigen::ComputeEigenvectors : Eigen::EigenvaluesOnly);
  v.lambda = eig.eigenvalues();
  if (vectors) v.basis = eig.eigenvectors();
  return v;
}

// Per texel: k half floats per view; shared: each view's mean and k basis vectors (floats).
double PcaBytesPerTexel(double weights, double shared, int64_t texels) {
  return 2 * weights + 4 * shared / double(std::max<int64_t>(1, texels));
}

}  // namespace

std::vector<PcaPoint> PerViewPcaCurve(const LightStack& s, const std::vector<int>& ks,
                                      const std::vector<uint8_t>& status,
                                      const ProgressFn& progress) {
  const auto groups = ViewGroups(s);
  const int C = s.channels();
  const std::vector<float> inv = InverseIntensities(s);
  std::vector<double> residual(ks.size(), 0.0);  // Σ over views of n · Σ_{j>k} λ_j
  double samples = 0;                            // Σ n·D
  std::vector<double> weights(ks.size(), 0.0);   // Σ over views of min(k, D): weights per texel
  std::vector<double> shared(ks.size(), 0.0);    // Σ over views of D (1 + min(k, D)): floats
  int views_done = 0;
  for (const std::vector<int>& g : groups) {
    if (progress) progress(views_done++, int64_t(groups.size()));
    const int D = int(g.size()) * C;
    const ViewPca v = FitViewPca(s, g, inv, status, false);
    if (v.n < 2) continue;
    for (size_t q = 0; q < ks.size(); ++q) {
      const int k = std::clamp(ks[q], 0, D);
      double rest = 0;  // the D − k smallest
      for (int j = 0; j < D - k; ++j) rest += std::max(0.0, v.lambda[j]);
      residual[q] += v.n * rest;
      weights[q] += k;
      shared[q] += double(D) * (1 + k);  // the view's mean and k basis vectors
    }
    samples += v.n * D;
  }
  std::vector<PcaPoint> out;
  for (size_t q = 0; q < ks.size(); ++q) {
    PcaPoint pt;
    pt.k = ks[q];
    pt.bytes_per_texel = PcaBytesPerTexel(weights[q], shared[q], s.plane_size());
    pt.rmse = samples > 0 ? std::sqrt(residual[q] / samples) : 0;
    out.push_back(pt);
  }
  return out;
}

std::vector<ViewPcaModel> PerViewPcaModels(const LightStack& s, int k_asked,
                                           const std::vector<uint8_t>& status,
                                           const ProgressFn& progress) {
  const auto groups = ViewGroups(s);
  const int C = s.channels(), W = s.width(), H = s.height();
  const int64_t T = s.plane_size();
  const std::vector<float> inv = InverseIntensities(s);
  std::vector<ViewPcaModel> out;
  int done = 0;
  for (const std::vector<int>& g : groups) {
    if (progress) progress(done++, int64_t(groups.size()));
    const int D = int(g.size()) * C, k = std::clamp(k_asked, 1, D);
    ViewPcaModel m;
    const LightSample& l = s.lights()[size_t(g[0])];
    m.theta_deg = l.has_view ? l.view_theta_deg : s.view_theta_deg;
    m.phi_deg = l.has_view ? l.view_phi_deg : s.view_phi_deg;
    m.images = g;
    m.weights = Image(W, H, k);
    m.basis = Image(D, k + 1, 1);
    const ViewPca pca = FitViewPca(s, g, inv, status, true);
    if (pca.n >= 2) {
      const auto b = pca.basis.rightCols(k);  // ascending: the k largest are the last
      for (int r = 0; r < D; ++r) {
        m.basis.Plane(0)[r] = float(pca.mean[r]);
        for (int j = 0; j < k; ++j)
          m.basis.Plane(0)[int64_t(j + 1) * D + r] = float(b(r, k - 1 - j));
      }
      ParallelFor(0, (T + kRun - 1) / kRun, [&](int64_t r0, int64_t r1) {
        Eigen::MatrixXd x(D, kRun);
        std::vector<float> scratch(kRun);
        for (int64_t r = r0; r < r1; ++r) {
          const int64_t p0 = r * kRun;
          const int len = int(std::min<int64_t>(kRun, T - p0));
          LoadViewRun(s, g, inv, p0, len, &x, &scratch);
          for (int t = 0; t < len; ++t) {
            if (!status.empty() && status[size_t(p0 + t)] != 0) continue;
            if (!x.col(t).allFinite()) continue;
            const Eigen::VectorXd w = b.transpose() * (x.col(t) - pca.mean);
            for (int j = 0; j < k; ++j) m.weights.Plane(j)[p0 + t] = float(w[k - 1 - j]);
          }
        }
      });
    }
    out.push_back(std::move(m));
  }
  return out;
}

std::vector<PcaPoint> PerViewPcaHeldOutViews(const LightStack& s, const std::vector<int>& held,
                                             const std::vector<int>& ks,
                                             const std::vector<uint8_t>& status,
                                             const ProgressFn& progress) {
  const auto groups = ViewGroups(s);
  const int C = s.channels(), G = int(groups.size());
  const int64_t T = s.plane_size();
  const std::vector<float> inv = InverseIntensities(s);
  const float clip = StackMayBeClipped(s) ? kClipLevel : std::numeric_limits<float>::infinity();
  std::vector<char> is_held(size_t(G), 0);
  for (int h : held) is_held[size_t(h)] = 1;
  std::vector<double> weights(ks.size(), 0.0), shared(ks.size(), 0.0);
  for (int g = 0; g < G; ++g)  // what the training views' PCA stores
    if (!is_held[size_t(g)])
      for (size_t q = 0; q < ks.size(); ++q) {
        const int D = int(groups[size_t(g)].size()) * C, k = std::clamp(ks[q], 0, D);
        weights[q] += k, shared[q] += double(D) * (1 + k);
      }
  std::vector<double> sse(ks.size(), 0.0);
  double samples = 0;
  // Per k and texel: Σ e² and the sample count over the held-out views (each texel is one
  // thread's in a view's pass).
  std::vector<std::vector<double>> texel_sse(ks.size(), std::vector<double>(size_t(T), 0.0));
  std::vector<double> texel_n(size_t(T), 0.0);
  // Per k and θv group (15°): Σ e² and samples.
  std::vector<std::map<int, std::pair<double, double>>> by_view(ks.size());
  std::map<int, ViewPca> pcas;  // training view → its PCA (with vectors), made when first needed
  int done = 0;
  for (int h : held) {
    if (progress) progress(done++, int64_t(held.size()));
    // The nearest training view (largest cosine) and, per held-out image, its nearest light.
    const Vec3 vh = s.ViewOf(groups[size_t(h)][0]);
    int t = -1;
    for (int g = 0; g < G; ++g)
      if (!is_held[size_t(g)] && (t < 0 || Dot(s.ViewOf(groups[size_t(g)][0]), vh) >
                                               Dot(s.ViewOf(groups[size_t(t)][0]), vh) + 1e-12))
        t = g;
    if (t < 0) break;
    const std::vector<int>& gt = groups[size_t(t)];
    const std::vector<int>& gh = groups[size_t(h)];
    std::vector<int> row_of(gh.size());  // held image → image index within gt
    for (size_t a = 0; a < gh.size(); ++a) {
      const Vec3& l = s.lights()[size_t(gh[a])].direction;
      size_t best = 0;
      for (size_t b = 1; b < gt.size(); ++b)
        if (Dot(s.lights()[size_t(gt[b])].direction, l) >
            Dot(s.lights()[size_t(gt[best])].direction, l))
          best = b;
      row_of[a] = int(best);
    }
    auto it = pcas.find(t);
    if (it == pcas.end()) it = pcas.emplace(t, FitViewPca(s, gt, inv, status, true)).first;
    const ViewPca& pca = it->second;
    if (pca.n < 2) continue;
    const int D = int(gt.size()) * C, Dh = int(gh.size()) * C;
    std::mutex merge;
    ParallelFor(0, (T + kRun - 1) / kRun, [&](int64_t r0, int64_t r1) {
      Eigen::MatrixXd x(D, kRun), y(Dh, kRun);
      std::vector<float> scratch(kRun);
      std::vector<double> part(ks.size(), 0.0);
      double part_n = 0;
      for (int64_t r = r0; r < r1; ++r) {
        const int64_t p0 = r * kRun;
        const int len = int(std::min<int64_t>(kRun, T - p0));
        LoadViewRun(s, gt, inv, p0, len, &x, &scratch);
        LoadViewRun(s, gh, inv, p0, len, &y, &scratch);
        for (int tx = 0; tx < len; ++tx) {
          if (!status.empty() && status[size_t(p0 + tx)] != 0) continue;
          if (!x.col(tx).allFinite()) continue;
          const Eigen::VectorXd centred = x.col(tx) - pca.mean;
          for (size_t q = 0; q < ks.size(); ++q) {
            const int k = std::clamp(ks[q], 0, D);
            const auto b = pca.basis.rightCols(k);  // the k largest
            const Eigen::VectorXd rec = pca.mean + b * (b.transpose() * centred);
            double e = 0, n = 0;
            for (size_t a = 0; a < gh.size(); ++a)
              for (int c = 0; c < C; ++c) {
                const float raw = s.Sample(gh[a], c, p0 + tx);
                if (!(raw > -std::numeric_limits<float>::infinity() && raw < clip)) continue;
                const double d = y(int(a) * C + c, tx) - rec(row_of[a] * C + c);
                e += d * d, n += 1;
              }
            part[q] += e;
            texel_sse[q][size_t(p0 + tx)] += e;
            if (q == 0) part_n += n, texel_n[size_t(p0 + tx)] += n;
          }
        }
      }
      std::lock_guard<std::mutex> lock(merge);
      for (size_t q = 0; q < ks.size(); ++q) {
        sse[q] += part[q];
        auto& [e, n] =
            by_view[q]
                   [int(std::lround(std::acos(std::clamp(vh.z, -1.0, 1.0)) * 180 / M_PI / 15.0)) *
                    15];
        e += part[q], n += part_n;
      }
      samples += part_n;
    });
  }
  std::vector<PcaPoint> out;
  for (size_t q = 0; q < ks.size(); ++q) {
    PcaPoint pt;
    pt.k = ks[q];
    pt.bytes_per_texel = PcaBytesPerTexel(weights[q], shared[q], T);
    pt.rmse = samples > 0 ? std::sqrt(sse[q] / samples) : NAN;
    double sum = 0, texels = 0;
    for (int64_t p = 0; p < T; ++p)
      if (texel_n[size_t(p)] > 0)
        sum += std::sqrt(texel_sse[q][size_t(p)] / texel_n[size_t(p)]), ++texels;
    pt.texel_rms_mean = texels > 0 ? sum / texels : NAN;
    for (const auto& [tv, en] : by_view[q])
      if (en.second > 0) pt.rmse_by_view_theta[tv] = std::sqrt(en.first / en.second);
    out.push_back(pt);
  }
  return out;
}

}  // namespace matfit::fit
