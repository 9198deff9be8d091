#include "server/metrics.h"

#include <cstdio>

namespace matfit::server {
namespace {

std::string Num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}

const std::vector<double> kLatencyBounds = {0.001, 0.0025, 0.005, 0.01, 0.025, 0.05,
                                            0.1,   0.25,   0.5,   1,    2.5,   10};
const std::vector<double> kFitBounds = {0.1, 0.5, 1, 2, 5, 10, 30, 60, 120, 300, 900, 3600};

}  // namespace

Histogram::Histogram(std::vector<double> upper_bounds)
    : bounds_(std::move(upper_bounds)), counts_(bounds_.size() + 1, 0) {}

void Histogram::Observe(double v) {
  size_t i = 0;
  while (i < bounds_.size() && v > bounds_[i]) ++i;
  counts_[i]++;
  sum_ += v;
  count_++;
}

void Histogram::Render(const std::string& name, const std::string& labels, std::string* out) const {
  const std::string sep = labels.empty() ? "" : ",";
  int64_t cumulative = 0;
  for (size_t i = 0; i <= bounds_.size(); ++i) {
    cumulative += counts_[i];
    const std::string le = i < bounds_.size() ? Num(bounds_[i]) : "+Inf";
    *out += name + "_bucket{" + labels + sep + "le=\"" + le + "\"} " + std::to_string(cumulative) +
            "\n";
  }
  const std::string braces = labels.empty() ? "" : "{" + labels + "}";
  *out += name + "_sum" + braces + " " + Num(sum_) + "\n";
  *out += name + "_count" + braces + " " + std::to_string(count_) + "\n";
}

Metrics::Metrics() : fit_seconds_(kFitBounds) {}

void Metrics::ObserveRequest(const std::string& route, const std::string& method, int status,
                             double seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  requests_[{route, method, status}]++;
  auto it = latency_.find(route);
  if (it == latency_.end()) it = latency_.emplace(route, Histogram(kLatencyBounds)).first;
  it->second.Observe(seconds);
}

void Metrics::ObserveJob(const std::string& state, double run_seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  finished_[state]++;
  if (state == "succeeded") fit_seconds_.Observe(run_seconds);
}

void Metrics::ObserveUpload(int64_t bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  upload_bytes_ += bytes;
}

std::string Metrics::Render(const std::map<std::string, int64_t>& jobs, int64_t queue_length,
                            int workers, int running_workers) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string o;
  o += "# HELP matfit_jobs Jobs in the job store by state.\n# TYPE matfit_jobs gauge\n";
  for (const auto& [state, n] : jobs)
    o += "matfit_jobs{state=\"" + state + "\"} " + std::to_string(n) + "\n";
  o += "# HELP matfit_queue_length Jobs waiting for a worker.\n# TYPE matfit_queue_length gauge\n";
  o += "matfit_queue_length " + std::to_string(queue_length) + "\n";
  o += "# HELP matfit_workers Worker threads, and how many run a job now.\n"
       "# TYPE matfit_workers gauge\n";
  o += "matfit_workers{busy=\"false\"} " + std::to_string(workers - running_workers) + "\n";
  o += "matfit_workers{busy=\"true\"} " + std::to_string(running_workers) + "\n";
  o += "# HELP matfit_jobs_finished_total Jobs finished by this process, by final state.\n"
       "# TYPE matfit_jobs_finished_total counter\n";
  for (const auto& [state, n] : finished_)
    o += "matfit_jobs_finished_total{state=\"" + state + "\"} " + std::to_string(n) + "\n";
  o += "# HELP matfit_fit_seconds Run time of succeeded jobs (read, fit, score, write).\n"
       "# TYPE matfit_fit_seconds histogram\n";
  fit_seconds_.Render("matfit_fit_seconds", "", &o);
  o += "# HELP matfit_upload_bytes_total Bytes of dataset archives received.\n"
       "# TYPE matfit_upload_bytes_total counter\n";
  o += "matfit_upload_bytes_total " + std::to_string(upload_bytes_) + "\n";
  o += "# HELP matfit_http_requests_total HTTP requests by route, method and status.\n"
       "# TYPE matfit_http_requests_total counter\n";
  for (const auto& [key, n] : requests_) {
    const auto& [route, method, status] = key;
    o += "matfit_http_requests_total{route=\"" + route + "\",method=\"" + method + "\",status=\"" +
         std::to_string(status) + "\"} " + std::to_string(n) + "\n";
  }
  o += "# HELP matfit_http_request_duration_seconds HTTP request latency by route.\n"
       "# TYPE matfit_http_request_duration_seconds histogram\n";
  for (const auto& [route, h] : latency_)
    h.Render("matfit_http_request_duration_seconds", "route=\"" + route + "\"", &o);
  return o;
}

}  // namespace matfit::server
