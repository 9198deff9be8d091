// The material service over real HTTP on 127.0.0.1 with a real client: submit → poll → fetch
// (pack equal to a direct `matfit fit`), cancel, restart during a run, metrics, previews, the
// leaf job, every OpenAPI path, and the viewer in headless Chromium.
#include "tests/server/server_fixture.h"

#include "server/job_spec.h"

namespace matfit::server::testing_fixture {
namespace {

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
    if (f.path().extension() == ".exr") {
      // OpenEXR headers carry the write time (DateTime): compare the decoded pixels, exactly.
      const fs::path served = tmp_ / ("served_" + f.path().filename().string());
      std::ofstream(served, std::ios::binary) << m->body;
      auto a = ReadImage(served.string()), b = ReadImage(f.path().string());
      ASSERT_TRUE(a.ok() && b.ok()) << f.path();
      EXPECT_EQ(a->data(), b->data()) << f.path().filename() << " differs from the direct fit";
    } else {
      EXPECT_EQ(m->body, Slurp(f.path())) << f.path().filename() << " differs from the direct fit";
    }
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

// holdout "loo" (issue 19): leave-one-out over lights, as `matfit fit --holdout loo`, from a form
// field or a JSON body; the stored spec keeps it (a restarted job re-reads it).
TEST_F(ServerTest, LeaveOneOutHoldoutFromFormAndJson) {
  opts_.allow_roots = {tmp_.string()};
  Start();
  auto r = Upload(ZipFixture("plastic-ring12"), {{"model", "lambert"}, {"holdout", "loo"}});
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 202) << r->body;
  const json job = WaitFor(json::parse(r->body)["id"], Finished);
  ASSERT_EQ(job["state"], "succeeded") << job.dump(2);
  EXPECT_EQ(job["summary"]["heldout_folds"], 12) << job.dump(2);
  EXPECT_GT(job["summary"]["heldout_psnr_srgb8_db"].get<double>(), 20) << job.dump(2);
  fs::copy(kFixtures + "/plastic-ring12", tmp_ / "ring");
  auto j =
      SubmitPath({{"dataset", (tmp_ / "ring").string()}, {"model", "lambert"}, {"holdout", "loo"}});
  ASSERT_TRUE(j);
  ASSERT_EQ(j->status, 202) << j->body;
  EXPECT_EQ(WaitFor(json::parse(j->body)["id"], Finished)["summary"]["heldout_folds"], 12);
  for (const json& bad : {json("lo"), json(true), json(-1)}) {
    auto b = SubmitPath({{"dataset", (tmp_ / "ring").string()}, {"holdout", bad}});
    ASSERT_TRUE(b);
    EXPECT_EQ(b->status, 400) << bad.dump() << " " << b->body;
    EXPECT_NE(b->body.find("holdout"), std::string::npos) << b->body;
  }
  JobSpec spec;
  spec.holdout = fit::kLeaveOneOut;
  auto back = JobSpecFromJson(spec.ToJson().dump());
  ASSERT_TRUE(back.ok()) << back.status().message();
  EXPECT_EQ(back->holdout, fit::kLeaveOneOut);
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

}  // namespace
}  // namespace matfit::server::testing_fixture
