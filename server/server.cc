#include "server/server.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <set>

#include "core/version.h"
#include "server/api_wording.h"
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

bool ValidNodeId(const std::string& id) {
  if (id.empty() || id.size() > 64 || id[0] == '.') return false;
  for (const char c : id)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '_' && c != '-')
      return false;
  return true;
}

// This node's id when --node-id is not given: the host name and the port (a restarted node
// keeps it and re-queues its own jobs at once), or the process id for an ephemeral port.
std::string DefaultNodeId(int port) {
  char host[256] = {0};
  if (::gethostname(host, sizeof host - 1) != 0) host[0] = 0;
  std::string id;
  for (const char* p = host; *p && id.size() < 40; ++p)
    id += std::isalnum(static_cast<unsigned char>(*p)) || *p == '-' ? *p : '_';
  if (id.empty()) id = "node";
  return id + "-" + std::to_string(port != 0 ? port : int(::getpid()));
}

// Shared folders of a cluster hold other nodes' work in progress (an upload between its move
// and its row, a pack being staged): a node sweeps there only what is this old.
constexpr auto kSharedSweepAge = std::chrono::hours(1);

bool OlderThan(const fs::path& p, std::filesystem::file_time_type::duration age) {
  std::error_code ec;
  const auto t = fs::last_write_time(p, ec);
  return !ec && t < fs::file_time_type::clock::now() - age;
}

}  // namespace

double NowSeconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::string Server::Impl::SourceLabel(const JobRecord& j) const {
  if (!j.uploaded) return j.dataset;  // a folder the client named itself
  std::error_code ec;
  const std::string rel = fs::relative(j.dataset, DatasetsDir() + "/" + j.id, ec).generic_string();
  return "upload " + j.id + (ec || rel.empty() || rel == "." ? "" : "/" + rel);
}

std::string Server::Impl::ForClients(std::string message, const JobRecord* job) const {
  auto replace_all = [&](const std::string& from, const std::string& to) {
    for (size_t at = 0; (at = message.find(from, at)) != std::string::npos; at += to.size())
      message.replace(at, from.size(), to);
  };
  if (job && job->uploaded) {
    replace_all(job->dataset + "/", "");
    replace_all(job->dataset, "the dataset folder");
  }
  replace_all(data + "/", "");
  replace_all(data, "the data folder");
  return ApiWording(std::move(message));
}

