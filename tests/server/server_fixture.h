// Shared fixture of the service tests: a server on 127.0.0.1 (port 0) in a temporary data
// folder, a real HTTP client, and helpers (uploads, polling, archives of the fixtures, raw
// sockets).
#pragma once

#include "server/server.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "core/image_io.h"
#include "core/synth/synth.h"
#include "fit/fit_job.h"
#include "tests/server/archive_util.h"

namespace matfit::server::testing_fixture {

namespace fs = std::filesystem;
using json = nlohmann::json;
using ::matfit::server::testing::ArchiveWriter;

inline const std::string kFixtures = std::string(MATFIT_SOURCE_DIR) + "/fixtures";

inline std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class ServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    tmp_ = fs::temp_directory_path() /
           ("matfit_server_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(tmp_);
    fs::create_directories(tmp_);
    opts_.data_dir = (tmp_ / "data").string();
    opts_.port = 0;
    opts_.quiet = true;
    opts_.render_backend = "cpu";
    opts_.drain_seconds = 0;
  }
  void TearDown() override {
    client_.reset();
    server_.reset();
    fs::remove_all(tmp_);
  }
  void Start() {
    auto s = Server::Create(opts_);
    ASSERT_TRUE(s.ok()) << s.status().message();
    server_ = std::move(*s);
    ASSERT_TRUE(server_->Start().ok());
    client_ = std::make_unique<httplib::Client>("127.0.0.1", server_->port());
    client_->set_read_timeout(120, 0);
    client_->set_write_timeout(120, 0);
  }
  httplib::Headers Auth(const std::string& token) {
    return token.empty() ? httplib::Headers{}
                         : httplib::Headers{{"Authorization", "Bearer " + token}};
  }
  httplib::Result Upload(const std::string& archive,
                         const std::vector<std::pair<std::string, std::string>>& fields,
                         const std::string& token = "") {
    httplib::MultipartFormDataItems items;
    if (!archive.empty())
      items.push_back({"file", Slurp(archive), "dataset.zip", "application/zip"});
    for (const auto& [k, v] : fields) items.push_back({k, v, "", ""});
    return client_->Post("/api/v1/jobs", Auth(token), items);
  }
  httplib::Result SubmitPath(const json& body, const std::string& token = "") {
    return client_->Post("/api/v1/jobs", Auth(token), body.dump(), "application/json");
  }
  json Get(const std::string& path, int expect = 200) {
    auto r = client_->Get(path.c_str());
    EXPECT_TRUE(r) << path;
    if (!r) return {};
    EXPECT_EQ(r->status, expect) << path << ": " << r->body;
    return json::parse(r->body, nullptr, false);
  }
  // Polls the job until `done(job)` or the timeout; returns the last job JSON.
  json WaitFor(const std::string& id, const std::function<bool(const json&)>& done,
               double timeout_s = 120) {
    const auto t0 = std::chrono::steady_clock::now();
    json j;
    while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() <
           timeout_s) {
      j = Get("/api/v1/jobs/" + id);
      if (done(j)) return j;
      std::this_thread::sleep_for(std::chrono::milliseconds(40));
    }
    ADD_FAILURE() << "job " << id << " timed out: " << j.dump();
    return j;
  }
  static bool Finished(const json& j) {
    const std::string s = j.value("state", "");
    return s == "succeeded" || s == "failed" || s == "cancelled";
  }
  std::string ZipFixture(const std::string& name) {
    const std::string out = (tmp_ / (name + ".zip")).string();
    ArchiveWriter w(out, ArchiveWriter::Format::kZip);
    w.Folder(kFixtures + "/" + name, name);
    return out;
  }
  // A dataset slow enough to catch running: cook-torrance with held-out folds.
  std::string SlowDataset(int size) {
    synth::SynthOptions so;
    so.material = "plastic", so.lights = "bonn81", so.size = size, so.layout = Layout::kLp;
    auto r = synth::Synthesize(so);
    EXPECT_TRUE(r.ok());
    const std::string dir = (tmp_ / "datasets" / ("slow" + std::to_string(size))).string();
    EXPECT_TRUE(synth::WriteSynthDataset(*r, so, dir, true).ok());
    return dir;
  }
  // Nothing of a rejected upload is left: no partial upload, no dataset, no pack, no job.
  void ExpectDataClean(size_t jobs_before) {
    const fs::path d = opts_.data_dir;
    EXPECT_TRUE(fs::is_empty(d / "uploads")) << "a partial upload was left";
    EXPECT_TRUE(fs::is_empty(d / "datasets")) << "a rejected dataset was kept";
    EXPECT_TRUE(fs::is_empty(d / "packs"));
    EXPECT_EQ(Get("/api/v1/jobs")["jobs"].size(), jobs_before);
    for (const auto& e : fs::recursive_directory_iterator(tmp_))  // nothing outside the data dir
      EXPECT_FALSE(e.path().filename() == "evil.txt") << e.path();
  }

  fs::path tmp_;
  ServerOptions opts_;
  std::unique_ptr<Server> server_;
  std::unique_ptr<httplib::Client> client_;
};

// Connects a raw TCP socket to the server.
inline int Connect(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(uint16_t(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) return -1;
  return fd;
}

// Sends `bytes` on a fresh connection and reads until the server closes it (or 10 s pass).
inline std::string RawExchange(int port, const std::string& bytes) {
  const int fd = Connect(port);
  if (fd < 0) return "";
  timeval tv{10, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
  std::string reply;
  char buf[4096];
  for (ssize_t n; (n = ::recv(fd, buf, sizeof buf, 0)) > 0;) reply.append(buf, size_t(n));
  ::close(fd);
  return reply;
}

inline int CountResponses(const std::string& reply) {
  int n = 0;
  for (size_t at = 0; (at = reply.find("HTTP/1.1 ", at)) != std::string::npos; ++at) ++n;
  return n;
}

}  // namespace matfit::server::testing_fixture
