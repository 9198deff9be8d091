// Issue #22, what the service sends back and keeps: content types from the route and no control
// bytes in paths (stored XSS via a NUL byte), no server paths in packs, non-UTF-8 input gets 400,
// a full disk fails a job with the reason and never caches an empty preview, and the preview
// cache is bounded with small previews never queued behind large ones.
#include <fcntl.h>
#include <sqlite3.h>
#include <sys/mount.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <future>

#include "tests/server/server_fixture.h"

namespace matfit::server::testing_fixture {
namespace {

bool IsUtf8Json(const std::string& body) {
  return !json::parse(body, nullptr, false).is_discarded();
}

class HardeningTest : public ServerTest {
 protected:
  // A succeeded `mean` fit of the ring fixture uploaded under `top`; returns its id.
  std::string FinishedJob(const std::string& top = "plastic-ring12") {
    const std::string zip = (tmp_ / ("job" + std::to_string(jobs_++) + ".zip")).string();
    {
      ArchiveWriter w(zip, ArchiveWriter::Format::kZip);
      w.Folder(kFixtures + "/plastic-ring12", top);
    }
    auto r = Upload(zip, {{"model", "mean"}});
    EXPECT_TRUE(r);
    if (!r) return "";
    EXPECT_EQ(r->status, 202) << r->body;
    const std::string id = json::parse(r->body, nullptr, false).value("id", "");
    EXPECT_EQ(WaitFor(id, Finished)["state"], "succeeded");
    return id;
  }
  // Bytes of every file under the preview cache.
  int64_t PreviewCacheBytes() {
    int64_t n = 0;
    for (const auto& e :
         fs::recursive_directory_iterator(fs::path(opts_.data_dir) / "cache" / "previews"))
      if (e.is_regular_file()) n += int64_t(e.file_size());
    return n;
  }
  int jobs_ = 0;
};

// ---- 7. Non-UTF-8 input -----------------------------------------------------------------------

TEST_F(HardeningTest, NonUtf8InputsGet400NamingTheField) {
  Start();
  const std::string plastic = ZipFixture("plastic-ring12");
  const std::string bad = "\xff\xfe\xc3";
  struct Case {
    std::string what, archive;
    std::vector<std::pair<std::string, std::string>> fields;
    std::string field;
  };
  auto tar = [&](const std::string& name, ArchiveWriter::Format f, const std::string& entry) {
    const std::string p = (tmp_ / name).string();
    ArchiveWriter w(p, f);
    w.Folder(kFixtures + "/plastic-ring12", "set");
    w.File(entry, "x");
    return p;
  };
  const std::vector<Case> cases = {
      {"field value", plastic, {{"model", "lambert" + bad}}, "model"},
      {"view value", plastic, {{"view", bad}}, "view"},
      {"mode value", plastic, {{"mode", bad}}, "mode"},
      {"field name", plastic, {{"mo" + bad, "lambert"}}, ""},
      {"archive entry (tar)",
       tar("e.tar", ArchiveWriter::Format::kTar, "set/" + bad + ".png"),
       {},
       "file"},
      {"archive entry (zip)",
       tar("e.zip", ArchiveWriter::Format::kZip, "set/" + bad + ".png"),
       {},
       "file"},
  };
  for (const auto& c : cases) {
    auto r = Upload(c.archive, c.fields);
    ASSERT_TRUE(r) << c.what;
    EXPECT_EQ(r->status, 400) << c.what << ": " << r->body;
    ASSERT_TRUE(IsUtf8Json(r->body)) << c.what << ": " << r->body;
    const json e = json::parse(r->body);
    if (!c.field.empty()) {
      EXPECT_EQ(e["error"].value("field", ""), c.field) << c.what << ": " << r->body;
    }
    EXPECT_NE(e["error"].value("message", "").find("UTF-8"), std::string::npos)
        << c.what << ": " << r->body;
    ExpectDataClean(0);
  }
  // Query parameters (names and values), and a header that ends up in a message.
  const std::string id = FinishedJob();
  const std::string enc = "%ff%fe%c3";
  const std::pair<std::string, std::string> queries[] = {
      {"/api/v1/jobs?state=" + enc, "state"},
      {"/api/v1/packs/" + id + "/preview.png?scene=" + enc, "scene"},
      {"/api/v1/packs/" + id + "/preview.png?theta=" + enc, "theta"},
      {"/api/v1/jobs?" + enc + "=1", ""},
  };
  for (const auto& [q, field] : queries) {
    auto r = client_->Get(q.c_str());
    ASSERT_TRUE(r) << q;
    EXPECT_EQ(r->status, 400) << q << ": " << r->body;
    ASSERT_TRUE(IsUtf8Json(r->body)) << q;
    const json e = json::parse(r->body);
    if (!field.empty()) {
      EXPECT_EQ(e["error"].value("field", ""), field) << q;
    }
    EXPECT_NE(e["error"].value("message", "").find("UTF-8"), std::string::npos) << r->body;
  }
  const std::string reply = RawExchange(
      server_->port(), "POST /api/v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: text/" + bad +
                           "\r\nContent-Length: 2\r\nConnection: close\r\n\r\n{}");
  EXPECT_EQ(reply.rfind("HTTP/1.1 415", 0), 0u) << reply;
  EXPECT_TRUE(IsUtf8Json(reply.substr(reply.find("\r\n\r\n") + 4))) << reply;
}

// ---- 3. Stored XSS via a NUL byte -----------------------------------------------------------

// The top folder of the uploaded archive: markup, which material.json used to repeat.
const std::string kMarkupName = "<svg onload=alert(1)>";

TEST_F(HardeningTest, ControlBytesInPathsAre400AndPackFilesKeepTheirRoutesType) {
  Start();
  const std::string id = FinishedJob(kMarkupName);
  ASSERT_FALSE(id.empty());
  const std::string base = "/api/v1/packs/" + id;
  // The NUL byte of the issue, and its cousins: never a 200, never text/html.
  for (const std::string tail : {"/material.json%00.html", "/material.json%00", "/material.json%01",
                                 "/material.json%1f.html", "/material.json%7f",
                                 "/material.json%0d%0aX-Evil:%201", "%00/material.json"}) {
    auto r = client_->Get((base + tail).c_str());
    ASSERT_TRUE(r) << tail;
    EXPECT_EQ(r->status, 400) << tail << ": " << r->body;
    EXPECT_EQ(r->get_header_value("Content-Type"), "application/json") << tail;
    EXPECT_FALSE(r->has_header("X-Evil")) << tail;
    const json e = json::parse(r->body, nullptr, false);
    EXPECT_NE(e["error"].value("message", "").find("control"), std::string::npos) << r->body;
  }
  auto job = client_->Get(("/api/v1/jobs/" + id + "%00").c_str());
  ASSERT_TRUE(job);
  EXPECT_EQ(job->status, 400);

  // Each route's own type, whatever the path ends with; nosniff and a CSP everywhere.
  const std::pair<std::string, std::string> typed[] = {
      {base + "/material.json", "application/json"},
      {base + "/material.gltf", "model/gltf+json"},
      {base + "/maps/albedo.png", "image/png"},
      {base + "/maps/albedo.exr", "image/x-exr"},
      {base + "/report", "application/json"},
      {base + "/preview.png?size=16", "image/png"},
      {base, "application/zip"},
      {"/api/v1/jobs/" + id, "application/json"},
      {"/api/v1/no-such-route", "application/json"},
      {base + "/no-such-file.html", "application/json"},
  };
  for (const auto& [path, type] : typed) {
    auto r = client_->Get(path.c_str());
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->get_header_value("Content-Type"), type) << path << " (" << r->status << ")";
    EXPECT_EQ(r->get_header_value("X-Content-Type-Options"), "nosniff") << path;
    const std::string csp = r->get_header_value("Content-Security-Policy");
    EXPECT_NE(csp.find("default-src 'none'"), std::string::npos) << path << ": " << csp;
    EXPECT_NE(csp.find("sandbox"), std::string::npos) << path << ": " << csp;
  }
  // The viewer and landing pages are HTML (they run scripts): nosniff too, and a policy that
  // allows only the server's own scripts, requests and images (no plugins, no other origins).
  for (const char* html : {"/api/v1/viewer/static/index.html", "/"}) {
    auto page = client_->Get(html);
    ASSERT_TRUE(page);
    EXPECT_EQ(page->status, 200);
    EXPECT_EQ(page->get_header_value("Content-Type"), "text/html; charset=utf-8");
    EXPECT_EQ(page->get_header_value("X-Content-Type-Options"), "nosniff");
    const std::string csp = page->get_header_value("Content-Security-Policy");
    EXPECT_NE(csp.find("default-src 'self'"), std::string::npos) << html << ": " << csp;
    EXPECT_NE(csp.find("object-src 'none'"), std::string::npos) << html << ": " << csp;
  }
}

TEST_F(HardeningTest, PacksAndJobRecordsHoldNoServerPaths) {
  Start();
  const std::string id = FinishedJob(kMarkupName);
  ASSERT_FALSE(id.empty());
  const std::string data = fs::canonical(opts_.data_dir).string();
  for (const std::string file : {"/material.json", "/report.json", "/material.gltf"}) {
    auto r = client_->Get(("/api/v1/packs/" + id + file).c_str());
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << file;
    EXPECT_EQ(r->body.find(data), std::string::npos) << file << " names the data folder";
    EXPECT_EQ(r->body.find(tmp_.string()), std::string::npos) << file << " names a server path";
  }
  // The provenance names the job and the dataset by its name inside the upload: data, in JSON.
  const json material = Get("/api/v1/packs/" + id + "/material.json");
  const std::string input = material["provenance"]["input"];
  EXPECT_NE(input.find(id), std::string::npos) << input;
  EXPECT_NE(input.find(kMarkupName), std::string::npos) << input;
  EXPECT_EQ(json::parse(Slurp(fs::path(opts_.data_dir) / "packs" / id / "report.json"))["source"],
            input);
  auto job = client_->Get(("/api/v1/jobs/" + id).c_str());
  ASSERT_TRUE(job);
  EXPECT_EQ(job->body.find(data), std::string::npos) << job->body;
}

TEST_F(HardeningTest, AFailedJobsMessageNamesNoServerPath) {
  Start();
  // Three broken uploads: an .lp naming an image that is not in the upload and an image cut
  // short (both caught when the headers are read at submission: 422; a PNG's chunks must fit in
  // the file), and an image whose compressed pixel data is corrupt (its header and chunks are
  // fine, so the job fails when it decodes). Every message names the file and no folder of the
  // server.
  const std::string missing = (tmp_ / "missing.zip").string(), cut = (tmp_ / "cut.zip").string(),
                    corrupt = (tmp_ / "corrupt.zip").string();
  {
    ArchiveWriter w(missing, ArchiveWriter::Format::kZip);
    w.Folder(kFixtures + "/plastic-ring12", "set", "img_003.png");
  }
  {
    ArchiveWriter w(cut, ArchiveWriter::Format::kZip);
    w.Folder(kFixtures + "/plastic-ring12", "set", "img_003.png");
    const std::string png = Slurp(kFixtures + "/plastic-ring12/img_003.png");
    w.File("set/img_003.png", png.substr(0, png.size() * 2 / 3));
  }
  {
    ArchiveWriter w(corrupt, ArchiveWriter::Format::kZip);
    w.Folder(kFixtures + "/plastic-ring12", "set", "img_003.png");
    std::string png = Slurp(kFixtures + "/plastic-ring12/img_003.png");
    const size_t idat = png.find("IDAT");
    ASSERT_NE(idat, std::string::npos);
    const size_t len = size_t(uint8_t(png[idat - 4])) << 24 | size_t(uint8_t(png[idat - 3])) << 16 |
                       size_t(uint8_t(png[idat - 2])) << 8 | size_t(uint8_t(png[idat - 1]));
    ASSERT_GT(len, 16u);
    for (size_t k = idat + 4 + len / 4; k < idat + 4 + len / 2; ++k) png[k] = char(~png[k]);
    w.File("set/img_003.png", png);
  }
  const std::string data = fs::canonical(opts_.data_dir).string();
  int job_failures = 0;
  for (const std::string& zip : {missing, cut, corrupt}) {
    auto r = Upload(zip, {{"model", "mean"}});
    ASSERT_TRUE(r);
    std::string error;
    if (r->status == 422) {
      error = json::parse(r->body)["error"]["message"];
    } else {
      ASSERT_EQ(r->status, 202) << r->body;
      const json j = WaitFor(json::parse(r->body)["id"], Finished);
      ASSERT_EQ(j["state"], "failed") << zip;
      error = j["error"];
      ++job_failures;
    }
    EXPECT_NE(error.find("img_003.png"), std::string::npos) << error;
    EXPECT_EQ(error.find(data), std::string::npos) << error;
    EXPECT_EQ(error.find(opts_.data_dir), std::string::npos) << error;
  }
  EXPECT_GE(job_failures, 1) << "no failure reached a running job: the job path is untested";
}

// ---- 4. A full disk fails the job with the reason -------------------------------------------

// A tmpfs mounted at tmp_/disk (needs root): a real disk that can be filled.
class FullDiskTest : public HardeningTest {
 protected:
  void Mount(const std::string& size) {
    disk_ = tmp_ / "disk";
    fs::create_directories(disk_);
    if (::mount("tmpfs", disk_.c_str(), "tmpfs", 0, ("size=" + size).c_str()) != 0) {
      const std::string why = std::strerror(errno);
      disk_.clear();
      GTEST_SKIP() << "cannot mount a tmpfs at " << (tmp_ / "disk") << " (" << why
                   << "); the full-disk tests need root (CAP_SYS_ADMIN)";
    }
    opts_.data_dir = (disk_ / "data").string();
  }
  void TearDown() override {
    client_.reset();
    server_.reset();
    if (!disk_.empty()) ::umount2(disk_.c_str(), MNT_DETACH);
    ServerTest::TearDown();
  }
  // Writes a filler file until the disk is full (ENOSPC).
  void Fill() {
    const fs::path p = disk_ / "filler";
    const int fd = ::open(p.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ASSERT_GE(fd, 0);
    std::string chunk(1 << 20, 'f');
    size_t n = chunk.size();
    for (;;) {
      const ssize_t w = ::write(fd, chunk.data(), n);
      if (w < 0 && errno == ENOSPC) {
        if (n == 1) break;
        n = std::max<size_t>(1, n / 4);
        continue;
      }
      ASSERT_GT(w, 0) << std::strerror(errno);
    }
    ::close(fd);
    std::error_code ec;
    ASSERT_EQ(fs::space(disk_, ec).available, 0u);
  }
  void Free() { fs::remove(disk_ / "filler"); }
  // On a 24 MiB tmpfs data folder: a by-path lambert job with 8 held-out folds whose disk is
  // filled while it fits, so that its pack (and its state update) hit ENOSPC. *id stays empty
  // when the tmpfs cannot be mounted (skipped).
  void FailAJobOnAFullDisk(std::string* id, json* final_job) {
    Mount("24m");
    if (disk_.empty()) return;
    opts_.allow_roots = {(tmp_ / "datasets").string()};
    fs::create_directories(tmp_ / "datasets");
    const std::string dataset = SlowDataset(128);  // on the ordinary disk
    Start();
    auto r = SubmitPath({{"dataset", dataset}, {"model", "lambert"}, {"holdout", 8}});
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 202) << r->body;
    *id = json::parse(r->body)["id"];
    WaitFor(*id, [](const json& j) { return j["state"] == "running"; });
    Fill();
    *final_job = WaitFor(*id, Finished, 90);
    ASSERT_EQ((*final_job)["state"], "failed") << final_job->dump(2);
  }
  // The state column of a job, read from jobs.db directly (what survives a crash).
  std::string StoredState(const std::string& id) {
    sqlite3* db = nullptr;
    const std::string path = opts_.data_dir + "/jobs.db";
    std::string state;
    if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK) {
      sqlite3_busy_timeout(db, 2000);
      sqlite3_stmt* s = nullptr;
      sqlite3_prepare_v2(db, "SELECT state FROM jobs WHERE id = ?", -1, &s, nullptr);
      sqlite3_bind_text(s, 1, id.c_str(), -1, SQLITE_TRANSIENT);
      if (sqlite3_step(s) == SQLITE_ROW)
        state = reinterpret_cast<const char*>(sqlite3_column_text(s, 0));
      sqlite3_finalize(s);
    }
    sqlite3_close(db);
    return state;
  }
  fs::path disk_;
};

