#include "server/http_gate.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>
#include <unordered_map>
#include <vector>

#include "server/log.h"
#include "server/server.h"

namespace matfit::server {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }
Clock::duration Duration(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

// Runs httplib's per-socket task on the accept thread: our process_and_close_socket only hands
// the socket to the event loop, so no pool is needed there.
class InlineQueue : public httplib::TaskQueue {
 public:
  void enqueue(std::function<void()> fn) override { fn(); }
  void shutdown() override {}
};

void AddressOf(const sockaddr_storage& a, std::string* ip, int* port) {
  char buf[INET6_ADDRSTRLEN] = "";
  if (a.ss_family == AF_INET) {
    const auto& v4 = reinterpret_cast<const sockaddr_in&>(a);
    ::inet_ntop(AF_INET, &v4.sin_addr, buf, sizeof buf);
    *port = ntohs(v4.sin_port);
  } else if (a.ss_family == AF_INET6) {
    const auto& v6 = reinterpret_cast<const sockaddr_in6&>(a);
    ::inet_ntop(AF_INET6, &v6.sin6_addr, buf, sizeof buf);
    *port = ntohs(v6.sin6_port);
  }
  *ip = buf;
}

std::string FormatSeconds(double s) {
  char b[32];
  std::snprintf(b, sizeof b, "%g s", s);
  return b;
}

// A short complete response written without blocking (best effort: the socket is closed next).
void SendBrief(int fd, int status, const char* reason, const std::string& message) {
  const std::string body =
      nlohmann::json{{"error", {{"status", status}, {"message", message}}}}.dump(
          -1, ' ', false, nlohmann::json::error_handler_t::replace);
  const std::string head = "HTTP/1.1 " + std::to_string(status) + " " + reason +
                           "\r\nContent-Type: application/json\r\nConnection: close\r\n"
                           "Cache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\n" +
                           (status == 503 ? "Retry-After: 1\r\n" : "") +
                           "Content-Length: " + std::to_string(body.size()) + "\r\n\r\n";
  const std::string all = head + body;
  (void)::send(fd, all.data(), all.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
}

}  // namespace

namespace gate_detail {

// ---------------------------------------------------------------------------------------------
// A connection, owned by exactly one of: the event loop, a lane's queue, a worker.
struct Conn {
  int fd = -1;
  std::string ip, local_ip;
  int port = 0, local_port = 0;
  std::string buf;  // bytes read from the socket but not yet consumed (read-ahead)
  size_t pos = 0;
  bool idle = true;   // between requests: no byte of the next head yet
  bool body = false;  // the pending request has a body (upload lane)
  int served = 0;     // requests served on this connection
  Clock::time_point deadline;

  size_t Buffered() const { return buf.size() - pos; }
};

// The stream httplib reads and writes through: the connection's read-ahead buffer first, then
// the socket, each wait bounded by the request's deadlines (not restarted per byte).
class DeadlineStream : public httplib::Stream {
 public:
  DeadlineStream(Conn& c, const ServerOptions& o) : c_(c), o_(o) {}

  bool TimedOut() const { return timed_out_; }

  bool is_readable() const override { return c_.Buffered() > 0 || Wait(POLLIN, ReadDeadline()); }
  bool is_writable() const override { return Wait(POLLOUT, WriteDeadline()); }

  ssize_t read(char* ptr, size_t size) override {
    if (c_.Buffered() == 0) {
      if (!Wait(POLLIN, ReadDeadline())) return -1;
      c_.buf.resize(kChunk);
      c_.pos = 0;
      ssize_t n;
      do n = ::recv(c_.fd, c_.buf.data(), kChunk, 0);
      while (n < 0 && errno == EINTR);
      if (n <= 0) {
        c_.buf.clear();
        return n;
      }
      c_.buf.resize(size_t(n));
      last_read_ = Clock::now();
    }
    const size_t n = std::min(size, c_.Buffered());
    std::memcpy(ptr, c_.buf.data() + c_.pos, n);
    c_.pos += n;
    read_ += n;
    if (c_.Buffered() == 0) c_.buf.clear(), c_.pos = 0;
    return ssize_t(n);
  }

  ssize_t write(const char* ptr, size_t size) override {
    if (!wrote_) wrote_ = true, first_write_ = Clock::now();
    if (!Wait(POLLOUT, WriteDeadline())) return -1;
    ssize_t n;
    do n = ::send(c_.fd, ptr, size, MSG_NOSIGNAL);
    while (n < 0 && errno == EINTR);
    if (n > 0) written_ += size_t(n), last_write_ = Clock::now();
    return n;
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = c_.ip, port = c_.port;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = c_.local_ip, port = c_.local_port;
  }
  socket_t socket() const override { return c_.fd; }

 private:
  static constexpr size_t kChunk = 16 << 10;

  // A body must arrive within grace + bytes/rate of the request's start, with no silence
  // longer than the request timeout; a response likewise from its first byte.
  Clock::time_point ReadDeadline() const {
    return std::min(last_read_ + std::chrono::seconds(o_.request_timeout_s),
                    start_ + Duration(o_.transfer_grace_s + double(read_) / o_.min_transfer_rate));
  }
  Clock::time_point WriteDeadline() const {
    return std::min(
        Clock::now() + std::chrono::seconds(o_.request_timeout_s),
        first_write_ + Duration(o_.transfer_grace_s + double(written_) / o_.min_transfer_rate));
  }
  bool Wait(short events, Clock::time_point deadline) const {
    for (;;) {
      const double left = Seconds(deadline - Clock::now());
      if (left <= 0) return timed_out_ = true, false;
      pollfd p{c_.fd, events, 0};
      const int r = ::poll(&p, 1, int(std::min(left * 1e3 + 1, 1e6)));
      if (r > 0) return (p.revents & (events | POLLHUP | POLLERR)) != 0;
      if (r < 0 && errno != EINTR) return false;
    }
  }

  Conn& c_;
  const ServerOptions& o_;
  const Clock::time_point start_ = Clock::now();
  Clock::time_point last_read_ = start_, first_write_ = start_, last_write_ = start_;
  size_t read_ = 0, written_ = 0;
  bool wrote_ = false;
  mutable bool timed_out_ = false;
};

}  // namespace gate_detail

using gate_detail::Conn;
using gate_detail::DeadlineStream;

// ---------------------------------------------------------------------------------------------
struct GatedHttpServer::Impl {
  GatedHttpServer& http;
  ServerOptions o;
  bool configured = false;

  // Event loop.
  int epoll_fd = -1, wake_fd = -1;
  std::thread loop;
  std::vector<std::unique_ptr<Conn>> inbox;  // admitted or returned, not yet in the loop
  std::unordered_map<Conn*, std::unique_ptr<Conn>> waiting;  // owned by the loop thread

  // Lanes: 0 = no body, 1 = body.
  struct Lane {
    std::deque<std::unique_ptr<Conn>> queue;
    std::map<std::string, int> active;  // requests being served per address
    std::condition_variable cv;
    std::vector<std::thread> threads;
  };
  Lane lanes[2];

  mutable std::mutex mutex;                // inbox, lanes, per-address counts, stats
  std::map<std::string, int> per_address;  // open connections per address
  GateStats stats;
  std::atomic<bool> stopping{false};
  bool stopped = false;

  explicit Impl(GatedHttpServer& h) : http(h) {}

  void Start();
  void Stop();
  void Admit(int fd);
  void Enqueue(std::unique_ptr<Conn> c);  // to the loop (thread-safe)
  void LoopMain();
  // Loop thread: dispatch a complete head, refuse, or keep waiting; `hangup`: the peer has
  // closed its side (an unfinished head then never completes).
  void Examine(std::unique_ptr<Conn>& c, bool hangup);
  void Close(std::unique_ptr<Conn> c, int status = 0, const char* reason = nullptr,
             const std::string& message = {});
  void WorkerMain(int lane);
  void Serve(std::unique_ptr<Conn> c);
};

namespace {

// Whether a complete head announces a body (Content-Length > 0 or any Transfer-Encoding).
bool HeadHasBody(const std::string& head) {
  size_t at = head.find("\r\n");
  while (at != std::string::npos && at + 2 < head.size()) {
    const size_t start = at + 2, end = head.find("\r\n", start);
    if (end == std::string::npos || end == start) break;
    const std::string line = head.substr(start, end - start);
    const size_t colon = line.find(':');
    if (colon != std::string::npos) {
      std::string name = line.substr(0, colon);
      for (char& ch : name) ch = char(std::tolower(static_cast<unsigned char>(ch)));
      const std::string value = line.substr(colon + 1);
      if (name == "transfer-encoding") return true;
      if (name == "content-length" && value.find_first_of("123456789") != std::string::npos)
        return true;
    }
    at = end;
  }
  return false;
}

}  // namespace

void GatedHttpServer::Impl::Start() {
  epoll_fd = ::epoll_create1(EPOLL_CLOEXEC);
  wake_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.ptr = nullptr;  // the wake-up descriptor
  ::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, wake_fd, &ev);
  loop = std::thread([this] { LoopMain(); });
  for (int lane = 0; lane < 2; ++lane) {
    const int n = lane == 0 ? o.http_threads : o.upload_slots;
    for (int i = 0; i < n; ++i)
      lanes[lane].threads.emplace_back([this, lane] { WorkerMain(lane); });
  }
}

