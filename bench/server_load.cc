// Load test of `matfit serve` on loopback (issue #6), bounded in time: the server runs as its own
// process (so its memory is its own), one fit keeps it busy, and this program measures
//   1. open-loop GET /api/v1/jobs/{id} at a fixed rate: latency from the *scheduled* send time
//      (no coordinated omission), errors;
//   2. preview latency, cold (rendered) and cached;
//   3. upload throughput of a large incompressible archive, streamed from disk, and the server's
//      resident memory while it arrives (sampled every 10 ms from /proc).
// Usage: server_load MATFIT_BINARY SOURCE_DIR [--seconds 30] [--rate 200] [--upload-mib 200]
//        [--quick] [--json FILE]. Exit status 1 on request errors or unbounded upload memory.
#include <httplib.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "core/synth/synth.h"

namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(q * double(v.size())))];
}

int64_t RssKiB(pid_t pid, const char* key) {  // VmRSS / VmHWM of a process, KiB
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(key, 0) == 0) return std::stoll(line.substr(std::strlen(key) + 1));
  return -1;
}

struct ServerProcess {
  pid_t pid = -1;
  int port = 0;
  ~ServerProcess() {
    if (pid > 0) {
      kill(pid, SIGTERM);
      waitpid(pid, nullptr, 0);
    }
  }
};

bool StartServer(const std::string& bin, const std::string& dir, int64_t upload_mib,
                 ServerProcess* s) {
  int fds[2];
  if (pipe(fds) != 0) return false;
  s->pid = fork();
  if (s->pid == 0) {
    dup2(fds[1], 2);
    close(fds[0]);
    const std::string data = dir + "/data", mib = std::to_string(upload_mib + 64);
    execl(bin.c_str(), bin.c_str(), "serve", "--port", "0", "--data", data.c_str(), "--allow-root",
          dir.c_str(), "--quiet", "--drain-seconds", "0", "--max-upload-mib", mib.c_str(),
          "--max-unpacked-mib", mib.c_str(), (char*)nullptr);
    _exit(127);
  }
  close(fds[1]);
  FILE* err = fdopen(fds[0], "r");
  char line[512];
  while (std::fgets(line, sizeof line, err)) {
    if (std::sscanf(line, "matfit serve: listening on http://127.0.0.1:%d", &s->port) == 1) {
      std::thread([err] {  // keep draining the server's log so it never blocks
        char b[4096];
        while (std::fgets(b, sizeof b, err)) {
        }
        std::fclose(err);
      })
          .detach();
      return true;
    }
  }
  return false;
}

std::string Submit(httplib::Client& c, const json& body) {
  auto r = c.Post("/api/v1/jobs", body.dump(), "application/json");
  if (!r || r->status != 202) return "";
  return json::parse(r->body)["id"];
}

