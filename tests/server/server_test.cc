// The material service over real HTTP on 127.0.0.1 with a real client: submit → poll → fetch
// (pack equal to a direct `matfit fit`), cancel, restart during a run, hostile inputs (status
// and a clean data folder), auth, metrics, previews, and the viewer in headless Chromium.
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

namespace matfit::server {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using testing::ArchiveWriter;

const std::string kFixtures = std::string(MATFIT_SOURCE_DIR) + "/fixtures";

std::string Slurp(const fs::path& p) {
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

TEST_F(ServerTest, SubmitPollDownloadEqualsADirectFit) {
  Start();
  auto r = Upload(ZipFixture("plastic-ring12"), {{"model", "lambert-robust"}, {"holdout", "3"}});
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 202) << r->body;
  const json sub = json::parse(r->body);
  const std::string id = sub["id"];
  EXPECT_EQ(sub["state"], "queued");
  EXPECT_EQ(r->get_header_value("Location"), "/api/v1/jobs/" + id);
  const json job = WaitFor(id, Finished);
  ASSERT_EQ(job["state"], "succeeded") << job.dump(2);
  EXPECT_EQ(job["progress"]["fraction"], 1.0);
  EXPECT_EQ(job["summary"]["method"], "lambert-robust");
  EXPECT_TRUE(job["summary"].contains("heldout_rmse"));
  EXPECT_EQ(job["attempts"], 1);
  EXPECT_EQ(job["links"]["pack"], "/api/v1/packs/" + id);

  // The same controller run directly on the fixture.
  fit::FitJobOptions o;
  o.input = kFixtures + "/plastic-ring12";
  o.model = "lambert-robust";
  o.holdout = 3;
  o.out = (tmp_ / "direct").string();
  auto direct = fit::RunFitJob(o);
  ASSERT_TRUE(direct.ok()) << direct.status().message();
  int compared = 0;
  for (const auto& f : fs::directory_iterator(tmp_ / "direct" / "maps")) {
    auto m =
        client_->Get(("/api/v1/packs/" + id + "/maps/" + f.path().filename().string()).c_str());
    ASSERT_TRUE(m);
    ASSERT_EQ(m->status, 200) << f.path();
    EXPECT_EQ(m->body, Slurp(f.path())) << f.path().filename() << " differs from the direct fit";
    ++compared;
  }
  EXPECT_GE(compared, 4);
  const json material = Get("/api/v1/packs/" + id + "/material.json");
  EXPECT_EQ(material["maps"], json::parse(Slurp(tmp_ / "direct" / "material.json"))["maps"]);
  auto gltf = client_->Get(("/api/v1/packs/" + id + "/material.gltf").c_str());
  ASSERT_TRUE(gltf);
  EXPECT_EQ(gltf->get_header_value("Content-Type"), "model/gltf+json");
  const json report = Get("/api/v1/packs/" + id + "/report");
  EXPECT_EQ(report["method"], "lambert-robust");
  EXPECT_EQ(report["rmse"], json::parse(direct->report_json)["rmse"]);

  auto zip = client_->Get(("/api/v1/packs/" + id).c_str());
  ASSERT_TRUE(zip);
  ASSERT_EQ(zip->status, 200);
  EXPECT_EQ(zip->body.substr(0, 2), "PK");
  EXPECT_EQ(zip->get_header_value("Content-Type"), "application/zip");

  // Previews: rendered once, then served from the cache; the PNG decodes.
  const std::string q = "/api/v1/packs/" + id + "/preview.png?theta=40&phi=20&scene=sphere&size=64";
  auto p1 = client_->Get(q.c_str());
  ASSERT_TRUE(p1);
  ASSERT_EQ(p1->status, 200) << p1->body;
  EXPECT_EQ(p1->get_header_value("X-Matfit-Cache"), "miss");
  std::ofstream(tmp_ / "p.png", std::ios::binary) << p1->body;
  auto img = ReadImage((tmp_ / "p.png").string());
  ASSERT_TRUE(img.ok()) << img.status().message();
  EXPECT_EQ(img->width(), 64);
  double sum = 0;
  for (float v : img->data()) sum += v;
  EXPECT_GT(sum, 0) << "the preview is black";
  auto p2 = client_->Get(q.c_str());
  ASSERT_TRUE(p2);
  EXPECT_EQ(p2->get_header_value("X-Matfit-Cache"), "hit");
  EXPECT_EQ(p2->body, p1->body);
  EXPECT_EQ(Get("/api/v1/packs/" + id + "/preview.png?size=5000", 400)["error"]["field"], "size");
  EXPECT_EQ(Get("/api/v1/packs/" + id + "/preview.png?scene=teapot", 400)["error"]["field"],
            "scene");

  // Traversal inside the pack namespace is refused (raw path, not normalised by the client).
  httplib::Client raw("127.0.0.1", server_->port());
  auto esc = raw.Get(("/api/v1/packs/" + id + "/../../jobs.db").c_str());
  ASSERT_TRUE(esc);
  EXPECT_EQ(esc->status, 404);
  auto esc2 = raw.Get(("/api/v1/packs/" + id + "/maps/../../../jobs.db").c_str());
  ASSERT_TRUE(esc2);
  EXPECT_EQ(esc2->status, 404) << esc2->body.substr(0, 100);

  // The viewer is a redirect to the embedded page with this pack.
  auto v = client_->Get(("/api/v1/viewer/" + id).c_str());
  ASSERT_TRUE(v);
  EXPECT_EQ(v->status, 302);
  EXPECT_NE(v->get_header_value("Location").find("pack=/api/v1/packs/" + id + "/"),
            std::string::npos);
  auto page = client_->Get("/api/v1/viewer/static/viewer.js");
  ASSERT_TRUE(page);
  EXPECT_NE(page->body.find("WebGL2"), std::string::npos);

  // Deleting a finished job removes its files.
  auto del = client_->Delete(("/api/v1/jobs/" + id).c_str());
  ASSERT_TRUE(del);
  EXPECT_EQ(del->status, 204);
  Get("/api/v1/jobs/" + id, 404);
  EXPECT_FALSE(fs::exists(fs::path(opts_.data_dir) / "packs" / id));
  EXPECT_TRUE(fs::is_empty(fs::path(opts_.data_dir) / "datasets"));
}

TEST_F(ServerTest, CancelARunningFitStopsPromptlyAndLeavesNoPack) {
  opts_.allow_roots = {tmp_.string()};
  Start();
  const std::string ds = SlowDataset(128);
  auto r = SubmitPath({{"dataset", ds}, {"model", "cook-torrance"}, {"holdout", 8}});
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 202) << r->body;
  const std::string id = json::parse(r->body)["id"];
  const json running = WaitFor(id, [](const json& j) {
    return j["state"] == "running" && j["progress"]["fraction"].get<double>() > 0.15;
  });
  ASSERT_EQ(running["state"], "running");
  EXPECT_FALSE(running["progress"]["eta_seconds"].is_null());
  EXPECT_NE(running["progress"]["stage"], "");
  const auto t0 = std::chrono::steady_clock::now();
  auto del = client_->Delete(("/api/v1/jobs/" + id).c_str());
  ASSERT_TRUE(del);
  EXPECT_EQ(del->status, 202) << del->body;
  const json done = WaitFor(id, Finished, 30);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(done["state"], "cancelled");
  EXPECT_LT(s, 5.0) << "cancellation took " << s << " s";
  EXPECT_FALSE(fs::exists(fs::path(opts_.data_dir) / "packs" / id));
  for (const auto& e : fs::directory_iterator(fs::path(opts_.data_dir) / "packs"))
    ADD_FAILURE() << "left in packs/: " << e.path();
  EXPECT_TRUE(fs::exists(ds)) << "a dataset named by path is the user's: never deleted";
  Get("/api/v1/packs/" + id, 409);
}

