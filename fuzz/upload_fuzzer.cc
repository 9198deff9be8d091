// The service's front door (server/http_gate.cc, routes_jobs.cc): the input is a whole raw HTTP
// request — head, multipart body, archive — sent over loopback to an in-process `matfit serve`.
// The server must answer or close, and keep serving (checked with /healthz every 256 inputs).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>

#include "fuzz/fuzz_util.h"
#include "server/server.h"

using namespace matfit;

namespace {

server::Server* Serve() {
  static std::unique_ptr<server::Server> s = [] {
    server::ServerOptions o;
    o.port = 0, o.quiet = true, o.workers = 1;
    o.data_dir = fuzz::ScratchDir() + "/serve";
    o.max_upload_bytes = 1 << 20;
    o.header_timeout_s = 1, o.request_timeout_s = 1, o.transfer_grace_s = 1;
    o.keep_alive_timeout_s = 0.5, o.drain_seconds = 0;
    auto created = server::Server::Create(o);
    if (!created.ok() || !(*created)->Start().ok()) std::abort();
    return std::move(*created);
  }();
  return s.get();
}

// A connection to the server, with 3 s send/receive timeouts. A connect that fails is retried,
// with its errno on stderr, for about 20 s (session 33: one connect of the README test command's
// 20 s run failed on this 2-core machine, after 959 inputs; three reruns of the same seed and the
// saved input alone passed); a server that still takes no connection has stopped serving, and
// the run aborts.
int Connect(int port) {
  for (int attempt = 1;; ++attempt) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0) std::abort();
    timeval tv{3, 0};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
    sockaddr_in a{};
    a.sin_family = AF_INET, a.sin_port = htons(uint16_t(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0) return fd;
    const int err = errno;
    close(fd);
    std::fprintf(stderr, "upload_fuzzer: connect to port %d failed (attempt %d): %s\n", port,
                 attempt, std::strerror(err));
    if (attempt == 5) std::abort();  // no connection for ~20 s: the server stopped serving
    sleep(1);
  }
}

// Sends `request`, half-closes, and reads the answer until the server closes (or 3 s).
std::string Exchange(int port, const std::string& request) {
  const int fd = Connect(port);
  for (size_t sent = 0; sent < request.size();) {
    const ssize_t n = send(fd, request.data() + sent, request.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) break;  // the server may close early (413, 400): fine
    sent += size_t(n);
  }
  shutdown(fd, SHUT_WR);
  std::string answer;
  char buf[4096];
  for (ssize_t n; (n = recv(fd, buf, sizeof buf, 0)) > 0;) answer.append(buf, size_t(n));
  close(fd);
  return answer;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static int inputs = 0;
  const int port = Serve()->port();
  (void)Exchange(port, std::string(reinterpret_cast<const char*>(data), size));
  if (++inputs % 256 == 0 &&
      Exchange(port, "GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
              .rfind("HTTP/1.1 200", 0) != 0)
    std::abort();  // a hostile request left the server unable to serve
  return 0;
}