void GatedHttpServer::Impl::Admit(int fd) {
  auto c = std::make_unique<Conn>();
  c->fd = fd;
  sockaddr_storage a{};
  socklen_t len = sizeof a;
  if (::getpeername(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0) AddressOf(a, &c->ip, &c->port);
  len = sizeof a;
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0)
    AddressOf(a, &c->local_ip, &c->local_port);
  const int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  int refuse = 0;
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (stopping) {
      refuse = -1;
    } else if (stats.open >= o.max_connections) {
      refuse = 1, ++stats.refused_server;
    } else if (per_address[c->ip] >= o.max_client_connections) {
      refuse = 2, ++stats.refused_client;
    } else {
      ++per_address[c->ip], ++stats.open;
    }
  }
  if (refuse != 0) {
    if (refuse == 1)
      SendBrief(fd, 503, "Service Unavailable",
                "the server has " + std::to_string(o.max_connections) +
                    " open connections, its limit; retry shortly");
    else if (refuse == 2)
      SendBrief(fd, 503, "Service Unavailable",
                "your address already holds " + std::to_string(o.max_client_connections) +
                    " open connections, the server's limit per client; close some (or reuse "
                    "keep-alive connections) and retry");
    ::shutdown(fd, SHUT_RDWR);
    ::close(fd);
    if (refuse == 2)
      LogEvent("warn", "connection_refused", {{"remote", c->ip}, {"reason", "client_limit"}});
    return;
  }
  c->deadline = Clock::now() + Duration(o.header_timeout_s);
  c->idle = false;  // a new connection has header_timeout_s for its whole first head
  Enqueue(std::move(c));
}