TEST_F(ServerTest, QueuedJobCancelsAtOnceAndRestartDuringARunCompletesIt) {
  opts_.allow_roots = {tmp_.string()};
  Start();
  const std::string ds = SlowDataset(96);
  auto a = SubmitPath({{"dataset", ds}, {"model", "cook-torrance"}, {"holdout", 4}});
  auto b = SubmitPath({{"dataset", ds}, {"model", "lambert"}});
  ASSERT_TRUE(a && b);
  const std::string ida = json::parse(a->body)["id"], idb = json::parse(b->body)["id"];
  WaitFor(ida, [](const json& j) { return j["state"] == "running"; });
  // b waits behind a (one worker): cancelling it is immediate.
  auto del = client_->Delete(("/api/v1/jobs/" + idb).c_str());
  ASSERT_TRUE(del);
  EXPECT_EQ(del->status, 200);
  EXPECT_EQ(json::parse(del->body)["state"], "cancelled");
  // Stop the server while a runs (drain 0 s): a goes back to the queue.
  client_.reset();
  server_->Shutdown();
  server_.reset();
  Start();
  const json j = WaitFor(ida, Finished);
  EXPECT_EQ(j["state"], "succeeded") << j.dump(2);
  EXPECT_EQ(j["attempts"], 2);
  EXPECT_TRUE(fs::exists(fs::path(opts_.data_dir) / "packs" / ida / "material.json"));
  EXPECT_EQ(Get("/api/v1/jobs/" + idb)["state"], "cancelled");
}

