// `matfit serve`: the material service (server/). SIGTERM / SIGINT shut it down gracefully:
// no new requests, running jobs get --drain-seconds to finish, then are re-queued.
#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <memory>
#include <thread>

#include <pthread.h>

#include "app/commands.h"
#include "core/parallel.h"
#include "server/server.h"

namespace matfit::app {
namespace {

struct ServeArgs {
  server::ServerOptions o;
  int64_t max_upload_mib = 4096, max_unpacked_mib = 8192, preview_cache_mib = 256;
  int64_t max_stack_msamples = 2000;  // million samples
  int threads = 0;
};

int RunServe(ServeArgs& a) {
  a.o.max_upload_bytes = a.max_upload_mib << 20;
  a.o.archive.max_unpacked_bytes = a.max_unpacked_mib << 20;
  a.o.preview_cache_bytes = a.preview_cache_mib << 20;
  a.o.max_stack_samples = a.max_stack_msamples * 1'000'000;
  SetNumThreads(a.threads);
  // Block the shutdown signals in every thread; one thread waits for them.
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGINT);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  std::signal(SIGPIPE, SIG_IGN);  // a client that hangs up must not kill the server

  auto s = server::Server::Create(a.o);
  if (!s.ok()) return Fail("serve", s.status().message().c_str());
  if (Status st = (*s)->Start(); !st.ok()) return Fail("serve", st.message().c_str());
  std::fprintf(stderr, "matfit serve: listening on http://%s:%d/api/v1 (data %s)\n",
               a.o.bind.c_str(), (*s)->port(), a.o.data_dir.c_str());
  server::Server* srv = s->get();
  std::thread waiter([set, srv] {
    int sig = 0;
    sigwait(&set, &sig);
    srv->Shutdown();
  });
  srv->Wait();
  waiter.join();
  return 0;
}

}  // namespace

void RegisterServe(CLI::App& app, int* exit_code) {
  auto args = std::make_shared<ServeArgs>();
  auto& o = args->o;
  CLI::App* sub = app.add_subcommand("serve", "Run the material service (HTTP API, job queue)");
  sub->add_option("--port", o.port, "TCP port (0 = any free port)")->capture_default_str();
  sub->add_option("--bind", o.bind, "address to listen on")->capture_default_str();
  sub->add_option("--data", o.data_dir, "data folder: job database, datasets, packs, caches")
      ->required();
  sub->add_option("--workers", o.workers, "jobs that run at once")->capture_default_str();
  sub->add_option("--db", o.database_url,
                  "job database of a cluster: postgresql://user@host:port/db, shared by every "
                  "node with the same --data folder (default: DATA/jobs.db, SQLite)");
  sub->add_option("--node-id", o.node_id,
                  "this node's name in a cluster (default: host-port); one process per name");
  sub->add_flag("--db-tokens", o.db_tokens,
                "also accept the bearer tokens kept in the cluster's database (matfit tokens)");
  sub->add_option("--lease-seconds", o.lease_seconds,
                  "a running job's lease: another node re-runs it this long after its node "
                  "stopped renewing it")
      ->capture_default_str();
  sub->add_option("--threads", args->threads, "compute threads per process (0 = all cores)")
      ->capture_default_str();
  sub->add_option("--token-file", o.token_file,
                  "bearer tokens, one per line: TOKEN [write|read] (no file: no auth, loopback "
                  "only)");
  sub->add_flag("--public-read", o.public_read, "GET endpoints need no token");
  sub->add_option("--allow-root", o.allow_roots,
                  "folder whose datasets may be submitted by path (repeatable)");
  sub->add_option("--max-upload-mib", args->max_upload_mib, "upload size limit in MiB")
      ->capture_default_str();
  sub->add_option("--max-unpacked-mib", args->max_unpacked_mib,
                  "unpacked archive size limit in MiB")
      ->capture_default_str();
  sub->add_option("--max-entries", o.archive.max_entries, "archive entry count limit")
      ->capture_default_str();
  sub->add_option("--max-folders", o.archive.max_folders,
                  "archive folder count limit (folders cost the disk an inode each)")
      ->capture_default_str();
  sub->add_option("--max-unpack-ratio", o.archive.max_unpack_ratio,
                  "an archive unpacks to at most this many times its size (at least 64 MiB; "
                  "0 = only --max-unpacked-mib)")
      ->capture_default_str();
  sub->add_option("--max-stack-msamples", args->max_stack_msamples,
                  "largest dataset in million samples (images × width × height × channels), "
                  "judged from the image headers at submission (422)")
      ->capture_default_str();
  sub->add_option("--request-timeout", o.request_timeout_s,
                  "longest silence within a request body or a response, s")
      ->capture_default_str();
  sub->add_option("--header-timeout", o.header_timeout_s,
                  "a request head must be complete this long after its first byte, s (408)")
      ->capture_default_str();
  sub->add_option("--keep-alive-timeout", o.keep_alive_timeout_s,
                  "idle keep-alive connections are closed after this, s")
      ->capture_default_str();
  sub->add_option("--transfer-grace", o.transfer_grace_s,
                  "a body or response may take this long plus its bytes / --min-transfer-rate, s")
      ->capture_default_str();
  sub->add_option("--min-transfer-rate", o.min_transfer_rate,
                  "bytes/s a body or response must average after the grace (slower: cut)")
      ->capture_default_str();
  sub->add_option("--max-connections", o.max_connections,
                  "open connections in all (more are answered 503)")
      ->capture_default_str();
  sub->add_option("--max-client-connections", o.max_client_connections,
                  "open connections per client address (more are answered 503)")
      ->capture_default_str();
  sub->add_option("--max-client-requests", o.max_client_requests,
                  "requests of one client address served at once, per lane")
      ->capture_default_str();
  sub->add_option("--http-threads", o.http_threads,
                  "request workers for requests without a body (reads, polls, deletes)")
      ->capture_default_str();
  sub->add_option("--upload-slots", o.upload_slots,
                  "request workers for requests with a body (submissions)")
      ->capture_default_str();
  sub->add_option("--drain-seconds", o.drain_seconds,
                  "on SIGTERM: how long running jobs may finish before they are re-queued")
      ->capture_default_str();
  sub->add_option("--render-backend", o.render_backend, "previews: auto, egl or cpu")
      ->capture_default_str();
  sub->add_option("--preview-cache-mib", args->preview_cache_mib,
                  "preview cache size in MiB; least recently used previews go first (0: none)")
      ->capture_default_str();
  sub->add_option("--preview-queue", o.preview_queue,
                  "previews that may wait per render lane (<= 256² and larger); more get 503")
      ->capture_default_str();
  sub->add_flag("--quiet", o.quiet, "no request log lines");
  sub->callback([args, exit_code] { *exit_code = RunServe(*args); });
}

}  // namespace matfit::app