void GatedHttpServer::Impl::Enqueue(std::unique_ptr<Conn> c) {
  {
    std::lock_guard<std::mutex> lock(mutex);
    inbox.push_back(std::move(c));
  }
  const uint64_t one = 1;
  (void)!::write(wake_fd, &one, sizeof one);
}

void GatedHttpServer::Impl::LoopMain() {
  std::vector<epoll_event> events(256);
  while (!stopping) {
    const int n = ::epoll_wait(epoll_fd, events.data(), int(events.size()), 200);
    std::vector<std::unique_ptr<Conn>> arrived;
    {
      std::lock_guard<std::mutex> lock(mutex);
      arrived.swap(inbox);
    }
    for (int i = 0; i < n; ++i) {
      if (events[size_t(i)].data.ptr == nullptr) {
        uint64_t v;
        (void)!::read(wake_fd, &v, sizeof v);
        continue;
      }
      auto it = waiting.find(static_cast<Conn*>(events[size_t(i)].data.ptr));
      if (it == waiting.end()) continue;
      std::unique_ptr<Conn> c = std::move(it->second);
      waiting.erase(it);
      Examine(c, (events[size_t(i)].events & (EPOLLRDHUP | EPOLLHUP | EPOLLERR)) != 0);
    }
    for (auto& c : arrived) {
      epoll_event ev{};
      ev.events = EPOLLIN | EPOLLRDHUP | EPOLLET;
      ev.data.ptr = c.get();
      ::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, c->fd, &ev);
      Examine(c, false);  // bytes may have arrived before registration
    }
    // Deadlines: an idle keep-alive connection closes quietly, an unfinished head gets 408.
    const auto now = Clock::now();
    for (auto it = waiting.begin(); it != waiting.end();) {
      if (now < it->second->deadline) {
        ++it;
        continue;
      }
      std::unique_ptr<Conn> c = std::move(it->second);
      it = waiting.erase(it);
      ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, c->fd, nullptr);
      if (c->idle) {
        Close(std::move(c));
      } else {
        {
          std::lock_guard<std::mutex> lock(mutex);
          ++stats.head_timeouts;
        }
        Close(std::move(c), 408, "Request Timeout",
              "the request head was not complete within " + FormatSeconds(o.header_timeout_s) +
                  " of its first byte; send the request line and headers without pauses");
      }
    }
    std::lock_guard<std::mutex> lock(mutex);
    stats.waiting_head = int64_t(waiting.size());
  }
  for (auto& [p, c] : waiting) {
    ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, c->fd, nullptr);
    Close(std::move(c));
  }
  waiting.clear();
}