TEST_F(ServerTest, HostileAndMalformedInputsGetTheRightStatusAndLeaveTheDataFolderClean) {
  opts_.allow_roots = {(tmp_ / "allowed").string()};
  fs::create_directories(tmp_ / "allowed");
  opts_.archive.max_unpacked_bytes = int64_t(16) << 20;
  opts_.archive.max_entries = 100;
  opts_.max_upload_bytes = int64_t(4) << 20;
  Start();
  auto make = [&](const std::string& name, ArchiveWriter::Format f,
                  const std::function<void(ArchiveWriter&)>& add) {
    const std::string p = (tmp_ / name).string();
    ArchiveWriter w(p, f);
    add(w);
    return p;
  };
  struct Case {
    std::string what, archive;
    std::vector<std::pair<std::string, std::string>> fields;
    int status;
    std::string field, message;
  };
  using F = ArchiveWriter::Format;
  const std::string plastic = ZipFixture("plastic-ring12");
  std::vector<Case> cases = {
      {"traversal",
       make("t.zip", F::kZip, [](ArchiveWriter& w) { w.File("../../evil.txt", "x"); }),
       {},
       400,
       "file",
       "'..'"},
      {"absolute",
       make("a.tgz", F::kTarGz, [](ArchiveWriter& w) { w.File("/tmp/evil.txt", "x"); }),
       {},
       400,
       "file",
       "absolute"},
      {"symlink",
       make("s.tar", F::kTar,
            [](ArchiveWriter& w) {
              w.File("set/a.txt", "x");
              w.Symlink("set/evil.txt", "/etc/passwd");
            }),
       {},
       400,
       "file",
       "link"},
      {"zip bomb",
       make("b.zip", F::kZip, [](ArchiveWriter& w) { w.Zeros("set/z.bin", int64_t(64) << 20); }),
       {},
       413,
       "file",
       "unpacks to more than 16 MiB"},
      {"entry count",
       make("n.tar", F::kTarGz,
            [](ArchiveWriter& w) {
              for (int i = 0; i < 150; ++i) w.File("set/f" + std::to_string(i), "x");
            }),
       {},
       413,
       "file",
       "more than 100 entries"},
      {"too large",
       make("big.tar", F::kTar,
            [](ArchiveWriter& w) {
              std::string noise(6 << 20, '\0');
              for (size_t i = 0; i < noise.size(); ++i) noise[i] = char((i * 2654435761u) >> 13);
              w.File("set/noise.bin", noise);
            }),
       {},
       413,
       "",
       "larger than"},
      {"not an archive", (tmp_ / "junk.zip").string(), {}, 400, "file", "not a .zip"},
      {"unknown layout",
       make("u.zip", F::kZip, [](ArchiveWriter& w) { w.File("set/readme.txt", "hi"); }),
       {},
       422,
       "file",
       ""},
      {"not a leaf scan", plastic, {{"mode", "leaf"}}, 422, "file", "not a leaf scan"},
      {"unknown field", plastic, {{"colour", "red"}}, 400, "colour", "not an option"},
      {"bad model", plastic, {{"model", "phong9"}}, 400, "model", "not a model"},
      {"auto model", plastic, {{"model", "auto"}}, 400, "model", "not available yet"},
      {"bad holdout", plastic, {{"holdout", "1"}}, 400, "holdout", "fold count"},
      {"bad view", plastic, {{"view", "north"}}, 400, "view", "THETA,PHI"},
      {"bad mode", plastic, {{"mode", "bake"}}, 400, "mode", "fit or leaf"},
      {"no file", "", {{"model", "lambert"}}, 400, "file", "required"},
  };
  std::ofstream(tmp_ / "junk.zip") << "definitely not an archive";
  for (const auto& c : cases) {
    auto r = Upload(c.archive, c.fields);
    ASSERT_TRUE(r) << c.what << ": no response (" << httplib::to_string(r.error()) << ")";
    EXPECT_EQ(r->status, c.status) << c.what << ": " << r->body;
    const json e = json::parse(r->body, nullptr, false);
    ASSERT_TRUE(e.contains("error")) << c.what << ": " << r->body;
    if (!c.field.empty()) {
      EXPECT_EQ(e["error"].value("field", ""), c.field) << c.what;
    }
    EXPECT_NE(e["error"]["message"].get<std::string>().find(c.message), std::string::npos)
        << c.what << ": " << e["error"]["message"];
    ExpectDataClean(0);
  }
  // JSON bodies.
  struct JsonCase {
    std::string what, body;
    int status;
    std::string field, message;
  };
  const std::string outside = kFixtures + "/plastic-ring12";
  const std::vector<JsonCase> jcases = {
      {"malformed", "{\"dataset\": ", 400, "", "not valid JSON"},
      {"not an object", "[1, 2]", 400, "", "JSON object"},
      {"no dataset", "{}", 400, "dataset", "required"},
      {"outside the roots", json{{"dataset", outside}}.dump(), 403, "dataset", "not inside"},
      {"dotdot out of a root",
       json{{"dataset", (tmp_ / "allowed" / ".." / "data").string()}}.dump(), 403, "dataset",
       "not inside"},
      {"missing", json{{"dataset", (tmp_ / "allowed" / "nope").string()}}.dump(), 404, "dataset",
       "does not exist"},
      {"holdout type", json{{"dataset", outside}, {"holdout", "four"}}.dump(), 400, "holdout",
       "integer"},
  };
  for (const auto& c : jcases) {
    auto r = client_->Post("/api/v1/jobs", c.body, "application/json");
    ASSERT_TRUE(r) << c.what;
    EXPECT_EQ(r->status, c.status) << c.what << ": " << r->body;
    const json e = json::parse(r->body, nullptr, false);
    if (!c.field.empty()) {
      EXPECT_EQ(e["error"].value("field", ""), c.field) << c.what;
    }
    EXPECT_NE(e["error"]["message"].get<std::string>().find(c.message), std::string::npos)
        << c.what << ": " << r->body;
  }
  auto wrong_type = client_->Post("/api/v1/jobs", "dataset=x", "text/plain");
  ASSERT_TRUE(wrong_type);
  EXPECT_EQ(wrong_type->status, 415);
  ExpectDataClean(0);
  Get("/api/v1/jobs/0123456789abcdef", 404);
  Get("/api/v1/jobs?state=sleeping", 400);
  Get("/api/v1/nothing-here", 404);
}