TEST_F(FullDiskTest, APackWriteOnAFullDiskFailsTheJobAndItsStateLands) {
  std::string id;
  json j;
  FailAJobOnAFullDisk(&id, &j);
  if (id.empty() || HasFatalFailure()) return;
  const std::string error = j["error"];
  EXPECT_NE(error.find("disk is full (ENOSPC)"), std::string::npos) << error;
  EXPECT_NE(error.find("No space left on device"), std::string::npos) << error;
  EXPECT_EQ(error.find(fs::canonical(opts_.data_dir).string()), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(fs::path(opts_.data_dir) / "packs" / id));
  std::printf("error: %s\n", error.c_str());
  // The job is not running: DELETE never answers 202 (a cancel nobody will act on).
  auto del = client_->Delete(("/api/v1/jobs/" + id).c_str());
  ASSERT_TRUE(del);
  EXPECT_NE(del->status, 202) << del->body;
  std::printf("DELETE on the full disk: %d %s\n", del->status, del->body.c_str());
  if (del->status == 507) {  // the database cannot record the deletion yet
    EXPECT_NE(json::parse(del->body)["error"]["message"].get<std::string>().find("space"),
              std::string::npos)
        << del->body;
    EXPECT_EQ(Get("/api/v1/jobs/" + id)["state"], "failed");
  } else {
    EXPECT_EQ(del->status, 204) << del->body;
  }
  // With space again, the final state lands in the database without a restart.
  Free();
  if (del->status == 507) {
    for (int i = 0; i < 100 && StoredState(id) != "failed"; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    EXPECT_EQ(StoredState(id), "failed");
    auto again = client_->Delete(("/api/v1/jobs/" + id).c_str());
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 204) << again->body;
  }
  Get("/api/v1/jobs/" + id, 404);
  // And a restart does not bring the job back to run again.
  server_.reset();
  Start();
  Get("/api/v1/jobs/" + id, 404);
}

