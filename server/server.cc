#include "server/server.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <random>
#include <set>

#include "core/parallel.h"
#include "core/version.h"
#include "server/job_runner.h"
#include "server/job_spec.h"
#include "server/log.h"
#include "server/server_impl.h"

namespace matfit::server {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

bool IsLoopback(const std::string& host) {
  return host == "127.0.0.1" || host == "localhost" || host == "::1";
}

// Start time of the request this HTTP thread is serving (set before routing).
thread_local std::chrono::steady_clock::time_point t_request_start;

bool IsTemporary(const std::string& name) {
  return name.size() > 1 && name[0] == '.' && name.find(".tmp-") != std::string::npos;
}

}  // namespace

double NowSeconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

bool ServerOptions::Check(std::string* why) const {
  if (data_dir.empty())
    return *why = "--data DIR is required (jobs, datasets and packs live there)", false;
  if (port < 0 || port > 65535) return *why = "--port must be in [0, 65535]", false;
  if (workers < 1 || workers > 64) return *why = "--workers must be in [1, 64]", false;
  if (http_threads < 2 || http_threads > 256)
    return *why = "HTTP threads must be in [2, 256]", false;
  if (max_upload_bytes < 1024) return *why = "--max-upload must be at least 1 KiB", false;
  if (request_timeout_s < 1) return *why = "--request-timeout must be ≥ 1 s", false;
  if (drain_seconds < 0) return *why = "--drain-seconds must be ≥ 0", false;
  if (max_stack_samples < 1)
    return *why = "--max-stack-msamples must be ≥ 1 (million samples)", false;
  if (render_backend != "auto" && render_backend != "egl" && render_backend != "cpu")
    return *why = "render backend must be auto, egl or cpu", false;
  if (token_file.empty() && !IsLoopback(bind))
    return *why =
               "--bind " + bind + " is not loopback: give --token-file so that writes need a token",
           false;
  for (const auto& r : allow_roots) {
    std::error_code ec;
    if (!fs::is_directory(r, ec)) return *why = "--allow-root '" + r + "' is not a folder", false;
  }
  return archive.Check(why);
}

Server::Impl::~Impl() {
  if (lock_fd >= 0) ::close(lock_fd);  // releases the flock
}