TEST_F(ServerTest, FilesNamedOutsideTheDatasetFailTheJobWithTheReason) {
  Start();
  // An .lp file naming an existing image outside the upload by absolute path, and a leaf
  // manifest naming one by a path above the scan: both readable, both refused.
  const std::string p1 = (tmp_ / "lp.zip").string(), p2 = (tmp_ / "leaf.zip").string();
  {
    ArchiveWriter w(p1, ArchiveWriter::Format::kZip);
    w.Folder(kFixtures + "/plastic-ring12", "set", "lights.lp");
    std::string lp = Slurp(kFixtures + "/plastic-ring12/lights.lp");
    const auto at = lp.find("img_000.png");
    lp.replace(at, 11, fs::absolute(kFixtures + "/plastic-ring12/img_000.png").string());
    w.File("set/lights.lp", lp);
  }
  {
    ArchiveWriter w(p2, ArchiveWriter::Format::kZip);
    w.Folder(kFixtures + "/leaf-scan", "scan", "leaf.json");
    std::string manifest = Slurp(kFixtures + "/leaf-scan/leaf.json");
    const std::string outside = fs::absolute(kFixtures + "/leaf-scan/1_BL.png").string();
    manifest.replace(manifest.find("\"*_BL.png\""), 10, "[\"1_BL.png\", \"" + outside + "\"]");
    w.File("scan/leaf.json", manifest);
  }
  const std::pair<std::string, std::string> modes[] = {{p1, "fit"}, {p2, "leaf"}};
  for (const auto& [archive, mode] : modes) {
    auto r = Upload(archive, {{"mode", mode}});
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 202) << mode << ": " << r->body;
    const json j = WaitFor(json::parse(r->body)["id"], Finished);
    EXPECT_EQ(j["state"], "failed") << mode;
    EXPECT_NE(j["error"].get<std::string>().find("outside the dataset folder"), std::string::npos)
        << mode << ": " << j["error"];
  }
}

