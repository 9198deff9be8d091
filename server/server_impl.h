// Internals of Server shared by its source files (server.cc: lifecycle and workers;
// routes_jobs.cc, routes_packs.cc: the HTTP handlers). Not part of the module's interface.
#pragma once

#include <httplib.h>

#include <atomic>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "server/auth.h"
#include "server/http_gate.h"
#include "server/job_store.h"
#include "server/metrics.h"
#include "server/preview.h"
#include "server/preview_cache.h"
#include "server/server.h"

namespace matfit::server {

double NowSeconds();  // Unix time

// A job a worker is running: its cancel flags and live progress (persisted ~1/s).
struct LiveJob {
  std::atomic<bool> cancel{false};
  std::atomic<bool> lease_lost{false};  // another node took the job over: drop the result
  std::atomic<bool> finishing{false};   // its final state is being written
  int attempt = 0;                      // the attempt this worker runs (its lease's fence)
  std::mutex mutex;
  double fraction = 0, started = 0;
  std::string stage;
};

// A job's final state that the database has not taken yet (disk full, I/O error). GET and
// DELETE show it; it is written again, with backoff, until it lands.
struct PendingFinal {
  JobFinal final_state;
  JobLease lease;
  std::string staging;  // the pack of a success, to publish (PublishPack)
  int tries = 0;
  double delay = 0.5, next_try = 0;  // seconds; Unix time of the next write
};

struct Server::Impl {
  ServerOptions options;
  std::string data;      // absolute data folder (shared by the nodes of a cluster)
  std::string node;      // this node's id ("local" for a single process without --node-id)
  std::string node_dir;  // this node's own files: `data`, or data/nodes/<node> in a cluster
  bool auth_on = false;  // --token-file or --db-tokens: every request outside the open set
                         // needs a token (an empty set then refuses them all)
  TokenSet file_tokens;  // from --token-file
  std::mutex tokens_mutex;
  std::shared_ptr<const TokenSet> tokens;  // file tokens + the database's (refreshed)
  std::shared_ptr<const TokenSet> Tokens() {
    std::lock_guard<std::mutex> lock(tokens_mutex);
    return tokens;
  }
  // Rebuilds `tokens` from the file's and, with --db-tokens, the database's.
  Status RefreshTokens();
  std::unique_ptr<JobStore> store;
  Metrics metrics;
  std::unique_ptr<PreviewRenderer> previews;
  std::unique_ptr<PreviewCache> preview_cache;
  GatedHttpServer http;  // httplib parses and routes; server/http_gate.h holds connections
  std::thread http_thread;
  std::vector<std::thread> workers;
  std::thread heartbeat;  // renews the leases of this node's jobs (shared stores only)
  int port = 0;
  int lock_fd = -1;  // flock on DATA/lock: one server per data folder
  ~Impl();

  std::mutex mutex;  // guards live, and is the workers' wake-up lock
  std::condition_variable wake, idle;
  std::map<std::string, std::shared_ptr<LiveJob>> live;
  std::atomic<bool> draining{false}, hard_stop{false}, stopped{false};
  bool heartbeat_stop = false;  // guarded by mutex
  std::condition_variable heartbeat_cv;
  std::mutex pending_mutex;  // guards pending
  std::map<std::string, PendingFinal> pending;
  std::mutex shutdown_mutex;
  std::condition_variable shutdown_cv;
  bool shutdown_done = false;

  // Folders under `data`.
  // Folders: datasets and packs are shared by a cluster's nodes; uploads in progress and the
  // caches are each node's own.
  std::string UploadsDir() const { return node_dir + "/uploads"; }
  std::string DatasetsDir() const { return data + "/datasets"; }
  std::string PackDir(const std::string& id) const { return data + "/packs/" + id; }
  // Where an attempt writes its pack before PublishPack moves it to PackDir.
  std::string StagingDir(const std::string& id, int attempt) const {
    return data + "/packs/." + id + ".tmp-run-" + node + "-" + std::to_string(attempt);
  }
  std::string ZipPath(const std::string& id) const {
    return node_dir + "/cache/zips/" + id + ".zip";
  }
  std::string PreviewDir(const std::string& id) const { return node_dir + "/cache/previews/" + id; }