TEST_F(FullDiskTest, AFinalStateTheDatabaseCannotTakeIsKeptAndShown) {
  std::string id;
  json j;
  FailAJobOnAFullDisk(&id, &j);
  if (id.empty() || HasFatalFailure()) return;
  // While the disk stays full, GET keeps showing the real state, whatever the database holds.
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  EXPECT_EQ(Get("/api/v1/jobs/" + id)["state"], "failed");
  EXPECT_EQ(Get("/api/v1/jobs?state=failed")["jobs"].size(), 1u);
  EXPECT_TRUE(Get("/api/v1/jobs?state=running")["jobs"].empty());
  // The row still says running: the state lives in memory (else this test proves nothing).
  EXPECT_EQ(StoredState(id), "running") << "the database took the state despite the full disk";
  Free();
  for (int i = 0; i < 100 && StoredState(id) != "failed"; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(StoredState(id), "failed");
  server_.reset();  // a restart keeps it failed (a job left "running" would be re-queued)
  Start();
  const json after = Get("/api/v1/jobs/" + id);
  EXPECT_EQ(after["state"], "failed");
  EXPECT_EQ(after["attempts"], 1);
}

// ---- 5. A preview that cannot be cached ------------------------------------------------------

TEST_F(FullDiskTest, APreviewOnAFullDiskIsAnErrorAndNeverCached) {
  Mount("24m");
  if (disk_.empty()) return;
  Start();
  const std::string id = FinishedJob();
  ASSERT_FALSE(id.empty());
  const std::string q = "/api/v1/packs/" + id + "/preview.png?theta=33&size=128";
  Fill();
  for (int attempt = 0; attempt < 2; ++attempt) {  // the second is not served from a cache
    auto r = client_->Get(q.c_str());
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 507) << r->body.size() << " bytes";
    EXPECT_EQ(r->get_header_value("Cache-Control"), "no-store");
    EXPECT_NE(r->body.find("No space left on device"), std::string::npos) << r->body;
    EXPECT_TRUE(IsUtf8Json(r->body));
  }
  Free();
  auto ok = client_->Get(q.c_str());
  ASSERT_TRUE(ok);
  ASSERT_EQ(ok->status, 200);
  EXPECT_EQ(ok->get_header_value("X-Matfit-Cache"), "miss");
  const fs::path png = tmp_ / "p.png";
  std::ofstream(png, std::ios::binary) << ok->body;
  auto img = ReadImage(png.string());
  ASSERT_TRUE(img.ok()) << img.status().message();
  EXPECT_EQ(img->width(), 128);
  // After a restart the cached copy is the good one.
  server_.reset();
  Start();
  auto again = client_->Get(q.c_str());
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 200);
  EXPECT_EQ(again->get_header_value("X-Matfit-Cache"), "hit");
  EXPECT_TRUE(again->body == ok->body);
}