bool ServerOptions::Check(std::string* why) const {
  if (data_dir.empty())
    return *why = "--data DIR is required (jobs, datasets and packs live there)", false;
  if (port < 0 || port > 65535) return *why = "--port must be in [0, 65535]", false;
  if (workers < 1 || workers > 64) return *why = "--workers must be in [1, 64]", false;
  if (http_threads < 1 || http_threads > 256)
    return *why = "--http-threads must be in [1, 256]", false;
  if (upload_slots < 1 || upload_slots > 64)
    return *why = "--upload-slots must be in [1, 64]", false;
  if (max_connections < 8 || max_connections > 100000)
    return *why = "--max-connections must be in [8, 100000]", false;
  if (max_client_connections < 1 || max_client_connections > max_connections)
    return *why = "--max-client-connections must be in [1, --max-connections]", false;
  if (max_client_requests < 1) return *why = "--max-client-requests must be ≥ 1", false;
  if (!(header_timeout_s >= 0.1 && header_timeout_s <= 3600))
    return *why = "--header-timeout must be in [0.1, 3600] s", false;
  if (!(keep_alive_timeout_s >= 0.1 && keep_alive_timeout_s <= 3600))
    return *why = "--keep-alive-timeout must be in [0.1, 3600] s", false;
  if (max_upload_bytes < 1024) return *why = "--max-upload must be at least 1 KiB", false;
  if (request_timeout_s < 1) return *why = "--request-timeout must be ≥ 1 s", false;
  if (!(transfer_grace_s >= 0.1 && transfer_grace_s <= 3600))
    return *why = "--transfer-grace must be in [0.1, 3600] s", false;
  if (!(min_transfer_rate >= 1)) return *why = "--min-transfer-rate must be ≥ 1 byte/s", false;
  if (drain_seconds < 0) return *why = "--drain-seconds must be ≥ 0", false;
  if (max_stack_samples < 1)
    return *why = "--max-stack-msamples must be ≥ 1 (million samples)", false;
  if (render_backend != "auto" && render_backend != "egl" && render_backend != "cpu")
    return *why = "render backend must be auto, egl or cpu", false;
  if (preview_cache_bytes < 0)
    return *why = "--preview-cache-mib must be ≥ 0 (0: previews are rendered every time)", false;
  if (preview_queue < 1 || preview_queue > 1000)
    return *why = "--preview-queue must be in [1, 1000]", false;
  if (token_file.empty() && !db_tokens && !IsLoopback(bind))
    return *why = "--bind " + bind +
                  " is not loopback: give --token-file (or, in a cluster, --db-tokens) so that "
                  "writes need a token",
           false;
  if (db_tokens && database_url.empty())
    return *why =
               "--db-tokens needs --db postgresql://… (the tokens live in the cluster's "
               "database); a single server takes --token-file",
           false;
  if (!database_url.empty() && !IsPostgresUrl(database_url))
    return *why =
               "--db takes a postgresql://user@host:port/database URL (without --db the jobs "
               "live in DATA/jobs.db, SQLite)",
           false;
  if (!node_id.empty() && !ValidNodeId(node_id))
    return *why = "--node-id must be 1-64 characters of A-Z a-z 0-9 . _ - (got '" + node_id + "')",
           false;
  if (!(lease_seconds >= 1 && lease_seconds <= 3600))
    return *why = "--lease-seconds must be in [1, 3600]", false;
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
  const bool cluster = !options.database_url.empty();
  impl->node = !options.node_id.empty() ? options.node_id
               : cluster                ? DefaultNodeId(options.port)
                                        : "local";
  impl->node_dir = cluster ? impl->data + "/nodes/" + impl->node : impl->data;
  fs::create_directories(impl->node_dir, ec);
  // One server per data folder (per node folder in a cluster): a second one would sweep the
  // first one's uploads.
  const std::string lock = impl->node_dir + "/lock";
  impl->lock_fd = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (impl->lock_fd < 0) return IoError("cannot create '" + lock + "'");
  if (::flock(impl->lock_fd, LOCK_EX | LOCK_NB) != 0)
    return Status(StatusCode::kUnavailable,
                  cluster ? "node '" + impl->node + "' already runs on data folder '" + impl->data +
                                "'; give each node its own --node-id"
                          : "data folder '" + impl->data +
                                "' is in use by another matfit serve; stop it or choose another "
                                "--data");
  for (const std::string sub : {"datasets", "packs"}) {
    fs::create_directories(impl->data + "/" + sub, ec);
    if (ec) return IoError("cannot create '" + impl->data + "/" + sub + "': " + ec.message());
  }
  for (const std::string sub : {"uploads", "cache/zips", "cache/previews"}) {
    fs::create_directories(impl->node_dir + "/" + sub, ec);
    if (ec) return IoError("cannot create '" + impl->node_dir + "/" + sub + "': " + ec.message());
  }
  if (!options.token_file.empty()) {
    auto t = TokenSet::Load(options.token_file);
    if (!t.ok()) return t.status();
    impl->file_tokens = std::move(*t);
  }
  impl->auth_on = !options.token_file.empty() || options.db_tokens;
  auto store = cluster ? OpenPostgresJobStore(options.database_url)
                       : OpenSqliteJobStore(impl->data + "/jobs.db");
  if (!store.ok()) return store.status();
  impl->store = std::move(*store);
  MATFIT_RETURN_IF_ERROR(impl->RefreshTokens());
  SetLogQuiet(options.quiet);

  int swept = 0;
  size_t jobs = 0;
  impl->Sweep(&swept, &jobs);
  const int requeued = impl->store->RequeueNode(impl->node);
  LogEvent("info", "startup",
           {{"data", impl->data},
            {"node", impl->node},
            {"database", cluster ? RedactDatabaseUrl(options.database_url) : "sqlite"},
            {"requeued", requeued},
            {"swept", swept},
            {"jobs", jobs},
            {"auth", !impl->auth_on      ? "off"
                     : options.db_tokens ? "bearer (file and database)"
                                         : "bearer"},
            {"tokens", impl->Tokens()->size()}});
  PreviewOptions po;
  po.backend = options.render_backend, po.max_queued = options.preview_queue;
  impl->previews = std::make_unique<PreviewRenderer>(po);
  impl->preview_cache = std::make_unique<PreviewCache>(impl->node_dir + "/cache/previews",
                                                       options.preview_cache_bytes);
  impl->RegisterRoutes();
  return std::unique_ptr<Server>(new Server(std::move(impl)));
}

