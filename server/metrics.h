// Prometheus text-format metrics: HTTP requests by route/method/status, request latency and
// fit-time histograms. Job counts come from the job store when the page is rendered.
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <tuple>
#include <vector>

namespace matfit::server {

class Histogram {
 public:
  explicit Histogram(std::vector<double> upper_bounds);
  void Observe(double v);
  // "name_bucket{labels,le="…"} n" lines, then _sum and _count.
  void Render(const std::string& name, const std::string& labels, std::string* out) const;

 private:
  std::vector<double> bounds_;
  std::vector<int64_t> counts_;  // cumulative at render time, per bucket here
  double sum_ = 0;
  int64_t count_ = 0;
};

class Metrics {
 public:
  Metrics();
  void ObserveRequest(const std::string& route, const std::string& method, int status,
                      double seconds);
  void ObserveJob(const std::string& state, double run_seconds);  // a finished job
  void ObserveUpload(int64_t bytes);
  // The whole exposition page; `jobs` = count per state name, `running_workers` busy now.
  std::string Render(const std::map<std::string, int64_t>& jobs, int64_t queue_length, int workers,
                     int running_workers) const;

 private:
  mutable std::mutex mutex_;
  std::map<std::tuple<std::string, std::string, int>, int64_t> requests_;
  std::map<std::string, Histogram> latency_;  // by route
  std::map<std::string, int64_t> finished_;   // by final state
  Histogram fit_seconds_;
  int64_t upload_bytes_ = 0;
};

}  // namespace matfit::server