TEST_F(ServerTest, BearerTokensGuardWritesAndReads) {
  const std::string tokens = (tmp_ / "tokens").string();
  std::ofstream(tokens) << "write-token-0123456789\nread-token-0123456789 read\n";
  opts_.token_file = tokens;
  Start();
  const std::string plastic = ZipFixture("plastic-ring12");
  auto none = Upload(plastic, {});
  ASSERT_TRUE(none);
  EXPECT_EQ(none->status, 401);
  EXPECT_EQ(none->get_header_value("WWW-Authenticate"), "Bearer");
  EXPECT_NE(json::parse(none->body)["error"]["message"].get<std::string>().find("Bearer"),
            std::string::npos);
  auto wrong = Upload(plastic, {}, "write-token-0123456788");
  ASSERT_TRUE(wrong);
  EXPECT_EQ(wrong->status, 401);
  auto reader = Upload(plastic, {}, "read-token-0123456789");
  ASSERT_TRUE(reader);
  EXPECT_EQ(reader->status, 403);
  EXPECT_TRUE(json::parse(reader->body).contains("error"));
  auto ok = Upload(plastic, {}, "write-token-0123456789");
  ASSERT_TRUE(ok);
  ASSERT_EQ(ok->status, 202);
  const std::string id = json::parse(ok->body)["id"];
  auto anon = client_->Get(("/api/v1/jobs/" + id).c_str());
  ASSERT_TRUE(anon);
  EXPECT_EQ(anon->status, 401) << "reads need a token without --public-read";
  auto del = client_->Delete(("/api/v1/jobs/" + id).c_str(), Auth("read-token-0123456789"));
  ASSERT_TRUE(del);
  EXPECT_EQ(del->status, 403);
  auto read = client_->Get(("/api/v1/jobs/" + id).c_str(), Auth("read-token-0123456789"));
  ASSERT_TRUE(read);
  EXPECT_EQ(read->status, 200);
  auto query = client_->Get(("/api/v1/jobs/" + id + "?token=read-token-0123456789").c_str());
  ASSERT_TRUE(query);
  EXPECT_EQ(query->status, 200) << "?token= works for reads (browser pages)";
  EXPECT_EQ(client_->Get("/healthz")->status, 200);
  EXPECT_EQ(client_->Get("/metrics")->status, 200);
}

TEST_F(ServerTest, PublicReadAndNoTokenFileOnlyOnLoopback) {
  const std::string tokens = (tmp_ / "tokens").string();
  std::ofstream(tokens) << "write-token-0123456789\n";
  opts_.token_file = tokens;
  opts_.public_read = true;
  Start();
  EXPECT_EQ(client_->Get("/api/v1/jobs")->status, 200);
  EXPECT_EQ(Upload(ZipFixture("plastic-ring12"), {})->status, 401);
  ServerOptions open = opts_;
  open.token_file.clear();
  open.bind = "0.0.0.0";
  std::string why;
  EXPECT_FALSE(open.Check(&why));
  EXPECT_NE(why.find("--token-file"), std::string::npos) << why;
}