void Server::Impl::Sweep(int* swept, size_t* jobs) {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(UploadsDir(), ec))  // this node's own
    *swept += fs::remove_all(e.path(), ec) > 0;
  std::set<std::string> ids;
  for (const auto& id : store->AllIds()) ids.insert(id);
  *jobs = ids.size();
  // In a cluster, another node's temporaries and not-yet-queued uploads are left alone unless
  // they are old; this node's own staged packs are dead (it is starting).
  const bool shared = store->Shared();
  // This node's staging names: ".ID.tmp-run-NODE-N", and temporaries made beside them
  // ("..ID.tmp-run-NODE-N.tmp-…"). Exactly NODE: node "gpu" must not match "gpu-2"'s.
  auto own = [&](const std::string& name) {
    const size_t at = name.find(".tmp-run-");
    if (at == std::string::npos) return false;
    const std::string rest = name.substr(at + 9);
    if (rest.compare(0, node.size() + 1, node + "-") != 0) return false;
    size_t i = node.size() + 1, digits = 0;
    while (i < rest.size() && std::isdigit(static_cast<unsigned char>(rest[i]))) ++i, ++digits;
    return digits > 0 && (i == rest.size() || rest[i] == '.');
  };
  auto sweep_dir = [&](const std::string& dir, bool node_own) {
    for (const auto& e : fs::directory_iterator(dir, ec)) {
      const std::string name = e.path().filename().string();
      const std::string id = e.path().stem().string();  // "<id>.zip" → "<id>"
      if (!IsTemporary(name) && ids.count(id)) continue;
      if (shared && !node_own && !own(name) && !OlderThan(e.path(), kSharedSweepAge)) continue;
      *swept += fs::remove_all(e.path(), ec) > 0;
    }
  };
  sweep_dir(DatasetsDir(), false);
  sweep_dir(data + "/packs", false);
  sweep_dir(node_dir + "/cache/zips", true);
  sweep_dir(node_dir + "/cache/previews", true);
}

Status Server::Impl::RefreshTokens() {
  auto set = std::make_shared<TokenSet>(file_tokens);
  if (options.db_tokens) {
    auto stored = store->ListTokens();
    if (!stored.ok()) return stored.status();
    for (const auto& t : *stored) set->AddHashed(t.sha256_hex, t.write);
  }
  std::lock_guard<std::mutex> lock(tokens_mutex);
  tokens = std::move(set);
  return Status::Ok();
}

void Server::Impl::RegisterRoutes() {
  const auto& o = options;
  // Timeouts, keep-alive and TCP_NODELAY are the connection layer's (http_gate.cc), which
  // takes its limits in Start().
  http.set_payload_max_length(size_t(o.max_upload_bytes));

  // Authorisation before routing (and before an upload body is read).
  http.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    t_request_start = std::chrono::steady_clock::now();
    if (RejectMalformedTarget(req, res)) return httplib::Server::HandlerResponse::Handled;
    if (!auth_on) return httplib::Server::HandlerResponse::Unhandled;
    const std::string& p = req.path;
    // Static pages and the model list hold nothing of anyone's: readable without a token.
    const bool open = p == "/" || p == "/healthz" || p == "/metrics" || p == "/api/v1/healthz" ||
                      p == "/api/v1/metrics" || p == "/api/v1/models" ||
                      p.rfind("/api/v1/viewer/static/", 0) == 0;
    const bool write = req.method == "POST" || req.method == "DELETE" || req.method == "PUT";
    if (open && !write) return httplib::Server::HandlerResponse::Unhandled;
    if (!write && options.public_read) return httplib::Server::HandlerResponse::Unhandled;
    std::string auth = req.get_header_value("Authorization");
    // Browsers cannot set headers on <img> or page loads: ?token= is accepted for reads.
    if (auth.empty() && !write && req.has_param("token"))
      auth = "Bearer " + req.get_param_value("token");
    switch (Tokens()->Check(auth, write ? Access::kWrite : Access::kRead)) {
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
    AddSecurityHeaders(res);
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_request_start).count();
    metrics.ObserveRequest(RouteOf(req.path), req.method, res.status, s);
  });
  http.set_logger([](const httplib::Request& req, const httplib::Response& res) {
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
    const auto counts = CountByState();
    const Status db = store->Ping();
    if (!db.ok()) LogEvent("error", "database_unreachable", {{"error", db.message()}});
    SendJson(res, db.ok() ? 200 : 503,
             {{"status", draining  ? "draining"
                         : db.ok() ? "ok"
                                   : "database unreachable"},
              {"version", kMatfitVersion},
              {"node", node},
              {"database",
               {{"engine", store->Engine()},
                {"reachable", db.ok()},
                {"error", db.ok() ? json(nullptr) : json("the job database does not answer")}}},
              {"workers", options.workers},
              {"queued", counts.at(JobState::kQueued)},
              {"running", counts.at(JobState::kRunning)},
              {"renderer", previews->Description()}});
  };
  http.Get("/healthz", health);
  http.Get("/api/v1/healthz", health);
  auto metrics_page = [this](const httplib::Request&, httplib::Response& res) {
    std::map<std::string, int64_t> jobs;
    for (const auto& [s, n] : CountByState()) jobs[JobStateName(s)] = n;
    int busy;
    {
      std::lock_guard<std::mutex> lock(mutex);
      busy = int(live.size());
    }
    std::string page = metrics.Render(jobs, jobs["queued"], options.workers, busy);
    if (const auto counters = store->Counters(); !counters.empty()) {
      page +=
          "# HELP matfit_cluster_jobs_finished_total Jobs finished by any node, by state.\n"
          "# TYPE matfit_cluster_jobs_finished_total counter\n";
      for (const char* st : {"succeeded", "failed", "cancelled"}) {
        const auto it = counters.find(std::string("jobs_finished_total:") + st);
        page += std::string("matfit_cluster_jobs_finished_total{state=\"") + st + "\"} " +
                std::to_string(it == counters.end() ? 0 : it->second) + "\n";
      }
      const auto it = counters.find("lease_takeovers_total");
      page +=
          "# HELP matfit_cluster_lease_takeovers_total Running jobs re-run by another node after "
          "their node's lease ran out.\n# TYPE matfit_cluster_lease_takeovers_total counter\n"
          "matfit_cluster_lease_takeovers_total " +
          std::to_string(it == counters.end() ? 0 : it->second) + "\n";
    }
    page +=
        "# HELP matfit_node_info This node (the job counts above are the whole cluster's).\n"
        "# TYPE matfit_node_info gauge\nmatfit_node_info{node=\"" +
        node + "\",database=\"" + store->Engine() + "\"} 1\n";
    RenderGateStats(http.Stats(), &page);
    res.set_content(page, "text/plain; version=0.0.4");
  };
  http.Get("/metrics", metrics_page);
  http.Get("/api/v1/metrics", metrics_page);
  RegisterJobRoutes();
  RegisterPackRoutes();
  RegisterHomeRoutes();
}