void GatedHttpServer::Impl::Examine(std::unique_ptr<Conn>& c, bool hangup) {
  // What is buffered from an earlier read plus what waits in the kernel (peeked, not taken).
  std::string head = c->buf.substr(c->pos);
  const size_t want = kMaxHeadBytes + 1 - std::min(head.size(), kMaxHeadBytes + 1);
  bool eof = false;
  if (want > 0) {
    const size_t had = head.size();
    head.resize(had + want);
    ssize_t n;
    do n = ::recv(c->fd, head.data() + had, want, MSG_PEEK | MSG_DONTWAIT);
    while (n < 0 && errno == EINTR);
    if (n == 0) eof = true;
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK) eof = true;
    head.resize(had + size_t(std::max<ssize_t>(n, 0)));
  }
  // Leading empty lines before a request line are allowed (RFC 9112 §2.2).
  const size_t lead = head.find_first_not_of("\r\n");
  const bool any = lead != std::string::npos;
  if (any && c->idle) {
    c->idle = false;
    c->deadline = Clock::now() + Duration(o.header_timeout_s);
  }
  const size_t end = any ? head.find("\r\n\r\n", lead) : std::string::npos;
  if (end != std::string::npos) {
    ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, c->fd, nullptr);
    c->body = HeadHasBody(head.substr(0, end + 4));
    Lane& lane = lanes[c->body ? 1 : 0];
    {
      std::lock_guard<std::mutex> lock(mutex);
      lane.queue.push_back(std::move(c));
    }
    lane.cv.notify_all();
    return;
  }
  if (eof || hangup) {
    ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, c->fd, nullptr);
    Close(std::move(c));
    return;
  }
  if (head.size() > kMaxHeadBytes) {
    ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, c->fd, nullptr);
    {
      std::lock_guard<std::mutex> lock(mutex);
      ++stats.head_too_large;
    }
    Close(std::move(c), 431, "Request Header Fields Too Large",
          "the request line and headers exceed " + std::to_string(kMaxHeadBytes >> 10) +
              " KiB; send a shorter URL or fewer and shorter headers");
    return;
  }
  Conn* key = c.get();
  waiting.emplace(key, std::move(c));
}

void GatedHttpServer::Impl::Close(std::unique_ptr<Conn> c, int status, const char* reason,
                                  const std::string& message) {
  if (status != 0) {
    // Take what the client sent so that closing does not reset the connection before it has
    // read the answer (unread data makes the kernel send RST).
    char sink[16 << 10];
    for (int i = 0; i < 64 && ::recv(c->fd, sink, sizeof sink, MSG_DONTWAIT) > 0; ++i) {
    }
    SendBrief(c->fd, status, reason, message);
    ::shutdown(c->fd, SHUT_WR);
  }
  ::close(c->fd);
  std::lock_guard<std::mutex> lock(mutex);
  --stats.open;
  if (--per_address[c->ip] <= 0) per_address.erase(c->ip);
}

void GatedHttpServer::Impl::WorkerMain(int index) {
  Lane& lane = lanes[index];
  for (;;) {
    std::unique_ptr<Conn> c;
    {
      std::unique_lock<std::mutex> lock(mutex);
      // The oldest queued connection whose address is under its share of this lane.
      auto eligible = [&] {
        return std::find_if(lane.queue.begin(), lane.queue.end(), [&](const auto& q) {
          auto a = lane.active.find(q->ip);
          return a == lane.active.end() || a->second < o.max_client_requests;
        });
      };
      lane.cv.wait(lock, [&] { return stopping || eligible() != lane.queue.end(); });
      if (stopping) return;
      auto it = eligible();
      c = std::move(*it);
      lane.queue.erase(it);
      ++lane.active[c->ip];
    }
    const std::string ip = c->ip;
    Serve(std::move(c));
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (--lane.active[ip] <= 0) lane.active.erase(ip);
    }
    lane.cv.notify_all();
  }
}