TEST_F(ServerTest, MetricsAndHealth) {
  Start();
  auto r = Upload(ZipFixture("plastic-ring12"), {{"model", "lambert"}});
  ASSERT_TRUE(r);
  WaitFor(json::parse(r->body)["id"], Finished);
  Get("/api/v1/jobs/nope", 404);
  const json h = Get("/api/v1/healthz");
  EXPECT_EQ(h["status"], "ok");
  auto m = client_->Get("/metrics");
  ASSERT_TRUE(m);
  EXPECT_EQ(m->get_header_value("Content-Type"), "text/plain; version=0.0.4");
  for (const char* line :
       {"matfit_jobs{state=\"succeeded\"} 1", "matfit_queue_length 0",
        "matfit_http_requests_total{route=\"/api/v1/jobs\",method=\"POST\",status=\"202\"} 1",
        "matfit_http_requests_total{route=\"/api/v1/jobs/{id}\",method=\"GET\",status=\"404\"} 1",
        "matfit_fit_seconds_count 1", "matfit_jobs_finished_total{state=\"succeeded\"} 1",
        "matfit_http_request_duration_seconds_bucket{route=\"/api/v1/jobs\",le=\"+Inf\"} 1"})
    EXPECT_NE(m->body.find(line), std::string::npos) << line << "\n" << m->body;
}

TEST_F(ServerTest, LeafSheetJobPacksPreviewAndViewerListEveryLeaf) {
  Start();
  auto r = Upload(ZipFixture("leaf-scan"), {{"mode", "leaf"}});
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 202) << r->body;
  const std::string id = json::parse(r->body)["id"];
  const json j = WaitFor(id, Finished, 300);
  ASSERT_EQ(j["state"], "succeeded") << j.dump(2);
  EXPECT_GE(j["summary"]["leaves"].get<int>(), 1);
  const json leaves = Get("/api/v1/packs/" + id + "/leaves.json");
  const std::string first = leaves["leaves"][0]["name"];
  EXPECT_EQ(Get("/api/v1/packs/" + id + "/report"), leaves);
  Get("/api/v1/packs/" + id + "/" + first + "/material.json");
  const json none = Get("/api/v1/packs/" + id + "/material.json", 404);
  EXPECT_NE(none["error"]["message"].get<std::string>().find("leaves.json"), std::string::npos);
  auto p = client_->Get(
      ("/api/v1/packs/" + id + "/preview.png?theta=150&size=48&leaf=" + first).c_str());
  ASSERT_TRUE(p);
  EXPECT_EQ(p->status, 200) << p->body;
  Get("/api/v1/packs/" + id + "/preview.png?leaf=leaf_99", 404);
  auto v = client_->Get(("/viewer/" + id).c_str());
  ASSERT_TRUE(v);
  EXPECT_EQ(v->status, 302);
  EXPECT_NE(v->get_header_value("Location").find("/api/v1/packs/" + id + "/" + first + "/"),
            std::string::npos);
}

TEST_F(ServerTest, ViewerPageRendersThePackInHeadlessChromium) {
  std::string chromium;
  for (const char* c : {"/usr/bin/chromium", "/usr/bin/chromium-browser"})
    if (fs::exists(c)) chromium = c;
  if (chromium.empty()) GTEST_SKIP() << "chromium not installed (scripts/install-deps.sh adds it)";
  Start();
  auto r = Upload(ZipFixture("plastic-ring12"), {{"model", "lambert"}});
  ASSERT_TRUE(r);
  const std::string id = json::parse(r->body)["id"];
  ASSERT_EQ(WaitFor(id, Finished)["state"], "succeeded");
  // Chromium follows the viewer's redirect; the options pass through it.
  const std::string page = "http://127.0.0.1:" + std::to_string(server_->port()) + "/viewer/" + id +
                           "?theta=40&phi=30&probe=1";
  const std::string profile = (tmp_ / "chromium-profile").string();
  const std::string cmd = "timeout 120 " + chromium +
                          " --headless=new --no-sandbox --use-angle=swiftshader "
                          "--enable-unsafe-swiftshader --disable-gpu-sandbox --user-data-dir=" +
                          profile + " --virtual-time-budget=20000 --dump-dom '" + page +
                          "' 2>/dev/null";
  std::string dom;
  {
    std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(cmd.c_str(), "r"), pclose);
    ASSERT_TRUE(pipe);
    char buf[65536];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, pipe.get())) > 0) dom.append(buf, n);
  }
  const size_t a = dom.find("<pre id=\"probe\">"), b = dom.find("</pre>", a);
  ASSERT_NE(a, std::string::npos) << dom.substr(0, 1500);
  const json probe = json::parse(dom.substr(a + 16, b - a - 16), nullptr, false);
  ASSERT_TRUE(probe.is_object()) << dom.substr(a, 400);
  ASSERT_FALSE(probe.contains("error")) << probe["error"];
  ASSERT_TRUE(probe.contains("rgba8_base64"));
  EXPECT_GT(probe["rgba8_base64"].get<std::string>().size(), 1000u);
}