Status Server::Start() {
  Impl& m = *impl_;
  // Every open connection is a descriptor: make room for the connection limit.
  if (rlimit r{}; ::getrlimit(RLIMIT_NOFILE, &r) == 0) {
    const rlim_t want = rlim_t(m.options.max_connections) + 512;
    if (r.rlim_cur < want && r.rlim_cur != RLIM_INFINITY) {
      r.rlim_cur = std::min(want, r.rlim_max);
      ::setrlimit(RLIMIT_NOFILE, &r);
    }
    if (r.rlim_cur < want)
      LogEvent("warn", "descriptor_limit",
               {{"limit", int64_t(r.rlim_cur)}, {"max_connections", m.options.max_connections}});
  }
  m.http.Configure(m.options);
  if (m.options.port == 0) {
    m.port = m.http.bind_to_any_port(m.options.bind);
    if (m.port <= 0) return IoError("cannot bind " + m.options.bind + " on any port");
  } else {
    if (!m.http.bind_to_port(m.options.bind, m.options.port))
      return IoError("cannot listen on " + m.options.bind + ":" + std::to_string(m.options.port) +
                     " (in use, or not allowed); choose another --port");
    m.port = m.options.port;
  }
  m.http.RaiseBacklog(std::min(m.options.max_connections, 4096));
  m.http_thread = std::thread([&m] { m.http.listen_after_bind(); });
  // stop() is a no-op until the listener runs: wait, so that an early Shutdown cannot hang.
  while (!m.http.is_running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  for (int i = 0; i < m.options.workers; ++i) m.workers.emplace_back([&m] { m.WorkerLoop(); });
  if (m.store->Shared()) m.heartbeat = std::thread([&m] { m.HeartbeatLoop(); });
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
  m.http.StopConnections();  // requests being served finish; waiting connections close
  m.draining = true;         // workers take no new job
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
    std::lock_guard<std::mutex> lock(m.mutex);
    m.heartbeat_stop = true;
  }
  m.heartbeat_cv.notify_all();
  if (m.heartbeat.joinable()) m.heartbeat.join();
  // A last try for final states the database has not taken (left "running", a job would be
  // re-queued at the next start).
  if (Status st = m.RetryPending(true); !st.ok())
    LogEvent("error", "job_state_unsaved", {{"error", st.message()}});
  {
    std::lock_guard<std::mutex> lock(m.shutdown_mutex);
    m.shutdown_done = true;
    m.shutdown_cv.notify_all();  // under the lock: a waiter may destroy the server right after
  }
  LogEvent("info", "stopped", json::object());
}

}  // namespace matfit::server