  void RegisterRoutes();
  void RegisterJobRoutes();
  void RegisterPackRoutes();
  void RegisterHomeRoutes();  // routes_home.cc: the landing page, the model list
  void WorkerLoop();
  void RunOne(const JobRecord& job);
  void HeartbeatLoop();
  // Moves an attempt's staged pack to PackDir(id), replacing an unpublished one left by an
  // attempt that died between its move and its commit. Runs inside the store's Finish.
  Status PublishPack(const std::string& id, const std::string& staging);
  void Sweep(int* swept, size_t* jobs);  // start-up: partial uploads, temporaries, orphans
  // The one way a job's final state is recorded: written at once (retrying briefly); when the
  // database cannot take it, kept in `pending` and written again by RetryPending.
  void RecordFinal(const std::string& id, PendingFinal final_state);
  // An attempt whose lease was lost: its staged pack is removed, nothing is recorded.
  void DropAttempt(const std::string& id, const PendingFinal& f, const Status& why);
  // One try at writing a final state. A success whose staged pack has gone (NotFound from
  // PublishPack) cannot be published: it is recorded as failed instead of retried forever.
  Status TryFinish(const std::string& id, PendingFinal* f);
  // Writes the pending final states that are due (all of them with force); returns the status
  // of writing `only` when given (only that one is tried then).
  Status RetryPending(bool force, const std::string& only = "");
  // A job as the store has it, with its pending final state applied; nullopt when unknown.
  std::optional<JobRecord> GetJob(const std::string& id);
  // Applies a pending final state to a record read from the store; true when there was one.
  bool ApplyPending(JobRecord* j);
  std::map<JobState, int64_t> CountByState();  // the store's counts, pending states applied
  nlohmann::json JobJson(const JobRecord& j);
  // What a pack names as its input: "upload ID/NAME" for uploads (NAME: the archive's top
  // folder, if any), the folder the client named otherwise.
  std::string SourceLabel(const JobRecord& j) const;
  // `message` for a client: the server's own folders removed (paths in an uploaded dataset
  // become relative to it, other paths relative to the data folder). The log keeps the original.
  std::string ForClients(std::string message, const JobRecord* job = nullptr) const;
  void RemoveJobFiles(const JobRecord& j);
};

// {"error": {"status": S, "message": M[, "field": F]}} with status S.
void SendError(httplib::Response& res, int status, const std::string& message,
               const std::string& field = "");
void SendJson(httplib::Response& res, int status, const nlohmann::json& body);
// The same error body, then the connection is closed: for replies sent before the request body
// was read to its end (cpp-httplib 0.11 would otherwise parse the rest as a next request). The
// body goes out through a content provider that reports failure once it has written everything,
// which makes the library drop the keep-alive connection.
void SendErrorAndClose(httplib::Response& res, int status, const std::string& message,
                       const std::string& field = "");
// Refuses (400, closing the connection) a request whose path has a control byte (a NUL would
// cut the file name short: `material.json%00.html`) or is not UTF-8, or whose query parameter
// names or values are not UTF-8 text (they end up in JSON). True when it did.
bool RejectMalformedTarget(const httplib::Request& req, httplib::Response& res);
// X-Content-Type-Options: nosniff on every response, and a Content-Security-Policy that allows
// nothing (no scripts, sandboxed) on every response that is not the viewer's HTML page.
void AddSecurityHeaders(httplib::Response& res);
// Streams a file (never loaded whole into memory); 404 JSON when it is missing.
void SendFile(httplib::Response& res, const std::string& path, const std::string& content_type);
// Content types by route, never from a client's path: a file of a pack (only the kinds a pack
// holds; anything else is application/octet-stream, never HTML) and an embedded viewer file.
std::string PackFileType(const std::string& name);
std::string ViewerFileType(const std::string& name);
// Route label for metrics: the pattern, not the raw path ("/api/v1/jobs/{id}").
std::string RouteOf(const std::string& path);

}  // namespace matfit::server
