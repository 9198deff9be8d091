// The service's web pages driven in a real browser (headless Chromium): the landing page at `/`
// (a folder upload packed in the page as a tar, an archive upload for a leaf job, the job
// followed to the end, the links it gives), and the viewer's controls (light sliders, keyboard,
// the model/leaf switcher and its labels).
//
// A test page ("harness") drives the real pages in a same-origin iframe, the way a user would:
// it fills the file inputs (DataTransfer), picks options, clicks, presses keys and moves sliders,
// and writes what it saw as JSON into the page, which Chromium dumps. Same origin: a small proxy
// here serves the harness and the fixture files and forwards every other request to the matfit
// server. Chromium's virtual time fast-forwards timers, so the harness waits for the server in
// real time through /wait (a pending request pauses virtual time). Screenshots of the landing
// page and of the viewer are checked for non-blank content. The proxy passes the server's
// security headers on, so the pages run under their real Content-Security-Policy.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <set>

#include "tests/render/browser.h"
#include "tests/server/server_fixture.h"

namespace matfit::server::testing_fixture {
namespace {

std::string Chromium() { return ::matfit::render::FindChromium(); }

using ::matfit::render::RunCommand;

// The harness: steps run in order; each records into R; the result goes to <pre id="result">.
constexpr const char* kHarness = R"html(<!doctype html>
<html><body>
<iframe id="f" width="1100" height="900"></iframe>
<pre id="result"></pre>
<script>
'use strict';
const R = {steps: []};
const FOLDER = __FOLDER__;
const TOKEN = '__TOKEN__';
const realWait = (ms) => fetch('/wait?ms=' + ms);
const virtualSleep = (ms) => new Promise((r) => setTimeout(r, ms));
// Polls cond() for up to `seconds` of real time, letting the page's own timers run between.
async function until(cond, seconds, what) {
  for (let i = 0; i < seconds * 4; ++i) {
    try { if (cond()) return true; } catch (_) {}
    await realWait(200);
    await virtualSleep(800);
  }
  R.steps.push('timed out: ' + what);
  return false;
}
const f = document.getElementById('f');
async function load(url) {
  await new Promise((r) => { f.onload = r; f.src = url; });
  return [f.contentDocument, f.contentWindow];
}
async function files(w, names, prefix) {
  const dt = new w.DataTransfer();
  for (const n of names) {
    const b = await (await fetch(prefix + n)).blob();
    dt.items.add(new w.File([b], n));
  }
  return dt.files;
}
// Mean of the viewer canvas's rgb (preserveDrawingBuffer keeps the last frame).
function canvasMean(d) {
  const c = d.getElementById('canvas'), t = document.createElement('canvas');
  t.width = c.width, t.height = c.height;
  const g = t.getContext('2d');
  g.drawImage(c, 0, 0);
  const px = g.getImageData(0, 0, t.width, t.height).data;
  let s = 0;
  for (let i = 0; i < px.length; i += 4) s += px[i] + px[i + 1] + px[i + 2];
  return s / (px.length / 4 * 3);
}
const key = (w, d, k, shift) =>
    d.dispatchEvent(new w.KeyboardEvent('keydown', {key: k, shiftKey: !!shift, bubbles: true}));

(async () => {
  // 1. The landing page: its model list comes from the server.
  let [d, w] = await load('/');
  await until(() => d.getElementById('model').options.length > 5, 20, 'model list');
  R.models = Array.from(d.getElementById('model').options).map((o) => o.value);
  R.title = d.title;

  // 2. A folder of images (an .lp set) uploaded through the folder input: packed as a tar. The
  //    server wants a token (typed in like a user would); the page and model list did not.
  d.getElementById('token').value = TOKEN;
  d.getElementById('folder').files = await files(w, FOLDER, '/fixture/plastic-ring12/');
  d.getElementById('folder').dispatchEvent(new w.Event('change'));
  R.picked = d.getElementById('picked').textContent;
  d.getElementById('model').value = 'lambert';
  d.getElementById('submit').click();
  await until(() => !d.getElementById('done').hidden || d.getElementById('error').textContent,
              90, 'fit job');
  R.fit = {error: d.getElementById('error').textContent,
           state: d.getElementById('job-state').textContent,
           progress: d.getElementById('job-progress').value,
           viewer: d.getElementById('open-viewer').getAttribute('href'),
           download: d.getElementById('download').getAttribute('href')};
  await until(() => d.getElementById('result-image').naturalWidth > 0, 20, 'preview image');
  R.fit.preview_width = d.getElementById('result-image').naturalWidth;
  const fitJob = R.fit.viewer.split('/').pop().split('?')[0];

  // 3. A leaf scan uploaded as an archive; the page lists the leaves and shows the numbered
  //    segmentation picture.
  d.getElementById('archive').files = await files(w, ['leaf-scan.zip'], '/fixture-zip/');
  d.getElementById('archive').dispatchEvent(new w.Event('change'));
  d.getElementById('mode').value = 'leaf';
  d.getElementById('mode').dispatchEvent(new w.Event('change'));
  R.model_hidden_for_leaf = d.getElementById('model-label').hidden;
  d.getElementById('submit').click();
  await until(() => (!d.getElementById('done').hidden &&
                     d.getElementById('leaves').children.length > 0) ||
                    d.getElementById('error').textContent, 90, 'leaf job');
  R.leaf = {error: d.getElementById('error').textContent,
            leaves: Array.from(d.getElementById('leaves').children).map((li) => li.textContent),
            viewer: d.getElementById('open-viewer').getAttribute('href')};
  await until(() => d.getElementById('result-image').naturalWidth > 0, 20, 'segmentation');
  R.leaf.image = d.getElementById('result-image').getAttribute('src');
  R.leaf.image_width = d.getElementById('result-image').naturalWidth;
  const leafJob = R.leaf.viewer.split('/').pop().split('?')[0];

  // 4. The viewer of the fit: sliders and keys move the light; the picture changes.
  [d, w] = await load(R.fit.viewer + '&size=128&theta=30&phi=45');
  await until(() => d.getElementById('light').textContent.includes('θ'), 30, 'viewer');
  const th = d.getElementById('light-theta'), ph = d.getElementById('light-phi');
  R.viewer = {light0: d.getElementById('light').textContent, mean0: canvasMean(d)};
  th.value = '80';
  th.dispatchEvent(new w.Event('input'));
  R.viewer.slider = d.getElementById('light').textContent;
  R.viewer.mean_grazing = canvasMean(d);
  for (let i = 0; i < 4; ++i) key(w, d, 'ArrowUp');      // θ 80 → 60
  key(w, d, 'ArrowLeft');                                 // φ 45 → 40
  key(w, d, 'ArrowRight', true);                          // φ 40 → 41
  R.viewer.keys = d.getElementById('light').textContent;
  R.viewer.slider_after_keys = [th.value, ph.value];
  R.viewer.theta_max = th.max;

  // 5. Two packs in one viewer (the fit and the leaf): labels name the leaf; ] and [ switch.
  const packs = `/api/v1/packs/${fitJob}/,/api/v1/packs/${leafJob}/leaf_01/`;
  [d, w] = await load(`/api/v1/viewer/static/index.html?pack=${packs}` +
                      '&shaders=/api/v1/viewer/static/&size=96&token=' + TOKEN);
  await until(() => d.getElementById('model').options.length === 2 &&
                    d.getElementById('light').textContent, 30, 'two-pack viewer');
  const sel = d.getElementById('model');
  R.switcher = {labels: Array.from(sel.options).map((o) => o.textContent),
                label: d.getElementById('model-label').firstChild.textContent,
                hidden: d.getElementById('model-label').hidden, first: sel.value};
  key(w, d, ']');
  await until(() => sel.value === '1' && d.getElementById('title').textContent.includes('lambert')
                    === false, 10, 'switch to the leaf');
  R.switcher.after = sel.value;
  R.switcher.theta_max_leaf = d.getElementById('light-theta').max;
  R.switcher.title = d.getElementById('title').textContent;
  key(w, d, '[');
  await until(() => sel.value === '0', 10, 'switch back');
  R.switcher.back = sel.value;
})().catch((e) => R.steps.push('error: ' + e)).finally(() => {
  document.getElementById('result').textContent = JSON.stringify(R);
});
</script>
</body></html>
)html";

class WebUiTest : public ServerTest {
 protected:
  // The proxy: the harness, /wait, the fixtures; everything else goes to the matfit server.
  void StartProxy(const std::string& harness, const std::string& leaf_zip) {
    proxy_.Get("/harness.html", [harness](const httplib::Request&, httplib::Response& res) {
      res.set_content(harness, "text/html; charset=utf-8");
    });
    proxy_.Get("/wait", [](const httplib::Request& req, httplib::Response& res) {
      const int ms = std::clamp(std::atoi(req.get_param_value("ms").c_str()), 0, 2000);
      std::this_thread::sleep_for(std::chrono::milliseconds(ms));
      res.set_content("ok", "text/plain");
    });
    proxy_.Get(R"(/fixture/plastic-ring12/([A-Za-z0-9_.]+))",
               [](const httplib::Request& req, httplib::Response& res) {
                 res.set_content(Slurp(kFixtures + "/plastic-ring12/" + req.matches[1].str()),
                                 "application/octet-stream");
               });
    proxy_.Get("/fixture-zip/leaf-scan.zip",
               [leaf_zip](const httplib::Request&, httplib::Response& res) {
                 res.set_content(Slurp(leaf_zip), "application/zip");
               });
    const int port = server_->port();
    auto copy = [](const httplib::Result& r, httplib::Response& res) {
      if (!r) return void(res.status = 502);
      res.status = r->status;
      for (const char* h :
           {"Location", "Cache-Control", "Content-Security-Policy", "X-Content-Type-Options"})
        if (r->has_header(h)) res.set_header(h, r->get_header_value(h));
      res.set_content(r->body, r->get_header_value("Content-Type").c_str());
    };
    auto headers = [](const httplib::Request& req) {
      httplib::Headers h;
      if (req.has_header("Authorization"))
        h.emplace("Authorization", req.get_header_value("Authorization"));
      return h;
    };
    proxy_.Get(".*", [=](const httplib::Request& req, httplib::Response& res) {
      httplib::Client c("127.0.0.1", port);
      c.set_read_timeout(60, 0);
      copy(c.Get(req.target.c_str(), headers(req)), res);
    });
    proxy_.Post(".*", [=](const httplib::Request& req, httplib::Response& res) {
      httplib::Client c("127.0.0.1", port);
      c.set_read_timeout(60, 0);
      httplib::MultipartFormDataItems items;  // the browser's form, field by field
      for (const auto& [name, file] : req.files)
        items.push_back({name, file.content, file.filename, file.content_type});
      copy(items.empty() ? c.Post(req.target.c_str(), headers(req), req.body,
                                  req.get_header_value("Content-Type").c_str())
                         : c.Post(req.target.c_str(), headers(req), items),
           res);
    });
    proxy_.set_exception_handler(
        [](const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
          std::string what = "unknown";
          try {
            std::rethrow_exception(ep);
          } catch (const std::exception& e) {
            what = e.what();
          }
          res.status = 500;
          res.set_content("proxy: " + req.method + " " + req.target + ": " + what, "text/plain");
        });
    proxy_port_ = proxy_.bind_to_any_port("127.0.0.1");
    ASSERT_GT(proxy_port_, 0);
    proxy_thread_ = std::thread([this] { proxy_.listen_after_bind(); });
  }
  void TearDown() override {
    proxy_.stop();
    if (proxy_thread_.joinable()) proxy_thread_.join();
    ServerTest::TearDown();
  }
  std::string Url(const std::string& path) const {
    return "http://127.0.0.1:" + std::to_string(proxy_port_) + path;
  }
  std::string Browser(const std::string& flags, const std::string& url) {
    return RunCommand(
        "timeout 300 " + chromium_ +
        " --headless=new --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader"
        " --disable-gpu-sandbox --no-first-run --disable-background-networking"
        " --disable-component-update --disable-sync --user-data-dir=" +
        (tmp_ / "chromium-profile").string() + " " + flags + " '" + url + "' 2>/dev/null");
  }
  // A screenshot of `url` has content: many distinct colours and a spread of brightness.
  void ExpectNonBlankScreenshot(const std::string& url, const std::string& name) {
    const std::string png = (tmp_ / (name + ".png")).string();
    Browser("--window-size=1000,800 --virtual-time-budget=20000 --screenshot=" + png, url);
    auto img = ReadImage(png);
    ASSERT_TRUE(img.ok()) << name << ": no screenshot: " << img.status().ToString();
    std::set<int> colours;
    double sum = 0, sum2 = 0;
    const int64_t n = img->plane_size();
    for (int64_t p = 0; p < n; ++p) {
      int code = 0;
      double l = 0;
      for (int c = 0; c < 3; ++c) {
        const float v = img->Plane(std::min(c, img->channels() - 1))[p];
        code = code * 64 + int(v * 63.0f), l += v / 3;
      }
      colours.insert(code), sum += l, sum2 += l * l;
    }
    const double sd =
        std::sqrt(std::max(0.0, sum2 / double(n) - (sum / double(n)) * (sum / double(n))));
    std::printf("screenshot %s: %zu colours, brightness sd %.3f\n", name.c_str(), colours.size(),
                sd);
    EXPECT_GT(colours.size(), 20u) << name << " looks blank";
    EXPECT_GT(sd, 0.03) << name << " looks blank";
  }

