// The material service (`matfit serve`): HTTP API under /api/v1, durable jobs in SQLite, a
// worker pool running the CLI's fit/leaf controllers, packs and previews from a data folder.
// API reference: docs/openapi.json; behaviour: docs/server.md.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/status.h"
#include "server/archive.h"

namespace matfit::server {

struct ServerOptions {
  std::string bind = "127.0.0.1";
  int port = 8080;                              // 0: any free port (tests)
  std::string data_dir;                         // everything the server writes lives here
  int workers = 1;                              // jobs that run at once
  std::string token_file;                       // empty: no auth (allowed only on a loopback bind)
  bool public_read = false;                     // GETs need no token even with a token file
  std::vector<std::string> allow_roots;         // folders whose datasets may be named by path
  int64_t max_upload_bytes = int64_t(4) << 30;  // request body limit, 4 GiB
  ArchiveLimits archive;
  // Decompression bombs: a dataset's images × width × height × channels, from the image headers
  // at submission (422) and again when the job reads them. 2×10⁹ samples: 2 GB as 8-bit codes,
  // 8 GB as float.
  int64_t max_stack_samples = 2'000'000'000;
  double drain_seconds = 10;  // on shutdown: wait this long for running jobs, then re-queue
  std::string render_backend = "auto";  // previews: auto, egl, cpu
  // Previews: the cache's total size (least recently used files go first), and how many
  // renders may wait in each lane (small ≤ 256², large) before more get 503.
  int64_t preview_cache_bytes = int64_t(256) << 20;
  int preview_queue = 8;
  bool quiet = false;  // no request log lines (errors are still logged)

  // A cluster of nodes (docs/scale-out.md): a postgresql:// URL puts the jobs in PostgreSQL,
  // shared by every node started with the same URL and the same --data folder (a shared
  // filesystem). Empty: SQLite at DATA/jobs.db, one process.
  std::string database_url;
  std::string node_id;  // this node's name ([A-Za-z0-9._-], ≤ 64); empty: host-port
  // A running job's lease: renewed every third of it; a node that stops renewing (killed, cut
  // off) loses its jobs to the other nodes this long after its last renewal.
  double lease_seconds = 30;
  // Accept the bearer tokens kept in the cluster's database (`matfit tokens add`), re-read
  // every lease/3 seconds, besides --token-file's. Needs database_url.
  bool db_tokens = false;

  // Connections (server/http_gate.h). Open connections wait for their request head in one
  // event loop, not in a thread; only complete heads reach the request workers.
  int http_threads = 16;             // workers for requests without a body (reads, polls, deletes)
  int upload_slots = 4;              // workers for requests with a body (submissions)
  int max_connections = 1000;        // open connections in all; more are answered 503
  int max_client_connections = 32;   // open connections per client address; more get 503
  int max_client_requests = 8;       // requests of one address served at once (per lane)
  double header_timeout_s = 10;      // a request head must be complete this long after it began
  double keep_alive_timeout_s = 5;   // an idle keep-alive connection is closed after this
  int request_timeout_s = 60;        // longest silence within a body or a response
  double transfer_grace_s = 10;      // a body/response may take grace + bytes / min rate
  double min_transfer_rate = 16384;  // bytes/s a body or response must average after the grace

  bool Check(std::string* why) const;
};

class Server {
 public:
  // Prepares the data folder (sweeping partial uploads, temporaries and orphans), opens the
  // job database and re-queues jobs a dead process left running.
  static StatusOr<std::unique_ptr<Server>> Create(const ServerOptions& options);
  ~Server();  // Shutdown()
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds the port and starts the HTTP threads and workers; returns once listening.
  Status Start();
  int port() const;
  // Blocks until Shutdown() has finished (from another thread or a signal handler thread).
  void Wait();
  // Stops accepting requests, lets running jobs finish for drain_seconds, then cancels and
  // re-queues them; joins every thread. Idempotent.
  void Shutdown();

 private:
  struct Impl;
  explicit Server(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace matfit::server
