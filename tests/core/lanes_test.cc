// Eight lanes of double (core/shading/lanes.h): Exp and Log against libm in ulps, and the shading
// functions on lanes against the same functions on scalar autodiff (ceres::Jet), values and
// derivatives, including the lanes their guards zero.
#include "core/shading/lanes.h"

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "core/shading/shading.h"

namespace matfit {
namespace {

using lanes::Dual;
using lanes::L8;

// Distance in units in the last place between two finite doubles of the same sign.
int64_t Ulps(double a, double b) {
  int64_t ia, ib;
  std::memcpy(&ia, &a, 8);
  std::memcpy(&ib, &b, 8);
  return ia > ib ? ia - ib : ib - ia;
}

template <typename F, typename G>
int64_t MaxUlps(const std::vector<double>& xs, F lane, G libm) {
  int64_t worst = 0;
  for (size_t i = 0; i + 8 <= xs.size(); i += 8) {
    const L8 y = lane(lanes::Load(&xs[i]));
    for (int k = 0; k < 8; ++k) {
      const double want = libm(xs[i + k]);
      EXPECT_EQ(std::signbit(y[k]), std::signbit(want)) << xs[i + k];
      worst = std::max(worst, Ulps(y[k], want));
    }
  }
  return worst;
}

TEST(Lanes, ExpIsWithinTwoUlpsOfLibm) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> wide(-708, 709.78), narrow(-1, 1);
  std::vector<double> xs = {
      0.0,    -0.0,   1.0,   -1.0,   0.5 * M_LN2, -0.5 * M_LN2,        1e-300, -1e-18,
      -707.9, 709.78, 100.0, -100.0, 3 * M_LN2,   1024 * M_LN2 - 1e-3, 2,      -2};
  for (int i = 0; i < 40000; ++i) xs.push_back(wide(rng));
  for (int i = 0; i < 40000; ++i) xs.push_back(narrow(rng));
  while (xs.size() % 8) xs.push_back(0.25);
  EXPECT_LE(MaxUlps(xs, lanes::Exp, [](double x) { return std::exp(x); }), 2);
  const double inf = std::numeric_limits<double>::infinity();
  double edge[8] = {710.0, 1e308, inf, -708.5, -1e308, -inf, std::nan(""), 0};
  const L8 e = lanes::Exp(lanes::Load(edge));
  EXPECT_EQ(e[0], inf);
  EXPECT_EQ(e[1], inf);
  EXPECT_EQ(e[2], inf);
  EXPECT_EQ(e[3], 0.0);  // flushed: libm's subnormal range
  EXPECT_EQ(e[4], 0.0);
  EXPECT_EQ(e[5], 0.0);
  EXPECT_TRUE(std::isnan(e[6]));
  EXPECT_EQ(e[7], 1.0);
}

TEST(Lanes, LogIsWithinOneUlpOfLibm) {
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> expo(-1074, 1023), mant(1, 2), near1(0.5, 2);
  std::vector<double> xs = {1.0,
                            2.0,
                            0.5,
                            M_SQRT2,
                            M_SQRT1_2,
                            1 + 1e-15,
                            1 - 1e-16,
                            4.9e-324,
                            2.2250738585072014e-308,
                            1e-310,
                            1.7976931348623157e308,
                            M_E};
  for (int i = 0; i < 40000; ++i) xs.push_back(std::ldexp(mant(rng), int(expo(rng))));
  for (int i = 0; i < 40000; ++i) xs.push_back(near1(rng));
  while (xs.size() % 8) xs.push_back(3.0);
  EXPECT_LE(MaxUlps(xs, lanes::Log, [](double x) { return std::log(x); }), 1);
  const double inf = std::numeric_limits<double>::infinity();
  double edge[8] = {0.0, -0.0, -1.0, -inf, inf, std::nan(""), 1.0, 1e-320};
  const L8 l = lanes::Log(lanes::Load(edge));
  EXPECT_EQ(l[0], -inf);
  EXPECT_EQ(l[1], -inf);
  EXPECT_TRUE(std::isnan(l[2]));
  EXPECT_TRUE(std::isnan(l[3]));
  EXPECT_EQ(l[4], inf);
  EXPECT_TRUE(std::isnan(l[5]));
  EXPECT_EQ(l[6], 0.0);
  EXPECT_LE(Ulps(l[7], std::log(1e-320)), 1);
}

// Any is true exactly when some lane of the mask is set: each lane alone, none, all.
TEST(Lanes, AnySeesEveryLane) {
  lanes::Mask m{};
  EXPECT_FALSE(lanes::Any(m));
  for (int k = 0; k < 8; ++k) {
    lanes::Mask one{};
    one.m[k] = -1;
    EXPECT_TRUE(lanes::Any(one)) << "lane " << k;
    m.m[k] = -1;
  }
  EXPECT_TRUE(lanes::Any(m));
}

// The lobes on lanes and on Jets: eight lights per call (some below the horizon of the tilted
// normal, some past the lobe's cut-off), derivatives in (p, q, amplitude, shape).
TEST(Lanes, ShadingFunctionsOnLanesEqualThemOnJets) {
  constexpr int N = 4;
  using J = ceres::Jet<double, N>;
  using D = Dual<N>;
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-1, 1);
  auto to_lanes = [](const J* j) {
    D d;
    for (int k = 0; k < 8; ++k) {
      d.a.v[k] = j[k].a;
      for (int m = 0; m < N; ++m) d.v[m].v[k] = j[k].v[m];
    }
    return d;
  };
  auto expect_equal = [](const D& lane, const J* jet, const char* what) {
    for (int k = 0; k < 8; ++k) {
      const double tol = 1e-14 * std::max(1.0, std::abs(jet[k].a));
      EXPECT_NEAR(lane.a[k], jet[k].a, tol) << what << " lane " << k;
      for (int m = 0; m < N; ++m)
        EXPECT_NEAR(lane.v[m][k], jet[k].v[m], 1e-13 * std::max(1.0, std::abs(jet[k].v[m])))
            << what << " lane " << k << " d/dx" << m;
    }
  };
  int zeroed = 0, lit = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const J p(0.8 * u(rng), 0), q(0.8 * u(rng), 1), amp(0.5 + 0.4 * u(rng), 2);
    const J e(20 + 15 * u(rng), 3), r(0.5 + 0.4 * u(rng), 3), cxy(-1 + 0.5 * u(rng), 3);
    const Vec3T<J> n = Normalize(Vec3T<J>(p, q, J(1)));
    const Vec3 view = Normalize(Vec3(0.2 * u(rng), 0.2 * u(rng), 1));
    Vec3T<L8> l8, h8, v8(L8(view.x), L8(view.y), L8(view.z));
    J blinn[8], cook[8], lafo[8], lambert[8];
    for (int k = 0; k < 8; ++k) {
      // Directions over the whole sphere's upper 1.2 hemispheres: z from −0.2 to 1.
      const double z = 0.4 + 0.6 * u(rng), ph = M_PI * u(rng), s = std::sqrt(1 - z * z);
      const Vec3 l(s * std::cos(ph), s * std::sin(ph), z), h = Normalize(l + view);
      l8.x.v[k] = l.x, l8.y.v[k] = l.y, l8.z.v[k] = l.z;
      h8.x.v[k] = h.x, h8.y.v[k] = h.y, h8.z.v[k] = h.z;
      blinn[k] = shading::BlinnPhongSpecularHalf(amp, e, n, l, h);
      cook[k] = shading::CookTorranceSpecularHalf(amp, r, n, l, view, h);
      lafo[k] = shading::LafortuneLobe(amp, cxy, e, n, l, view);
      lambert[k] = shading::Lambert(amp, n, l);
      zeroed += blinn[k].a == 0, lit += blinn[k].a > 0;
    }
    const Vec3T<D> n8(to_lanes(std::vector<J>(8, n.x).data()),
                      to_lanes(std::vector<J>(8, n.y).data()),
                      to_lanes(std::vector<J>(8, n.z).data()));
    auto bc = [&](const J& j) { return to_lanes(std::vector<J>(8, j).data()); };
    expect_equal(shading::BlinnPhongSpecularHalf(bc(amp), bc(e), n8, l8, h8), blinn, "blinn-phong");
    expect_equal(shading::CookTorranceSpecularHalf(bc(amp), bc(r), n8, l8, v8, h8), cook,
                 "cook-torrance");
    expect_equal(shading::LafortuneLobe(bc(amp), bc(cxy), bc(e), n8, l8, v8), lafo, "lafortune");
    expect_equal(shading::Lambert(bc(amp), n8, l8), lambert, "lambert");
  }
  // Both sides of the guards were exercised.
  EXPECT_GT(zeroed, 200);
  EXPECT_GT(lit, 200);
}

}  // namespace
}  // namespace matfit
