// Slow and greedy clients against a real server on loopback (issue 22, finding 1): clients that
// trickle a request head, a body or never read a response must not starve /healthz, job polling
// or job execution; a head has a deadline that does not restart per byte; one address cannot
// hold more than its share of connections or request workers.
#include <fcntl.h>
#include <poll.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <mutex>

#include "tests/server/server_fixture.h"

namespace matfit::server::testing_fixture {
namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// A TCP connection from a chosen loopback source address (127.0.0.0/8 is all local), so that
// a test can play many clients. Returns -1 when connect fails.
int ConnectFrom(int port, const std::string& source) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in s{};
  s.sin_family = AF_INET;
  ::inet_pton(AF_INET, source.c_str(), &s.sin_addr);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&s), sizeof s) != 0) {
    ::close(fd);
    return -1;
  }
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(uint16_t(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

bool SendAll(int fd, const std::string& s) {
  return ::send(fd, s.data(), s.size(), MSG_NOSIGNAL | MSG_DONTWAIT) == ssize_t(s.size());
}

// True when the peer has closed the connection (or reset it); drains whatever it sent.
bool PeerClosed(int fd, std::string* got = nullptr) {
  char buf[4096];
  for (;;) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
    if (n > 0) {
      if (got) got->append(buf, size_t(n));
      continue;
    }
    if (n == 0) return true;
    return errno != EAGAIN && errno != EWOULDBLOCK;
  }
}

// Waits up to `timeout_s` for the server to close `fd`; returns the seconds it took, or -1.
double WaitClosed(int fd, double timeout_s, std::string* got = nullptr) {
  const auto t0 = Clock::now();
  while (Since(t0) < timeout_s) {
    pollfd p{fd, POLLIN, 0};
    ::poll(&p, 1, 50);
    if (PeerClosed(fd, got)) return Since(t0);
  }
  return -1;
}

// One /healthz on a fresh connection; the latency in seconds, or +inf on failure.
double HealthLatency(int port) {
  httplib::Client c("127.0.0.1", port);
  c.set_connection_timeout(2, 0);
  c.set_read_timeout(2, 0);
  const auto t0 = Clock::now();
  auto r = c.Get("/healthz");
  const double s = Since(t0);
  return r && r->status == 200 ? s : std::numeric_limits<double>::infinity();
}

double Percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[std::min(v.size() - 1, size_t(p * double(v.size())))];
}

class SlowClientTest : public ServerTest {};