TEST_F(ServerTest, EveryRouteOfTheOpenApiFileIsServed) {
  const json api = json::parse(Slurp(std::string(MATFIT_SOURCE_DIR) + "/docs/openapi.json"));
  Start();
  auto r = Upload(ZipFixture("plastic-ring12"), {{"model", "lambert"}});
  ASSERT_TRUE(r);
  const std::string id = json::parse(r->body)["id"];
  ASSERT_EQ(WaitFor(id, Finished)["state"], "succeeded");
  int checked = 0;
  for (const auto& [path, ops] : api["paths"].items()) {
    std::string p = path;
    auto put = [&](const std::string& key, const std::string& v) {
      if (const auto at = p.find(key); at != std::string::npos) p.replace(at, key.size(), v);
    };
    put("{id}", id);
    put("{file}", p.find("static") != std::string::npos ? "viewer.js" : "material.json");
    for (const auto& [method, op] : ops.items()) {
      if (method == "delete" || method == "post") continue;  // exercised by the other tests
      auto g = client_->Get(p.c_str());
      ASSERT_TRUE(g) << p;
      EXPECT_TRUE(g->status == 200 || g->status == 302)
          << method << " " << p << ": " << g->status << " " << g->body.substr(0, 200);
      EXPECT_TRUE(op["responses"].contains(std::to_string(g->status))) << p;
      ++checked;
    }
  }
  EXPECT_GE(checked, 12);
}

TEST_F(ServerTest, OneServerPerDataFolder) {
  Start();
  auto second = Server::Create(opts_);
  ASSERT_FALSE(second.ok());
  EXPECT_NE(second.status().message().find("in use by another matfit serve"), std::string::npos)
      << second.status().message();
}