TEST_F(HardeningTest, AnEmptyOrTruncatedCacheFileIsNeverServed) {
  Start();
  const std::string id = FinishedJob();
  ASSERT_FALSE(id.empty());
  const std::string q = "/api/v1/packs/" + id + "/preview.png?theta=21&size=96";
  auto first = client_->Get(q.c_str());
  ASSERT_TRUE(first);
  ASSERT_EQ(first->status, 200);
  const fs::path dir = fs::path(opts_.data_dir) / "cache" / "previews" / id;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".png") files.push_back(e.path());
  ASSERT_EQ(files.size(), 1u);
  const std::string good = Slurp(files[0]);
  ASSERT_TRUE(good == first->body);
  // Empty, then cut short: each is rendered again, never served.
  for (const size_t keep : {size_t(0), good.size() / 2, good.size() - 1}) {
    std::ofstream(files[0], std::ios::binary | std::ios::trunc) << good.substr(0, keep);
    auto r = client_->Get(q.c_str());
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 200);
    EXPECT_EQ(r->get_header_value("X-Matfit-Cache"), "miss") << "kept " << keep;
    EXPECT_TRUE(r->body == good) << "kept " << keep << ": served " << r->body.size() << " bytes";
  }
}

// ---- 8. Previews under abuse ------------------------------------------------------------------