void GatedHttpServer::Impl::Serve(std::unique_ptr<Conn> c) {
  DeadlineStream strm(*c, o);
  const bool close_connection = stopping || c->served + 1 >= 1000;
  bool closed = false;
  const bool ok = http.ServeOne(strm, close_connection, closed);
  ++c->served;
  if (strm.TimedOut()) {
    std::lock_guard<std::mutex> lock(mutex);
    ++stats.transfer_timeouts;
  }
  if (!ok || closed || close_connection || strm.TimedOut() || stopping) {
    ::shutdown(c->fd, SHUT_RDWR);
    Close(std::move(c));
    return;
  }
  c->idle = true;
  c->deadline = Clock::now() + Duration(o.keep_alive_timeout_s);
  Enqueue(std::move(c));
}

void GatedHttpServer::Impl::Stop() {
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (stopped) return;
    stopped = true;
    stopping = true;
  }
  const uint64_t one = 1;
  (void)!::write(wake_fd, &one, sizeof one);
  if (loop.joinable()) loop.join();
  for (auto& lane : lanes) {
    lane.cv.notify_all();
    for (auto& t : lane.threads) t.join();
    lane.threads.clear();
  }
  std::vector<std::unique_ptr<Conn>> left;
  {
    std::lock_guard<std::mutex> lock(mutex);
    for (auto& lane : lanes)
      for (auto& c : lane.queue) left.push_back(std::move(c));
    for (auto& lane : lanes) lane.queue.clear();
    for (auto& c : inbox) left.push_back(std::move(c));
    inbox.clear();
  }
  for (auto& c : left) Close(std::move(c));
  if (epoll_fd >= 0) ::close(epoll_fd);
  if (wake_fd >= 0) ::close(wake_fd);
  epoll_fd = wake_fd = -1;
}

// ---------------------------------------------------------------------------------------------
void RenderGateStats(const GateStats& s, std::string* out) {
  std::string& o = *out;
  o += "# HELP matfit_http_connections Open HTTP connections, and those waiting for a head.\n"
       "# TYPE matfit_http_connections gauge\n";
  o += "matfit_http_connections{state=\"open\"} " + std::to_string(s.open) + "\n";
  o += "matfit_http_connections{state=\"waiting_head\"} " + std::to_string(s.waiting_head) + "\n";
  o += "# HELP matfit_http_connections_dropped_total Connections refused or cut, by reason.\n"
       "# TYPE matfit_http_connections_dropped_total counter\n";
  const std::pair<const char*, int64_t> reasons[] = {{"client_limit", s.refused_client},
                                                     {"server_limit", s.refused_server},
                                                     {"head_timeout", s.head_timeouts},
                                                     {"head_too_large", s.head_too_large},
                                                     {"transfer_timeout", s.transfer_timeouts}};
  for (const auto& [reason, n] : reasons)
    o += std::string("matfit_http_connections_dropped_total{reason=\"") + reason + "\"} " +
         std::to_string(n) + "\n";
}

GatedHttpServer::GatedHttpServer() : impl_(std::make_unique<Impl>(*this)) {
  new_task_queue = [] { return new InlineQueue; };
}

GatedHttpServer::~GatedHttpServer() { StopConnections(); }

void GatedHttpServer::Configure(const ServerOptions& options) {
  impl_->o = options;
  if (!impl_->configured) impl_->Start();
  impl_->configured = true;
}

void GatedHttpServer::StopConnections() {
  if (impl_->configured) impl_->Stop();
}

GateStats GatedHttpServer::Stats() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->stats;
}

bool GatedHttpServer::process_and_close_socket(socket_t sock) {
  if (!impl_->configured) {  // not configured: refuse rather than serve without limits
    ::close(sock);
    return false;
  }
  impl_->Admit(sock);
  return true;
}

void GatedHttpServer::RaiseBacklog(int n) {
  // Linux takes a second listen() on a listening socket as a new backlog. cpp-httplib listens
  // with 5, which drops SYNs (and stalls clients for seconds) when connections arrive in bursts.
  if (svr_sock_ != INVALID_SOCKET) ::listen(svr_sock_, n);
}

bool GatedHttpServer::ServeOne(httplib::Stream& strm, bool close_connection,
                               bool& connection_closed) {
  return process_request(strm, close_connection, connection_closed, nullptr);
}

}  // namespace matfit::server
