// The WebGL2 viewer in a real browser: serve render/web, render/shaders and a fixture pack over
// loopback HTTP, load the page in headless Chromium (WebGL2 on SwiftShader), and compare the
// pixels it drew with the EGL renderer's (or, without EGL, the CPU reference's) render of the
// same material and light.
#include <gtest/gtest.h>
#include <httplib.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include <unistd.h>

#include "core/pack/pack.h"
#include "core/synth/materials.h"
#include "core/synth/synth.h"
#include "fit/method.h"
#include "render/cpu_renderer.h"
#include "render/egl_renderer.h"
#include "tests/render/browser.h"

namespace matfit::render {
namespace {

namespace fs = std::filesystem;

struct Case {
  const char* material;
  const char* scene;
  double theta, phi;
  const char* other = nullptr;  // a second pack listed first: the model switcher selects ours
  double camera_theta = 0, camera_phi = 0;
  const char* fit_model = nullptr;  // the pack holds this model's fit of the material (else truth)
};

TEST(WebViewer, HeadlessChromiumDrawsWhatTheEglRendererDraws) {
  const std::string chromium = FindChromium();
  if (chromium.empty()) GTEST_SKIP() << "chromium not installed (scripts/install-deps.sh adds it)";
  const fs::path tmp = fs::temp_directory_path() / ("matfit-viewer-" + std::to_string(getpid()));
  fs::remove_all(tmp);
  fs::create_directories(tmp);

  httplib::Server server;
  ASSERT_TRUE(server.set_mount_point("/web", MATFIT_SOURCE_DIR "/render/web"));
  ASSERT_TRUE(server.set_mount_point("/shaders", MATFIT_SOURCE_DIR "/render/shaders"));
  ASSERT_TRUE(server.set_mount_point("/packs", tmp.string()));
  const int port = server.bind_to_any_port("127.0.0.1");
  ASSERT_GT(port, 0);
  std::thread thread([&] { server.listen_after_bind(); });

  auto egl = EglRenderer::Create();
  for (const Case& c : {Case{"plastic", "sphere", 40, 30}, Case{"plastic-ct", "plane", 55, 200},
                        Case{"wool", "plane", 30, 45}, Case{"leaf", "plane", 150, 30, "wool-plane"},
                        Case{"plastic", "cloth", 45, 60, nullptr, 35, -40},
                        Case{"plastic", "plane", 35, 60, nullptr, 0, 0, "ptm-srgb"},
                        Case{"plastic", "sphere", 35, 60, nullptr, 0, 0, "rbf"}}) {
    MaterialMaps maps = *synth::MakeMaterial(c.material, 48, 3);
    if (c.fit_model) {  // an sRGB-domain basis (u_basis_srgb), rbf's table texture
      synth::SynthOptions so;
      so.material = c.material, so.lights = "dome:60", so.size = 48, so.layout = Layout::kLp;
      auto data = synth::Synthesize(so);
      ASSERT_TRUE(data.ok()) << data.status().ToString();
      auto fit = fit::MakeMethod(c.fit_model)->Fit(data->stack, {});
      ASSERT_TRUE(fit.ok()) << fit.status().ToString();
      maps = std::move(fit->maps);
    }
    const std::string name = std::string(c.material) + "-" + c.scene +
                             (c.fit_model ? std::string("-") + c.fit_model : "");  // the folder
    ASSERT_TRUE(
        WritePack(maps, std::vector<uint8_t>(size_t(48 * 48), 0), {}, {}, (tmp / name).string())
            .ok());
    const int size = 96;
    const std::string url =
        "http://127.0.0.1:" + std::to_string(port) + "/web/index.html?pack=/packs/" + name +
        "/&shaders=/shaders/&scene=" + c.scene + "&theta=" + std::to_string(c.theta) +
        "&phi=" + std::to_string(c.phi) + "&size=" + std::to_string(size) +
        "&camera_theta=" + std::to_string(c.camera_theta) +
        "&camera_phi=" + std::to_string(c.camera_phi) + "&probe=1";
    const std::string dom = RunCommand(
        "timeout 120 " + chromium +  // a hung browser fails the test instead of stalling CI
        " --headless=new --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader"
        " --no-first-run --disable-background-networking --disable-component-update"
        " --disable-sync --user-data-dir=" +
        (tmp / "profile").string() + " --virtual-time-budget=20000 --dump-dom '" + url +
        "' 2>/dev/null");
    const size_t a = dom.find("<pre id=\"probe\">"), b = dom.find("</pre>", a);
    ASSERT_NE(a, std::string::npos) << "no probe element in the page:\n" << dom.substr(0, 2000);
    const auto probe = nlohmann::json::parse(dom.substr(a + 16, b - a - 16), nullptr, false);
    ASSERT_TRUE(probe.is_object() && probe.contains("rgba8_base64"))
        << name << ": the page did not draw: " << dom.substr(a, std::min<size_t>(b - a, 2000));
    const std::string px = Base64Decode(probe["rgba8_base64"].get<std::string>());
    ASSERT_EQ(px.size(), size_t(size) * size * 4);

    RenderOptions o;
    o.size = size;
    o.scene = *ParseScene(c.scene);
    o.theta_deg = c.theta, o.phi_deg = c.phi;
    o.camera_theta_deg = c.camera_theta, o.camera_phi_deg = c.camera_phi;
    auto ref = egl.ok() ? (*egl)->Render(maps, o) : RenderCpu(maps, o);
    ASSERT_TRUE(ref.ok()) << ref.status().ToString();
    int64_t off = 0, lit = 0;
    double worst = 0;
    for (int64_t p = 0; p < int64_t(size) * size; ++p) {
      lit += uint8_t(px[p * 4 + 1]) > 5;
      for (int ch = 0; ch < 4; ++ch) {
        const double d =
            std::abs(double(uint8_t(px[p * 4 + ch])) - std::round(255 * ref->Plane(ch)[p]));
        worst = std::max(worst, d);
        off += d > 2;
      }
    }
    EXPECT_GT(lit, size * size / 4) << name << ": the canvas is (nearly) blank";
    EXPECT_LE(off, int64_t(size) * size * 4 / 200)
        << name << " " << c.scene << ": " << off << " values differ by > 2/255 (worst " << worst
        << ") from the " << (egl.ok() ? "EGL" : "CPU") << " render; browser renderer "
        << probe.value("renderer", "?");
    std::printf("%s %s: browser (%s) vs %s: %lld of %d values off by > 2/255, worst %.0f\n",
                name.c_str(), c.scene, probe.value("renderer", "?").c_str(),
                egl.ok() ? "EGL" : "CPU", (long long)off, size * size * 4, worst);
  }
  server.stop();
  thread.join();
  fs::remove_all(tmp);
}

}  // namespace
}  // namespace matfit::render