TEST_F(HardeningTest, ThePreviewCacheStaysUnderItsBound) {
  opts_.preview_cache_bytes = 96 << 10;
  Start();
  const std::string id = FinishedJob();
  ASSERT_FALSE(id.empty());
  int64_t largest = 0;
  auto get = [&](int theta) {
    auto r = client_->Get(
        ("/api/v1/packs/" + id + "/preview.png?size=48&theta=" + std::to_string(theta)).c_str());
    EXPECT_TRUE(r);
    return r;
  };
  for (int i = 0; i < 60; ++i) {
    auto r = get(i);
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << r->body;
    largest = std::max<int64_t>(largest, int64_t(r->body.size()));
    ASSERT_LE(PreviewCacheBytes(), opts_.preview_cache_bytes) << "after " << i + 1 << " previews";
    if (i == 10) {  // an early preview used again is the most recent: it is kept
      EXPECT_EQ(get(5)->get_header_value("X-Matfit-Cache"), "hit");
    }
  }
  EXPECT_GT(PreviewCacheBytes(), opts_.preview_cache_bytes - 2 * largest) << "the cache is unused";
  EXPECT_EQ(get(59)->get_header_value("X-Matfit-Cache"), "hit");  // the newest stays
  EXPECT_EQ(get(0)->get_header_value("X-Matfit-Cache"), "miss");  // the oldest went
  // A restart counts the files already there.
  server_.reset();
  Start();
  for (int i = 100; i < 110; ++i) ASSERT_EQ(get(i)->status, 200);
  EXPECT_LE(PreviewCacheBytes(), opts_.preview_cache_bytes);
}

