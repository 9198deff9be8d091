#include "fit/holdout_views.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "fit/per_view_fit.h"
#include "fit/score.h"

namespace matfit::fit {
namespace {

int Group15(double deg) { return int(std::lround(deg / 15.0)) * 15; }

}  // namespace

std::vector<int> ChooseHeldOutViews(const LightStack& s,
                                    const std::vector<std::vector<int>>& groups, int count) {
  const int frontal = MostFrontalView(s, groups);
  std::vector<int> order;
  for (int g = 0; g < int(groups.size()); ++g)
    if (g != frontal) order.push_back(g);
  auto angles = [&](int g) {
    const LightSample& l = s.lights()[size_t(groups[size_t(g)][0])];
    return std::pair(l.view_theta_deg, l.view_phi_deg);
  };
  std::sort(order.begin(), order.end(), [&](int a, int b) { return angles(a) < angles(b); });
  std::vector<int> out;
  const int n = int(order.size());
  for (int k = 0; k < count && k < n; ++k)
    out.push_back(order[size_t((2 * k + 1) * n / (2 * count))]);  // the middle of each share
  return out;
}

void SplitByViews(const std::vector<std::vector<int>>& groups, const std::vector<int>& held,
                  std::vector<int>* train, std::vector<int>* test) {
  std::vector<char> out(groups.size(), 0);
  for (int g : held) out[size_t(g)] = 1;
  train->clear(), test->clear();
  for (size_t g = 0; g < groups.size(); ++g)
    for (int i : groups[g]) (out[g] ? test : train)->push_back(i);
  std::sort(train->begin(), train->end());
  std::sort(test->begin(), test->end());
}

StatusOr<HeldOutViewMetrics> HeldOutViews(const FitMethod& method, const LightStack& s, int count,
                                          const FitOptions& options) {
  const auto groups = ViewGroups(s);
  const int v = int(groups.size());
  if (v < 2)
    return InvalidArgument(
        "--holdout-views needs a stack of several views (read with --view "
        "all); this one has one view");
  if (count < 1 || count > v - 1)
    return InvalidArgument("--holdout-views must be in [1, " + std::to_string(v - 1) +
                           "] for this stack of " + std::to_string(v) +
                           " views (the most frontal view is always fitted), got " +
                           std::to_string(count));
  const std::vector<int> held = ChooseHeldOutViews(s, groups, count);
  std::vector<int> train, test;
  SplitByViews(groups, held, &train, &test);
  const LightStack train_stack = BorrowImages(s, train);
  auto fit = method.Fit(train_stack, options);
  if (!fit.ok())
    return Status(fit.status().code(),
                  "held-out views: the fit without them failed: " + fit.status().message());
  HeldOutViewMetrics m;
  m.train_views = v - count;
  // A per-view fit predicts a held-out view from the nearest fitted view (fit/per_view_fit.h).
  const ScoreParts parts{.reconstruction = true, .residuals = false, .srgb8 = true};
  m.all = ScoreFit(s, test, *fit, false, {}, parts).reconstruction;
  std::vector<int> by_theta = held;
  std::sort(by_theta.begin(), by_theta.end(), [&](int a, int b) {
    const LightSample &la = s.lights()[size_t(groups[size_t(a)][0])],
                      &lb = s.lights()[size_t(groups[size_t(b)][0])];
    return std::pair(la.view_theta_deg, la.view_phi_deg) <
           std::pair(lb.view_theta_deg, lb.view_phi_deg);
  });
  for (int g : by_theta) {
    const LightSample& l = s.lights()[size_t(groups[size_t(g)][0])];
    m.views.push_back({l.view_theta_deg, l.view_phi_deg,
                       ScoreFit(s, groups[size_t(g)], *fit, false, {}, parts).reconstruction});
  }
  return m;
}

void AddDeviationByViewTheta(const LightStack& s, const MapsOfView& maps_of, ViewThetaSums* sums) {
  for (const std::vector<int>& g : ViewGroups(s)) {
    const LightSample& first = s.lights()[size_t(g[0])];
    const int tv = Group15(first.has_view ? first.view_theta_deg : s.view_theta_deg);
    const auto [maps, status] = maps_of(s.ViewOf(g[0]));
    // The θl groups of this view's images, each weighted by its sample count.
    std::map<int, std::vector<int>> by_light;
    for (int i : g) by_light[Group15(s.lights()[size_t(i)].theta_deg)].push_back(i);
    for (const auto& [tl, images] : by_light) {
      const ReconstructionMetrics r =
          ScoreStack(s, images, *maps, *status, {}, {.reconstruction = true, .residuals = false})
              .reconstruction;
      auto& [sum, n] = (*sums)[tv][tl];
      sum += r.deviation_percent * double(r.samples), n += double(r.samples);
    }
  }
}

void AddDeviationByViewTheta(const LightStack& s, const MaterialMaps& maps,
                             const std::vector<uint8_t>& status, ViewThetaSums* sums) {
  AddDeviationByViewTheta(
      s, [&](const Vec3&) { return std::pair(&maps, &status); }, sums);
}

std::map<int, std::map<int, double>> DeviationByViewTheta(const ViewThetaSums& sums) {
  std::map<int, std::map<int, double>> out;
  for (const auto& [tv, m] : sums)
    for (const auto& [tl, sn] : m)
      if (sn.second > 0) out[tv][tl] = sn.first / sn.second;
  return out;
}

std::map<int, std::map<int, double>> DeviationByViewTheta(const LightStack& s,
                                                          const MaterialMaps& maps,
                                                          const std::vector<uint8_t>& status) {
  ViewThetaSums sums;
  AddDeviationByViewTheta(s, maps, status, &sums);
  return DeviationByViewTheta(sums);
}

}  // namespace matfit::fit