  httplib::Server proxy_;
  std::thread proxy_thread_;
  int proxy_port_ = 0;
  std::string chromium_;
};

TEST_F(WebUiTest, LandingPageAndViewerControlsWorkInHeadlessChromium) {
  chromium_ = Chromium();
  if (chromium_.empty()) GTEST_SKIP() << "chromium not installed (scripts/install-deps.sh adds it)";
  const std::string token = "web-ui-token-0123456789";
  std::ofstream(tmp_ / "tokens") << token << "\n";
  opts_.token_file = (tmp_ / "tokens").string();
  Start();
  // The landing page and the model list need no token; the jobs do.
  for (const char* open : {"/", "/api/v1/models", "/api/v1/viewer/static/home.js"}) {
    auto g = client_->Get(open);
    ASSERT_TRUE(g);
    EXPECT_EQ(g->status, 200) << open;
  }
  auto jobs = client_->Get("/api/v1/jobs");
  ASSERT_TRUE(jobs);
  EXPECT_EQ(jobs->status, 401);
  std::string folder = "[";
  for (const auto& e : fs::directory_iterator(kFixtures + "/plastic-ring12"))
    if (e.is_regular_file())
      folder += (folder.size() > 1 ? ",\"" : "\"") + e.path().filename().string() + "\"";
  folder += "]";
  std::string harness = kHarness;
  harness.replace(harness.find("__FOLDER__"), 10, folder);
  harness.replace(harness.find("__TOKEN__"), 9, token);
  StartProxy(harness, ZipFixture("leaf-scan"));

  const std::string dom = Browser("--virtual-time-budget=600000 --dump-dom", Url("/harness.html"));
  const size_t a = dom.find("<pre id=\"result\">"), b = dom.find("</pre>", a);
  ASSERT_NE(a, std::string::npos) << dom.substr(0, 1500);
  std::string text = dom.substr(a + 17, b - a - 17);
  for (const auto& [from, to] : {std::pair{"&amp;", "&"}, {"&lt;", "<"}, {"&gt;", ">"}})
    for (size_t at; (at = text.find(from)) != std::string::npos;)
      text.replace(at, strlen(from), to);
  const json r = json::parse(text, nullptr, false);
  ASSERT_TRUE(r.is_object()) << text.substr(0, 2000);
  std::printf("harness: %s\n", r.dump().c_str());
  EXPECT_TRUE(r["steps"].empty()) << r["steps"].dump();

  // Landing page: every model of the ladder offered, auto first.
  ASSERT_TRUE(r["models"].is_array());
  EXPECT_EQ(r["models"][0], "auto");
  for (const auto& m : fit::MethodNames())
    EXPECT_NE(std::find(r["models"].begin(), r["models"].end(), m), r["models"].end()) << m;
  // The folder upload fitted, and the page links the viewer, the pack and the preview.
  EXPECT_NE(r["picked"].get<std::string>().find("13 files"), std::string::npos) << r["picked"];
  EXPECT_EQ(r["fit"]["error"], "");
  EXPECT_NE(r["fit"]["state"].get<std::string>().find("succeeded"), std::string::npos);
  EXPECT_EQ(r["fit"]["progress"], 1);
  EXPECT_EQ(r["fit"]["viewer"].get<std::string>().rfind("/viewer/", 0), 0u);
  EXPECT_NE(r["fit"]["viewer"].get<std::string>().find("token=" + token), std::string::npos);
  EXPECT_EQ(r["fit"]["download"].get<std::string>().rfind("/api/v1/packs/", 0), 0u);
  EXPECT_GT(r["fit"]["preview_width"].get<int>(), 0);
  // The leaf job: listed by number, numbered segmentation shown, model choice hidden.
  EXPECT_TRUE(r["model_hidden_for_leaf"].get<bool>());
  EXPECT_EQ(r["leaf"]["error"], "");
  ASSERT_EQ(r["leaf"]["leaves"].size(), 1u) << r["leaf"];
  EXPECT_EQ(r["leaf"]["leaves"][0].get<std::string>().rfind("leaf 1 (leaf_01", 0), 0u);
  EXPECT_NE(r["leaf"]["image"].get<std::string>().find("segmentation.png"), std::string::npos);
  EXPECT_GT(r["leaf"]["image_width"].get<int>(), 0);
  // Viewer controls: the slider and the keys set the light, and the picture follows it.
  const json& v = r["viewer"];
  EXPECT_EQ(v["light0"], "light θ 30.0°, φ 45.0°");
  EXPECT_EQ(v["slider"], "light θ 80.0°, φ 45.0°");
  EXPECT_GT(v["mean0"].get<double>(), 20) << "the viewer drew nothing";
  EXPECT_LT(v["mean_grazing"].get<double>(), 0.8 * v["mean0"].get<double>())
      << "a grazing light should darken a lambert plane";
  EXPECT_EQ(v["keys"], "light θ 60.0°, φ 41.0°");
  EXPECT_EQ(v["slider_after_keys"], json({"60", "41"}));
  EXPECT_EQ(v["theta_max"], "85");
  // The switcher names the leaf by its number and folder; ] and [ step through the packs, and
  // a leaf can be lit from behind (θ up to 180°).
  const json& s = r["switcher"];
  ASSERT_EQ(s["labels"].size(), 2u);
  EXPECT_EQ(s["labels"][0], "lambert");
  EXPECT_EQ(s["labels"][1].get<std::string>().rfind("leaf 1 (leaf_01, ", 0), 0u) << s["labels"];
  EXPECT_EQ(s["label"], "leaf ");
  EXPECT_FALSE(s["hidden"].get<bool>());
  EXPECT_EQ(s["first"], "0");
  EXPECT_EQ(s["after"], "1");
  EXPECT_EQ(s["theta_max_leaf"], "180");
  EXPECT_EQ(s["back"], "0");

  // Screenshots: the landing page and the viewer are not blank.
  ExpectNonBlankScreenshot(Url("/"), "landing");
  ExpectNonBlankScreenshot(Url(r["fit"]["viewer"].get<std::string>() + "&size=256"), "viewer");
}

}  // namespace
}  // namespace matfit::server::testing_fixture