// ≥ 200 connections trickling one header line every 3 s for 30 s, from 50 addresses: /healthz
// on fresh connections keeps p99 ≤ 100 ms, a job submitted meanwhile completes, and the server
// cuts trickling heads at the header deadline (it does not restart on each byte).
TEST_F(SlowClientTest, TricklingHeadsDoNotStarveHealthOrJobs) {
  opts_.header_timeout_s = 4;
  Start();
  const int port = server_->port();
  constexpr int kSlow = 200, kAddresses = 50;
  constexpr double kAttackSeconds = 30;

  std::atomic<bool> stop{false};
  std::atomic<int> open_now{0}, max_open{0}, cut{0};
  std::mutex cut_mutex;
  std::vector<double> cut_after;  // seconds from connect to the server's close
  std::thread attacker([&] {
    struct Slow {
      int fd = -1;
      Clock::time_point opened, last_send;
    };
    std::vector<Slow> conns(kSlow);
    auto open = [&](int i) {
      Slow& s = conns[size_t(i)];
      s.fd = ConnectFrom(port, "127.0.0." + std::to_string(2 + i % kAddresses));
      if (s.fd < 0) return;
      s.opened = s.last_send = Clock::now();
      if (!SendAll(s.fd, "GET /healthz HTTP/1.1\r\nHost: x\r\n")) {
        ::close(s.fd);
        s.fd = -1;
      }
    };
    for (int i = 0; i < kSlow; ++i) open(i);
    while (!stop) {
      int n = 0;
      for (int i = 0; i < kSlow; ++i) {
        Slow& s = conns[size_t(i)];
        if (s.fd >= 0 && PeerClosed(s.fd)) {
          {
            std::lock_guard<std::mutex> lock(cut_mutex);
            cut_after.push_back(Since(s.opened));
          }
          ++cut;
          ::close(s.fd);
          s.fd = -1;
        }
        if (s.fd < 0) open(i);  // the attack goes on: reconnect
        if (s.fd >= 0 && Since(s.last_send) >= 3) {
          SendAll(s.fd, "X-Slow: 1\r\n");
          s.last_send = Clock::now();
        }
        n += s.fd >= 0;
      }
      open_now = n;
      max_open = std::max(max_open.load(), n);
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    for (auto& s : conns)
      if (s.fd >= 0) ::close(s.fd);
  });

  // Let the slow connections pile up, then submit a job and measure /healthz until the attack
  // ends.
  std::this_thread::sleep_for(std::chrono::seconds(2));
  // The attack ends with the test, whatever fails first.
  struct Join {
    std::atomic<bool>& stop;
    std::thread& t;
    ~Join() {
      stop = true;
      if (t.joinable()) t.join();
    }
  } join{stop, attacker};
  auto r = Upload(ZipFixture("plastic-ring12"), {{"model", "lambert"}});
  ASSERT_TRUE(r) << "the submission failed under the attack: " << httplib::to_string(r.error());
  ASSERT_EQ(r->status, 202) << r->body;
  const std::string id = json::parse(r->body)["id"];
  std::vector<double> latency;
  int min_open_during = kSlow;
  std::string state;
  const auto t0 = Clock::now();
  while (Since(t0) < kAttackSeconds - 2) {
    latency.push_back(HealthLatency(port));
    min_open_during = std::min(min_open_during, open_now.load());
    if (!Finished(json{{"state", state}})) {
      httplib::Client c("127.0.0.1", port);
      c.set_read_timeout(2, 0);
      if (auto j = c.Get(("/api/v1/jobs/" + id).c_str()); j && j->status == 200)
        state = json::parse(j->body).value("state", "");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  stop = true;
  attacker.join();

  const double p50 = Percentile(latency, 0.5), p99 = Percentile(latency, 0.99);
  std::printf("slow clients: %d held at peak, >= %d open while measuring, %d cut by the server\n",
              max_open.load(), min_open_during, cut.load());
  std::printf("/healthz on fresh connections: %zu requests, p50 %.1f ms, p99 %.1f ms\n",
              latency.size(), p50 * 1e3, p99 * 1e3);
  EXPECT_GE(max_open.load(), kSlow * 9 / 10) << "the attack did not get its connections open";
  EXPECT_GE(min_open_during, kSlow / 2) << "too few slow connections held while measuring";
  EXPECT_GT(latency.size(), 100u);
  EXPECT_LE(p99, 0.100) << "p99 of /healthz under slow clients";
  EXPECT_EQ(state, "succeeded") << "the job did not finish under the attack";
  // Heads are cut at the header deadline (4 s) although a byte arrives every 3 s.
  ASSERT_GT(cut.load(), 0) << "no trickling head was ever cut";
  std::lock_guard<std::mutex> lock(cut_mutex);
  for (double s : cut_after) EXPECT_LT(s, opts_.header_timeout_s + 2.5);
}

// A head cut at the deadline gets 408; a head larger than the limit gets 431; both close.
TEST_F(SlowClientTest, HeadDeadlineAndSizeLimit) {
  opts_.header_timeout_s = 2;
  Start();
  const int fd = Connect(server_->port());
  ASSERT_GE(fd, 0);
  ASSERT_TRUE(SendAll(fd, "GET /healthz HTTP/1.1\r\n"));
  std::string got;
  const double s = WaitClosed(fd, 10, &got);
  ::close(fd);
  EXPECT_GT(s, 1.5);
  EXPECT_LT(s, 4.0);
  EXPECT_NE(got.find("408"), std::string::npos) << got;

  const std::string big = "GET /healthz HTTP/1.1\r\nX-Big: " + std::string(64 << 10, 'a');
  const std::string reply = RawExchange(server_->port(), big);
  EXPECT_NE(reply.find("431"), std::string::npos) << reply.substr(0, 200);
}

// One address may hold at most max_client_connections; the next is refused with 503 at once,
// while other addresses are served.
TEST_F(SlowClientTest, PerClientConnectionLimit) {
  opts_.max_client_connections = 8;
  Start();
  const int port = server_->port();
  std::vector<int> held;
  for (int i = 0; i < 8; ++i) {
    const int fd = ConnectFrom(port, "127.0.0.9");
    ASSERT_GE(fd, 0);
    ASSERT_TRUE(SendAll(fd, "GET /healthz HTTP/1.1\r\n"));  // an unfinished head
    held.push_back(fd);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const int extra = ConnectFrom(port, "127.0.0.9");
  ASSERT_GE(extra, 0);
  std::string got;
  EXPECT_GE(WaitClosed(extra, 2, &got), 0) << "the connection over the limit was not closed";
  EXPECT_NE(got.find("503"), std::string::npos) << got;
  ::close(extra);
  EXPECT_LT(HealthLatency(port), 0.5);  // another address is served
  for (int fd : held) ::close(fd);
  // Once they are gone the address is welcome again.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const int again = ConnectFrom(port, "127.0.0.9");
  ASSERT_GE(again, 0);
  ASSERT_TRUE(SendAll(again, "GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n"));
  std::string ok;
  EXPECT_GE(WaitClosed(again, 5, &ok), 0);
  EXPECT_NE(ok.find("200 OK"), std::string::npos) << ok;
  ::close(again);
}

// A body trickled below the minimum transfer rate is cut after the grace period: it holds an
// upload slot for seconds, not for as long as the client likes; reads stay fast meanwhile.
TEST_F(SlowClientTest, SlowBodyIsCutAndDoesNotBlockReads) {
  opts_.transfer_grace_s = 2;
  opts_.min_transfer_rate = 64 << 10;
  opts_.upload_slots = 1;
  Start();
  const int port = server_->port();
  std::vector<int> fds;
  for (int i = 0; i < 4; ++i) {
    const int fd = ConnectFrom(port, "127.0.0." + std::to_string(20 + i));
    ASSERT_GE(fd, 0);
    ASSERT_TRUE(
        SendAll(fd,
                "POST /api/v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                "Content-Length: 100000\r\n\r\n{"));
    fds.push_back(fd);
  }
  std::vector<double> latency;
  const auto t0 = Clock::now();
  while (Since(t0) < 3) {
    latency.push_back(HealthLatency(port));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_LE(Percentile(latency, 0.99), 0.100);
  // The first body is cut after ~2 s; the others wait for the single slot, then are cut too:
  // all four within 4 × (grace + slack) of the start.
  for (int fd : fds) {
    EXPECT_GE(WaitClosed(fd, 20), 0) << "a trickled body was never cut";
    ::close(fd);
  }
  EXPECT_LT(Since(t0), 4 * (opts_.transfer_grace_s + 1.5));
}

// Every connection limit is validated with a message naming its flag.
TEST(SlowClientOptions, LimitsAreValidated) {
  ServerOptions base;
  base.data_dir = "/tmp/x";
  std::string why;
  ASSERT_TRUE(base.Check(&why)) << why;
  const std::vector<std::pair<std::function<void(ServerOptions&)>, std::string>> bad = {
      {[](ServerOptions& o) { o.header_timeout_s = 0; }, "--header-timeout"},
      {[](ServerOptions& o) { o.keep_alive_timeout_s = -1; }, "--keep-alive-timeout"},
      {[](ServerOptions& o) { o.transfer_grace_s = std::nan(""); }, "--transfer-grace"},
      {[](ServerOptions& o) { o.min_transfer_rate = 0; }, "--min-transfer-rate"},
      {[](ServerOptions& o) { o.max_connections = 2; }, "--max-connections"},
      {[](ServerOptions& o) { o.max_client_connections = 5000; }, "--max-client-connections"},
      {[](ServerOptions& o) { o.max_client_requests = 0; }, "--max-client-requests"},
      {[](ServerOptions& o) { o.http_threads = 0; }, "--http-threads"},
      {[](ServerOptions& o) { o.upload_slots = 0; }, "--upload-slots"}};
  for (const auto& [change, flag] : bad) {
    ServerOptions o = base;
    change(o);
    EXPECT_FALSE(o.Check(&why)) << flag;
    EXPECT_NE(why.find(flag), std::string::npos) << why;
  }
}

}  // namespace
}  // namespace matfit::server::testing_fixture
