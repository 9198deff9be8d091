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
  int request_timeout_s = 60;  // socket read/write inactivity
  double drain_seconds = 10;   // on shutdown: wait this long for running jobs, then re-queue
  std::string render_backend = "auto";  // previews: auto, egl, cpu
  int http_threads =
      32;              // one per open connection (cpp-httplib keeps a thread per keep-alive client)
  bool quiet = false;  // no request log lines (errors are still logged)

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