std::string State(httplib::Client& c, const std::string& id) {
  auto r = c.Get(("/api/v1/jobs/" + id).c_str());
  return r && r->status == 200 ? json::parse(r->body).value("state", "") : "";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: server_load MATFIT_BINARY SOURCE_DIR [options]\n");
    return 2;
  }
  const std::string bin = argv[1], src = argv[2];
  double seconds = 30, rate = 200;
  int64_t upload_mib = 200;
  std::string json_out;
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&] { return i + 1 < argc ? std::string(argv[++i]) : std::string(); };
    if (a == "--seconds")
      seconds = std::stod(next());
    else if (a == "--rate")
      rate = std::stod(next());
    else if (a == "--upload-mib")
      upload_mib = std::stoll(next());
    else if (a == "--json")
      json_out = next();
    else if (a == "--quick")
      seconds = 5, upload_mib = 50;
    else
      return std::fprintf(stderr, "unknown option %s\n", a.c_str()), 2;
  }
  char tmpl[] = "/tmp/matfit_load_XXXXXX";
  const std::string dir = mkdtemp(tmpl);
  struct Cleanup {
    std::string d;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(d, ec);
    }
  } cleanup{dir};

  // A fit long enough to run through the whole load phase (queued twice to be sure).
  matfit::synth::SynthOptions so;
  so.material = "plastic", so.lights = "bonn81", so.size = 160, so.layout = matfit::Layout::kLp;
  auto synth = matfit::synth::Synthesize(so);
  if (!synth.ok() || !matfit::synth::WriteSynthDataset(*synth, so, dir + "/slow", true).ok())
    return std::fprintf(stderr, "cannot write the dataset\n"), 1;

  ServerProcess server;
  if (!StartServer(bin, dir, upload_mib, &server))
    return std::fprintf(stderr, "the server did not start\n"), 1;
  httplib::Client c("127.0.0.1", server.port);
  c.set_read_timeout(300, 0);
  c.set_write_timeout(300, 0);
  const std::string fixture = dir + "/plastic";
  fs::copy(src + "/fixtures/plastic-ring12", fixture, fs::copy_options::recursive);
  const std::string small = Submit(c, {{"dataset", fixture}, {"model", "lambert-robust"}});
  while (State(c, small) != "succeeded") std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const json slow_body = {{"dataset", dir + "/slow"}, {"model", "cook-torrance"}, {"holdout", 8}};
  const std::string slow = Submit(c, slow_body), slow2 = Submit(c, slow_body);
  while (State(c, slow) != "running") std::this_thread::sleep_for(std::chrono::milliseconds(20));

  // 1. Fixed-rate GETs.
  const int kThreads = 8;  // client connections (fewer than the server's HTTP threads)
  const int64_t total = int64_t(seconds * rate);
  std::vector<double> latency(size_t(total), -1);
  std::atomic<int64_t> errors{0}, next{0};
  const auto t0 = Clock::now() + std::chrono::milliseconds(100);
  std::vector<std::thread> pool;
  for (int t = 0; t < kThreads; ++t)
    pool.emplace_back([&] {
      httplib::Client cl("127.0.0.1", server.port);
      cl.set_keep_alive(true);
      const std::string path = "/api/v1/jobs/" + slow;
      for (int64_t k; (k = next++) < total;) {
        const auto due = t0 + std::chrono::duration_cast<Clock::duration>(
                                  std::chrono::duration<double>(double(k) / rate));
        std::this_thread::sleep_until(due);
        auto r = cl.Get(path.c_str());
        if (!r || r->status != 200) errors++;
        latency[size_t(k)] = std::chrono::duration<double>(Clock::now() - due).count() * 1e3;
      }
    });
  for (auto& t : pool) t.join();
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  const std::string during = State(c, slow) + "/" + State(c, slow2);

  // 2. Previews: five light directions cold, then the same five from the cache.
  std::vector<double> cold, cached;
  for (int pass = 0; pass < 3; ++pass)
    for (int k = 0; k < 5; ++k) {
      const std::string q = "/api/v1/packs/" + small + "/preview.png?size=512&scene=sphere&theta=" +
                            std::to_string(20 + 10 * k);
      const auto a = Clock::now();
      auto r = c.Get(q.c_str());
      const double ms = std::chrono::duration<double>(Clock::now() - a).count() * 1e3;
      if (!r || r->status != 200) errors++;
      (pass == 0 ? cold : cached).push_back(ms);
    }

  // 3. Upload: a tar of the fixture plus incompressible padding, streamed as multipart. The fits
  // are cancelled first so that the server's memory is steady and the growth is the upload's.
  for (const auto& id : {slow, slow2}) c.Delete(("/api/v1/jobs/" + id).c_str());
  while (State(c, slow) == "running" || State(c, slow2) == "running")
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const std::string archive = dir + "/big.tar";
  {
    std::string cmd = "cd '" + dir + "' && head -c " + std::to_string(upload_mib << 20) +
                      " /dev/urandom > plastic/padding.bin && tar cf big.tar plastic && rm "
                      "plastic/padding.bin";
    if (std::system(cmd.c_str()) != 0) return std::fprintf(stderr, "cannot build the archive\n"), 1;
  }
  const int64_t size = int64_t(fs::file_size(archive));
  const std::string boundary = "matfitloadboundary7d1f";
  const std::string head =
      "--" + boundary + "\r\nContent-Disposition: form-data; name=\"model\"\r\n\r\nlambert\r\n--" +
      boundary +
      "\r\nContent-Disposition: form-data; name=\"file\"; "
      "filename=\"big.tar\"\r\nContent-Type: application/x-tar\r\n\r\n";
  const std::string tail = "\r\n--" + boundary + "--\r\n";
  const int64_t rss_before = RssKiB(server.pid, "VmRSS:");
  std::atomic<bool> uploading{true};
  std::atomic<int64_t> rss_peak{rss_before};
  std::thread sampler([&] {
    while (uploading) {
      rss_peak = std::max<int64_t>(rss_peak, RssKiB(server.pid, "VmRSS:"));
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  });
  FILE* f = std::fopen(archive.c_str(), "rb");
  const size_t body = head.size() + size_t(size) + tail.size();
  const auto u0 = Clock::now();
  auto up = c.Post(
      "/api/v1/jobs", body,
      [&](size_t offset, size_t length, httplib::DataSink& sink) {
        static thread_local std::vector<char> buf(1 << 16);
        size_t n = 0;
        if (offset < head.size()) {
          n = std::min(length, head.size() - offset);
          sink.write(head.data() + offset, n);
        } else if (offset < head.size() + size_t(size)) {
          const size_t at = offset - head.size();
          n = std::min({length, buf.size(), size_t(size) - at});
          std::fseek(f, long(at), SEEK_SET);
          n = std::fread(buf.data(), 1, n, f);
          sink.write(buf.data(), n);
        } else {
          const size_t at = offset - head.size() - size_t(size);
          n = std::min(length, tail.size() - at);
          sink.write(tail.data() + at, n);
        }
        return n > 0;
      },
      ("multipart/form-data; boundary=" + boundary).c_str());
  const double upload_s = std::chrono::duration<double>(Clock::now() - u0).count();
  uploading = false;
  sampler.join();
  std::fclose(f);
  if (!up || up->status != 202) {
    errors++;
    std::fprintf(stderr, "upload failed: %s\n", up ? up->body.c_str() : "no response");
  }
  const double mib = double(size) / (1 << 20);
  const double rss_growth_mib = double(rss_peak - rss_before) / 1024;

  std::vector<double> lat;
  for (double v : latency)
    if (v >= 0) lat.push_back(v);
  json out = {
      {"gets",
       {{"requests", total},
        {"target_rate", rate},
        {"achieved_rate", double(total) / wall},
        {"errors", errors.load()},
        {"p50_ms", Quantile(lat, 0.5)},
        {"p90_ms", Quantile(lat, 0.9)},
        {"p99_ms", Quantile(lat, 0.99)},
        {"max_ms", Quantile(lat, 1.0)},
        {"fit_states_after", during}}},
      {"preview_512_sphere",
       {{"cold_median_ms", Quantile(cold, 0.5)}, {"cached_median_ms", Quantile(cached, 0.5)}}},
      {"upload",
       {{"mib", mib},
        {"seconds", upload_s},
        {"mib_per_s", mib / upload_s},
        {"server_rss_before_mib", double(rss_before) / 1024},
        {"server_rss_growth_mib", rss_growth_mib}}}};
  std::printf(
      "GET /api/v1/jobs/{id} with a fit running (%s after): %lld requests at %.1f/s "
      "(target %.0f), %lld errors\n  latency from scheduled send: p50 %.2f ms, p90 %.2f "
      "ms, p99 %.2f ms, max %.2f ms\n",
      during.c_str(), (long long)total, double(total) / wall, rate, (long long)errors.load(),
      Quantile(lat, 0.5), Quantile(lat, 0.9), Quantile(lat, 0.99), Quantile(lat, 1.0));
  std::printf("preview 512² sphere: cold median %.1f ms, cached median %.2f ms (×%.0f)\n",
              Quantile(cold, 0.5), Quantile(cached, 0.5),
              Quantile(cold, 0.5) / Quantile(cached, 0.5));
  std::printf(
      "upload %.0f MiB (no fit running): %.2f s, %.0f MiB/s; server RSS %.1f MiB before, "
      "+%.1f MiB peak while uploading\n",
      mib, upload_s, mib / upload_s, double(rss_before) / 1024, rss_growth_mib);
  if (!json_out.empty()) std::ofstream(json_out) << out.dump(2) << "\n";
  const bool bounded = rss_growth_mib < 0.25 * mib;
  if (!bounded) std::fprintf(stderr, "server memory grew by more than a quarter of the upload\n");
  return errors == 0 && bounded ? 0 : 1;
}
