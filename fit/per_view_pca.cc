#include "fit/per_view_pca.h"

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <mutex>

#include "core/parallel.h"
#include "fit/fit_common.h"

namespace matfit::fit {

std::vector<PcaPoint> PerViewPcaCurve(const LightStack& s, const std::vector<int>& ks,
                                      const std::vector<uint8_t>& status,
                                      const ProgressFn& progress) {
  const auto groups = ViewGroups(s);
  const int C = s.channels();
  const int64_t T = s.plane_size();
  const std::vector<float> inv = InverseIntensities(s);
  std::vector<double> residual(ks.size(), 0.0);  // Σ over views of n · Σ_{j>k} λ_j
  double samples = 0;                            // Σ n·D
  std::vector<double> weights(ks.size(), 0.0);   // Σ over views of min(k, D): weights per texel
  std::vector<double> shared(ks.size(), 0.0);    // Σ over views of D (1 + min(k, D)): floats
  int views_done = 0;
  for (const std::vector<int>& g : groups) {
    if (progress) progress(views_done++, int64_t(groups.size()));
    const int D = int(g.size()) * C;
    Eigen::MatrixXd cross = Eigen::MatrixXd::Zero(D, D);
    Eigen::VectorXd sum = Eigen::VectorXd::Zero(D);
    double n = 0;
    std::mutex merge;
    constexpr int kRun = 256;
    ParallelFor(0, (T + kRun - 1) / kRun, [&](int64_t r0, int64_t r1) {
      Eigen::MatrixXd x(D, kRun), part_cross = Eigen::MatrixXd::Zero(D, D);
      Eigen::VectorXd part_sum = Eigen::VectorXd::Zero(D);
      std::vector<float> scratch(kRun);
      double part_n = 0;
      for (int64_t r = r0; r < r1; ++r) {
        const int64_t p0 = r * kRun;
        const int len = int(std::min<int64_t>(kRun, T - p0));
        for (size_t a = 0; a < g.size(); ++a)
          for (int c = 0; c < C; ++c) {
            const float* row = s.Texels(g[a], c, p0, len, scratch.data());
            const double in = inv[size_t(g[a]) * C + c];
            for (int t = 0; t < len; ++t) x(int(a) * C + c, t) = double(row[t]) * in;
          }
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
      cross += part_cross, sum += part_sum, n += part_n;
    });
    if (n < 2) continue;
    // Covariance (lower triangle filled by rankUpdate), its eigenvalues ascending.
    const Eigen::VectorXd mean = sum / n;
    Eigen::MatrixXd cov = cross.selfadjointView<Eigen::Lower>();
    cov = cov / n - mean * mean.transpose();
    const Eigen::VectorXd lambda =
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(cov, Eigen::EigenvaluesOnly).eigenvalues();
    for (size_t q = 0; q < ks.size(); ++q) {
      const int k = std::clamp(ks[q], 0, D);
      double rest = 0;  // the D − k smallest
      for (int j = 0; j < D - k; ++j) rest += std::max(0.0, lambda[j]);
      residual[q] += n * rest;
      weights[q] += k;
      shared[q] += double(D) * (1 + k);  // the view's mean and k basis vectors
    }
    samples += n * D;
  }
  std::vector<PcaPoint> out;
  const double texels = double(std::max<int64_t>(1, T));
  for (size_t q = 0; q < ks.size(); ++q) {
    PcaPoint pt;
    pt.k = ks[q];
    // Per texel: k half floats per view; shared: each view's mean and k basis vectors (floats).
    pt.bytes_per_texel = 2 * weights[q] + 4 * shared[q] / texels;
    pt.rmse = samples > 0 ? std::sqrt(residual[q] / samples) : 0;
    out.push_back(pt);
  }
  return out;
}

}  // namespace matfit::fit