TEST_F(HardeningTest, ASmallPreviewDoesNotWaitBehindLargeOnes) {
  opts_.render_backend = "auto";  // the EGL renderer where there is one (llvmpipe: slow renders)
  Start();
  const std::string id = FinishedJob();
  ASSERT_FALSE(id.empty());
  auto timed = [&](const std::string& q) {
    httplib::Client c("127.0.0.1", server_->port());
    c.set_read_timeout(300, 0);
    const auto t0 = std::chrono::steady_clock::now();
    auto r = c.Get(q.c_str());
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_TRUE(r && r->status == 200) << q;
    return s;
  };
  const std::string base = "/api/v1/packs/" + id + "/preview.png?scene=sphere";
  timed(base + "&size=16&theta=49");  // renderers started
  const double one_large = timed(base + "&size=1024&theta=1");
  std::vector<std::future<double>> large;
  for (int i = 0; i < 4; ++i)
    large.push_back(
        std::async(std::launch::async, timed, base + "&size=1024&theta=" + std::to_string(10 + i)));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // all four queued or running
  const double small = timed(base + "&size=16&theta=50");
  double large_total = 0;
  for (auto& f : large) large_total = std::max(large_total, f.get());
  std::printf(
      "one 1024² preview alone: %.2f s; a 16² preview while four 1024² are queued: %.3f s; "
      "the four 1024²: %.2f s\n",
      one_large, small, large_total);
  // Before: the 16² preview waited for all four (small ≈ the four's time, 5.2 s vs 1.3 s for
  // one). Now it has its own lane; on llvmpipe the large renders still occupy both cores, so the
  // small one gets a share of the CPU (measured 0.007–0.31 s beside 0.6 s for one large), never
  // a place behind them.
  EXPECT_LT(small, 0.5 * large_total);
}

