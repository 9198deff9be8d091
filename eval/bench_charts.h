// The charts of `matfit bench` from its results (pure: file name → SVG text).
//   pareto_<dataset>.svg   fit time vs error (log–log), one point per method, Pareto front
//   theta_<dataset>.svg    reconstruction deviation per θ_l group, one line per method
//   views_<case>.svg       multi-view cases: bytes per texel vs held-out-view error (log–log),
//                          Pareto front; views_texel_<case>.svg the same with the texel mean
//   hl2_directions.svg     leaf HL2 precompute error vs N_L
//   stability_error.svg    heat map: median relighting error per method × perturbation
//   stability_silent.svg   heat map: silent-failure rate (target 0)
#pragma once

#include <map>
#include <string>

#include "eval/bench.h"
#include "eval/stability.h"

namespace matfit::eval {

std::map<std::string, std::string> BenchCharts(const BenchResult& result);
std::map<std::string, std::string> StabilityCharts(const StabilityResult& result);

}  // namespace matfit::eval
