#include "fit/light_matrix.h"

#include <Eigen/Dense>
#include <cmath>

namespace matfit::fit {

StatusOr<LightMatrix> MakeLightMatrix(const std::vector<LightSample>& lights) {
  const int n = int(lights.size());
  if (n < 3)
    return InvalidArgument("only " + std::to_string(n) +
                           " light(s): a normal needs at least 3 "
                           "non-coplanar lights; capture more light directions");
  Eigen::MatrixXd L(n, 3);
  for (int i = 0; i < n; ++i)
    L.row(i) << lights[i].direction.x, lights[i].direction.y, lights[i].direction.z;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(L, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const auto sv = svd.singularValues();
  if (!(sv[2] > 1e-6 * sv[0]))
    return InvalidArgument(
        "the lights are coplanar (light matrix rank 2, σ3/σ1 = " + std::to_string(sv[2] / sv[0]) +
        "): normals cannot be recovered; add "
        "lights out of that plane");
  LightMatrix m;
  m.n = n;
  m.condition = sv[0] / sv[2];
  const Eigen::MatrixXd p = svd.solve(Eigen::MatrixXd::Identity(n, n));  // 3 × n
  m.pinv.resize(size_t(3) * n);
  for (int r = 0; r < 3; ++r)
    for (int i = 0; i < n; ++i) m.pinv[size_t(r) * n + i] = p(r, i);
  return m;
}

int FindLightAlong(const std::vector<LightSample>& lights, const Vec3& view, double max_deg) {
  int best = -1;
  double best_deg = max_deg;
  for (int i = 0; i < int(lights.size()); ++i) {
    const double d = AngleBetweenDeg(lights[i].direction, view);
    if (d <= best_deg) best = i, best_deg = d;
  }
  return best;
}

}  // namespace matfit::fit