Server::Server(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Server::~Server() { Shutdown(); }

StatusOr<std::unique_ptr<Server>> Server::Create(const ServerOptions& options) {
  std::string why;
  if (!options.Check(&why)) return InvalidArgument(why);
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  std::error_code ec;
  fs::create_directories(options.data_dir, ec);
  impl->data = fs::weakly_canonical(fs::absolute(options.data_dir, ec), ec).string();
  if (ec || !fs::is_directory(impl->data))
    return IoError("cannot use data folder '" + options.data_dir + "'");
  // One server per data folder: a second one would sweep the first one's uploads.
  const std::string lock = impl->data + "/lock";
  impl->lock_fd = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (impl->lock_fd < 0) return IoError("cannot create '" + lock + "'");
  if (::flock(impl->lock_fd, LOCK_EX | LOCK_NB) != 0)
    return Status(StatusCode::kUnavailable,
                  "data folder '" + impl->data +
                      "' is in use by another matfit serve; stop it or choose another --data");
  for (const char* sub : {"uploads", "datasets", "packs", "cache/zips", "cache/previews"}) {
    fs::create_directories(impl->data + "/" + sub, ec);
    if (ec) return IoError("cannot create '" + impl->data + "/" + sub + "': " + ec.message());
  }
  if (!options.token_file.empty()) {
    auto t = TokenSet::Load(options.token_file);
    if (!t.ok()) return t.status();
    impl->tokens = std::move(*t);
  }
  auto store = JobStore::Open(impl->data + "/jobs.db");
  if (!store.ok()) return store.status();
  impl->store = std::move(*store);
  SetLogQuiet(options.quiet);

  // Start-up sweep: partial uploads, temporaries of interrupted writes, files of deleted jobs.
  int swept = 0;
  for (const auto& e : fs::directory_iterator(impl->UploadsDir(), ec))
    swept += fs::remove_all(e.path(), ec) > 0;
  std::set<std::string> ids;
  for (const auto& id : impl->store->AllIds()) ids.insert(id);
  for (const char* sub : {"datasets", "packs", "cache/zips", "cache/previews"})
    for (const auto& e : fs::directory_iterator(impl->data + "/" + sub, ec)) {
      const std::string name = e.path().filename().string();
      const std::string id = e.path().stem().string();  // "<id>.zip" → "<id>"
      if (IsTemporary(name) || !ids.count(id)) swept += fs::remove_all(e.path(), ec) > 0;
    }
  const int requeued = impl->store->RequeueRunning();
  LogEvent("info", "startup",
           {{"data", impl->data},
            {"requeued", requeued},
            {"swept", swept},
            {"jobs", ids.size()},
            {"auth", impl->tokens.empty() ? "off" : "bearer"}});
  impl->previews = std::make_unique<PreviewRenderer>(options.render_backend);
  impl->RegisterRoutes();
  return std::unique_ptr<Server>(new Server(std::move(impl)));
}

void Server::Impl::RegisterRoutes() {
  const auto& o = options;
  http.new_task_queue = [n = o.http_threads] { return new httplib::ThreadPool(size_t(n)); };
  http.set_read_timeout(o.request_timeout_s, 0);
  http.set_write_timeout(o.request_timeout_s, 0);
  http.set_keep_alive_timeout(5);
  http.set_keep_alive_max_count(1000);
  // Responses go out as headers + body writes: without TCP_NODELAY, Nagle + delayed ACK adds
  // ~40 ms to every keep-alive request.
  http.set_tcp_nodelay(true);
  http.set_payload_max_length(size_t(o.max_upload_bytes));

  // Authorisation before routing (and before an upload body is read).
  http.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    t_request_start = std::chrono::steady_clock::now();
    if (tokens.empty()) return httplib::Server::HandlerResponse::Unhandled;
    const std::string& p = req.path;
    const bool open = p == "/healthz" || p == "/metrics" || p == "/api/v1/healthz" ||
                      p == "/api/v1/metrics" || p.rfind("/api/v1/viewer/static/", 0) == 0;
    const bool write = req.method == "POST" || req.method == "DELETE" || req.method == "PUT";
    if (open && !write) return httplib::Server::HandlerResponse::Unhandled;
    if (!write && options.public_read) return httplib::Server::HandlerResponse::Unhandled;
    std::string auth = req.get_header_value("Authorization");
    // Browsers cannot set headers on <img> or page loads: ?token= is accepted for reads.
    if (auth.empty() && !write && req.has_param("token"))
      auth = "Bearer " + req.get_param_value("token");
    switch (tokens.Check(auth, write ? Access::kWrite : Access::kRead)) {
      case AuthResult::kOk: return httplib::Server::HandlerResponse::Unhandled;
      // The body (if any) is not read: the reply closes the connection (SendErrorAndClose), so
      // that the unread bytes can never be parsed as a next request.
      case AuthResult::kMissing:
        res.set_header("WWW-Authenticate", "Bearer");
        SendErrorAndClose(
            res, 401,
            "this endpoint needs `Authorization: Bearer TOKEN` (tokens are in the server's "
            "--token-file)");
        return httplib::Server::HandlerResponse::Handled;
      case AuthResult::kInvalid:
        res.set_header("WWW-Authenticate", "Bearer error=\"invalid_token\"");
        SendErrorAndClose(res, 401, "the bearer token is not valid");
        return httplib::Server::HandlerResponse::Handled;
      case AuthResult::kForbidden:
        SendErrorAndClose(res, 403,
                          "this token may only read; writes need a token with the write role");
        return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  http.set_exception_handler(
      [](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
        std::string what = "unknown";
        try {
          std::rethrow_exception(ep);
        } catch (const std::exception& e) {
          what = e.what();
        } catch (...) {
        }
        res.headers.erase("EXCEPTION_WHAT");
        LogEvent("error", "exception", {{"what", what}});
        SendError(res, 500, "internal error");
      });
  http.set_error_handler([](const httplib::Request& req, httplib::Response& res) {
    if (!res.body.empty() || res.content_provider_) return;  // our own error bodies
    if (res.status == 404)
      SendError(res, 404,
                "no such endpoint: " + req.method + " " + req.path + " (see docs/openapi.json)");
    else if (res.status == 413)
      SendError(res, 413, "the request body is larger than the server's upload limit");
    else
      SendError(res, res.status, "request failed");
  });
  // Metrics are counted before the response goes out (the post-routing handler runs just
  // before httplib writes it): a client that has its answer then sees it counted in /metrics,
  // whichever connection it asks on. Their latency is the time to the first response byte; the
  // log line, written after the response, has the whole time.
  http.set_post_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_request_start).count();
    metrics.ObserveRequest(RouteOf(req.path), req.method, res.status, s);
  });
  http.set_logger([this](const httplib::Request& req, const httplib::Response& res) {
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_request_start).count();
    LogEvent("info", "request",
             {{"method", req.method},
              {"path", req.path},
              {"status", res.status},
              {"ms", std::round(s * 1e4) / 10},
              {"remote", req.remote_addr}});
  });

  auto health = [this](const httplib::Request&, httplib::Response& res) {
    const auto counts = store->CountByState();
    SendJson(res, 200,
             {{"status", draining ? "draining" : "ok"},
              {"version", kMatfitVersion},
              {"workers", options.workers},
              {"queued", counts.at(JobState::kQueued)},
              {"running", counts.at(JobState::kRunning)},
              {"renderer", previews->Description()}});
  };
  http.Get("/healthz", health);
  http.Get("/api/v1/healthz", health);
  auto metrics_page = [this](const httplib::Request&, httplib::Response& res) {
    std::map<std::string, int64_t> jobs;
    for (const auto& [s, n] : store->CountByState()) jobs[JobStateName(s)] = n;
    int busy;
    {
      std::lock_guard<std::mutex> lock(mutex);
      busy = int(live.size());
    }
    res.set_content(metrics.Render(jobs, jobs["queued"], options.workers, busy),
                    "text/plain; version=0.0.4");
  };
  http.Get("/metrics", metrics_page);
  http.Get("/api/v1/metrics", metrics_page);
  RegisterJobRoutes();
  RegisterPackRoutes();
}