// Connects a raw TCP socket to the server.
int Connect(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(uint16_t(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) return -1;
  return fd;
}

TEST_F(ServerTest, StalledClientsTimeOutAndAnInterruptedUploadLeavesNothing) {
  opts_.request_timeout_s = 1;
  Start();
  // A client that sends half a request line and stalls is disconnected by the read timeout.
  const int stall = Connect(server_->port());
  ASSERT_GE(stall, 0);
  const std::string half = "GET /healthz HTTP/1.1\r\nHost: x\r\n";
  ASSERT_EQ(::send(stall, half.data(), half.size(), 0), ssize_t(half.size()));
  timeval tv{15, 0};
  ::setsockopt(stall, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  std::string reply;
  char buf[4096];
  const auto t0 = std::chrono::steady_clock::now();
  for (ssize_t n; (n = ::recv(stall, buf, sizeof buf, 0)) > 0;) reply.append(buf, size_t(n));
  const double waited =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // Either a bare close or an error status, then a close — never a 200 for half a request.
  EXPECT_EQ(reply.find("200 OK"), std::string::npos) << reply;
  EXPECT_LT(waited, 10) << "no request timeout";
  std::printf("stalled client: closed after %.2f s, reply: %s\n", waited,
              reply.substr(0, reply.find('\r')).c_str());
  ::close(stall);

  // An upload that announces 8 MiB, sends 1 MiB of the file part and hangs up.
  const int up = Connect(server_->port());
  ASSERT_GE(up, 0);
  const std::string part =
      "--b0undary\r\nContent-Disposition: form-data; name=\"file\"; filename=\"x.zip\"\r\n"
      "Content-Type: application/zip\r\n\r\n";
  const std::string head =
      "POST /api/v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: "
      "multipart/form-data; boundary=b0undary\r\nContent-Length: " +
      std::to_string(8 << 20) + "\r\n\r\n" + part;
  ASSERT_EQ(::send(up, head.data(), head.size(), 0), ssize_t(head.size()));
  const std::string chunk(1 << 20, 'z');
  ASSERT_EQ(::send(up, chunk.data(), chunk.size(), 0), ssize_t(chunk.size()));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  ::close(up);
  const fs::path uploads = fs::path(opts_.data_dir) / "uploads";
  for (int i = 0; i < 100 && !fs::is_empty(uploads); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_TRUE(fs::is_empty(uploads)) << "the partial upload was left behind";
  EXPECT_TRUE(Get("/api/v1/jobs")["jobs"].empty());
}

// Sends `bytes` on a fresh connection and reads until the server closes it (or 10 s pass).
std::string RawExchange(int port, const std::string& bytes) {
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

int CountResponses(const std::string& reply) {
  int n = 0;
  for (size_t at = 0; (at = reply.find("HTTP/1.1 ", at)) != std::string::npos; ++at) ++n;
  return n;
}

TEST_F(ServerTest, ARejectedBodyIsNeverParsedAsTheNextRequest) {
  const std::string tokens = (tmp_ / "tokens").string();
  std::ofstream(tokens) << "write-token-0123456789\n";
  opts_.token_file = tokens;
  Start();
  const std::string smuggled = "GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n";
  auto post = [&](const std::string& auth, const std::string& body, bool chunked) {
    std::string h = "POST /api/v1/jobs HTTP/1.1\r\nHost: x\r\n" + auth +
                    "Content-Type: multipart/form-data; boundary=bb\r\n";
    if (!chunked) return h + "Content-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
    char size[32];
    std::snprintf(size, sizeof size, "%zx", body.size());
    return h + "Transfer-Encoding: chunked\r\n\r\n" + size + "\r\n" + body + "\r\n0\r\n\r\n";
  };
  auto field = [](const std::string& name, const std::string& v) {
    return "--bb\r\nContent-Disposition: form-data; name=\"" + name + "\"\r\n\r\n" + v + "\r\n";
  };
  // 401 before the body is read: the reply closes the connection.
  std::string r =
      RawExchange(server_->port(), post("", field("model", "lambert") + smuggled, false));
  EXPECT_NE(r.find("401"), std::string::npos) << r;
  EXPECT_EQ(CountResponses(r), 1) << "the unread body was parsed as a request:\n" << r;
  // A repeated field stops the upload early; the rest of the body is never a request.
  const std::string auth = "Authorization: Bearer write-token-0123456789\r\n";
  std::string body = field("model", "lambert") + field("model", "mean") + smuggled + "--bb--\r\n";
  r = RawExchange(server_->port(), post(auth, body, false));
  EXPECT_NE(r.find("400"), std::string::npos) << r;
  EXPECT_EQ(CountResponses(r), 1) << r;
  // Chunked, with many unknown fields: refused at the first one, not after reading them all.
  body.clear();
  for (int i = 0; i < 2000; ++i) body += field("f" + std::to_string(i), std::string(1000, 'x'));
  r = RawExchange(server_->port(), post(auth, body + "--bb--\r\n", true));
  EXPECT_NE(r.find("not an option"), std::string::npos) << r.substr(0, 300);
  EXPECT_EQ(CountResponses(r), 1);
  EXPECT_TRUE(fs::is_empty(fs::path(opts_.data_dir) / "uploads"));
}

TEST_F(ServerTest, ConcurrentDeletesDeleteOnceAndNeverFail) {
  Start();
  for (int round = 0; round < 5; ++round) {
    auto r = Upload(ZipFixture("plastic-ring12"), {{"model", "mean"}});
    ASSERT_TRUE(r);
    const std::string id = json::parse(r->body)["id"];
    ASSERT_EQ(WaitFor(id, Finished)["state"], "succeeded");
    std::atomic<int> deleted{0}, missing{0}, other{0};
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t)
      threads.emplace_back([&] {
        httplib::Client c("127.0.0.1", server_->port());
        auto d = c.Delete(("/api/v1/jobs/" + id).c_str());
        if (d && d->status == 204)
          deleted++;
        else if (d && d->status == 404)
          missing++;
        else
          other++;
      });
    for (auto& t : threads) t.join();
    EXPECT_EQ(deleted, 1);
    EXPECT_EQ(missing, 3);
    EXPECT_EQ(other, 0);
  }
}

}  // namespace
}  // namespace matfit::server