TEST_F(HardeningTest, LargePreviewsBeyondTheQueueGet503) {
  opts_.render_backend = "auto";
  opts_.preview_queue = 1;
  Start();
  const std::string id = FinishedJob();
  ASSERT_FALSE(id.empty());
  std::vector<std::future<httplib::Result>> large;
  for (int i = 0; i < 8; ++i)
    large.push_back(std::async(std::launch::async, [&, i] {
      httplib::Client c("127.0.0.1", server_->port());
      c.set_read_timeout(300, 0);
      return c.Get(
          ("/api/v1/packs/" + id + "/preview.png?size=1024&theta=" + std::to_string(i)).c_str());
    }));
  int ok = 0, busy = 0;
  for (auto& f : large) {
    const auto r = f.get();
    ASSERT_TRUE(r);
    if (r->status == 200) {
      ++ok;
    } else {
      ASSERT_EQ(r->status, 503) << r->body;
      ++busy;
      EXPECT_EQ(r->get_header_value("Retry-After"), "1");
      EXPECT_EQ(r->get_header_value("Cache-Control"), "no-store");
      EXPECT_NE(r->body.find("retry shortly"), std::string::npos) << r->body;
    }
  }
  std::printf("8 concurrent 1024² previews, queue 1: %d rendered, %d refused\n", ok, busy);
  EXPECT_GE(ok, 1);
  EXPECT_GE(busy, 1);
}

}  // namespace
}  // namespace matfit::server::testing_fixture