Status Server::Start() {
  Impl& m = *impl_;
  if (m.options.port == 0) {
    m.port = m.http.bind_to_any_port(m.options.bind);
    if (m.port <= 0) return IoError("cannot bind " + m.options.bind + " on any port");
  } else {
    if (!m.http.bind_to_port(m.options.bind, m.options.port))
      return IoError("cannot listen on " + m.options.bind + ":" + std::to_string(m.options.port) +
                     " (in use, or not allowed); choose another --port");
    m.port = m.options.port;
  }
  m.http_thread = std::thread([&m] { m.http.listen_after_bind(); });
  // stop() is a no-op until the listener runs: wait, so that an early Shutdown cannot hang.
  while (!m.http.is_running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  for (int i = 0; i < m.options.workers; ++i) m.workers.emplace_back([&m] { m.WorkerLoop(); });
  LogEvent("info", "listening",
           {{"bind", m.options.bind}, {"port", m.port}, {"workers", m.options.workers}});
  return Status::Ok();
}

int Server::port() const { return impl_->port; }

void Server::Wait() {
  std::unique_lock<std::mutex> lock(impl_->shutdown_mutex);
  impl_->shutdown_cv.wait(lock, [&] { return impl_->shutdown_done; });
}

void Server::Shutdown() {
  Impl& m = *impl_;
  if (m.stopped.exchange(true)) {
    Wait();
    return;
  }
  LogEvent("info", "shutdown", {{"drain_seconds", m.options.drain_seconds}});
  m.http.stop();
  if (m.http_thread.joinable()) m.http_thread.join();
  m.draining = true;  // workers take no new job
  {
    std::unique_lock<std::mutex> lock(m.mutex);
    m.wake.notify_all();
    m.idle.wait_for(lock, std::chrono::duration<double>(m.options.drain_seconds),
                    [&] { return m.live.empty(); });
    m.hard_stop = true;  // running jobs see a cancel and are re-queued
    for (auto& [id, j] : m.live) j->cancel = true;
  }
  m.wake.notify_all();
  for (auto& w : m.workers) w.join();
  m.workers.clear();
  {
    std::lock_guard<std::mutex> lock(m.shutdown_mutex);
    m.shutdown_done = true;
    m.shutdown_cv.notify_all();  // under the lock: a waiter may destroy the server right after
  }
  LogEvent("info", "stopped", json::object());
}

void Server::Impl::WorkerLoop() {
  while (!draining) {
    auto job = store->ClaimNext(NowSeconds());
    if (!job) {
      std::unique_lock<std::mutex> lock(mutex);
      wake.wait_for(lock, std::chrono::seconds(1));
      continue;
    }
    RunOne(*job);
  }
}

void Server::Impl::RunOne(const JobRecord& job) {
  auto lj = std::make_shared<LiveJob>();
  lj->started = NowSeconds();
  {
    std::lock_guard<std::mutex> lock(mutex);
    live[job.id] = lj;
    if (hard_stop) lj->cancel = true;  // claimed just as a shutdown gave up waiting
  }
  LogEvent("info", "job_started",
           {{"id", job.id},
            {"attempt", job.attempts},
            {"spec", json::parse(job.spec_json, nullptr, false)}});
  const auto t0 = std::chrono::steady_clock::now();
  auto last_persist = t0;
  auto progress = [&](double f, const std::string& stage) {
    const auto now = std::chrono::steady_clock::now();
    {
      std::lock_guard<std::mutex> lock(lj->mutex);
      lj->fraction = f, lj->stage = stage;
    }
    if (now - last_persist > std::chrono::seconds(1)) {  // persisted about once a second
      last_persist = now;
      (void)store->UpdateProgress(job.id, f, stage);
      if (auto r = store->Get(job.id); r && r->cancel_requested) lj->cancel = true;
    }
    return !lj->cancel.load();
  };
  StatusOr<std::string> r = DataError("the stored job options are unreadable");
  if (auto spec = JobSpecFromJson(job.spec_json); spec.ok()) {
    if (job.cancel_requested) lj->cancel = true;
    try {  // a job must never take the server down (or, re-queued, take it down again)
      r = lj->cancel
              ? StatusOr<std::string>(Status(StatusCode::kCancelled, "cancelled"))
              : RunJob(*spec, job.dataset, PackDir(job.id), progress, options.max_stack_samples);
    } catch (const std::exception& e) {
      r = Status(StatusCode::kInternal, std::string("internal error: ") + e.what());
    }
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::string final_state;
  if (r.ok()) {
    final_state = "succeeded";
    (void)store->Finish(job.id, JobState::kSucceeded, "", *r, NowSeconds(), seconds);
  } else if (r.status().code() == StatusCode::kCancelled && hard_stop) {
    final_state = "requeued";
    (void)store->Requeue(job.id);
  } else if (r.status().code() == StatusCode::kCancelled) {
    final_state = "cancelled";
    (void)store->Finish(job.id, JobState::kCancelled, "cancelled while running", "", NowSeconds(),
                        seconds);
  } else {
    final_state = "failed";
    (void)store->Finish(job.id, JobState::kFailed, r.status().message(), "", NowSeconds(), seconds);
  }
  if (final_state != "requeued") metrics.ObserveJob(final_state, seconds);
  LogEvent(final_state == "failed" ? "warn" : "info", "job_finished",
           {{"id", job.id},
            {"state", final_state},
            {"seconds", seconds},
            {"error", r.ok() ? "" : r.status().message()}});
  {
    std::lock_guard<std::mutex> lock(mutex);
    live.erase(job.id);
  }
  idle.notify_all();
}

}  // namespace matfit::server
