// Connection handling of `matfit serve` in front of cpp-httplib's request processing.
//
// cpp-httplib 0.11 runs each connection in a pool thread for its whole life and restarts its read
// timeout on every byte, so a few dozen clients trickling a request head hold every thread. Here
// the library only accepts: each accepted socket goes to one event loop (epoll) that waits, with
// no thread per connection, until the request head is complete in the kernel's receive buffer
// (MSG_PEEK), under an absolute deadline from the head's first byte and a size limit. Only then
// is the connection handed to a request worker, which runs httplib's own request parser, router
// and response writer on it once and hands a keep-alive connection back to the loop.
//
// Workers form two lanes: requests without a body (reads, polls, deletes) and requests with one
// (submissions), so uploads never delay /healthz or job polling. In each lane one client
// address is served at most `max_client_requests` at a time; bodies and responses must keep a
// minimum average rate after a grace period. Open connections are capped in all and per address.
#pragma once

#include <httplib.h>

#include <cstdint>
#include <memory>
#include <string>

namespace matfit::server {

struct ServerOptions;

// Counters of the connection layer, for /metrics.
struct GateStats {
  int64_t open = 0;               // connections open now
  int64_t waiting_head = 0;       // of which waiting in the event loop
  int64_t refused_client = 0;     // refused: the address had max_client_connections
  int64_t refused_server = 0;     // refused: max_connections reached
  int64_t head_timeouts = 0;      // heads not complete by the header deadline (408)
  int64_t head_too_large = 0;     // heads over the size limit (431)
  int64_t transfer_timeouts = 0;  // bodies or responses cut below the minimum rate
};

// Appends the counters to a Prometheus text page (matfit_http_connections…).
void RenderGateStats(const GateStats& s, std::string* out);

class GatedHttpServer : public httplib::Server {
 public:
  // Request heads are limited to this many bytes (request line and headers).
  static constexpr size_t kMaxHeadBytes = 16 << 10;

  GatedHttpServer();
  ~GatedHttpServer() override;

  // Takes the limits; call once before listening.
  void Configure(const ServerOptions& options);
  // After stop(): closes waiting connections, lets workers finish the requests they are serving,
  // closes queued ones and joins every thread. Idempotent.
  void StopConnections();
  GateStats Stats() const;
  // After binding: a listen backlog of n (the library's is 5).
  void RaiseBacklog(int n);

  struct Impl;

 private:
  friend struct Impl;
  bool process_and_close_socket(socket_t sock) override;  // called on the accept thread
  // One request on a stream whose head is complete: httplib's parser, router and writer.
  bool ServeOne(httplib::Stream& strm, bool close_connection, bool& connection_closed);

  std::unique_ptr<Impl> impl_;
};

}  // namespace matfit::server
