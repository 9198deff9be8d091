#include "render/scene.h"

#include <algorithm>
#include <cmath>

namespace matfit::render {

float ClothHeight(float x, float y, float* dzdx, float* dzdy) {
  // Two families of folds hanging from the top edge, deepening toward the bottom (slopes ≤ 0.9).
  const float a = 3.1f * x + 0.6f * std::sin(2.0f * y), depth = 0.16f * (1.2f - 0.5f * y);
  const float b = 5.3f * y + 1.3f;
  *dzdx = depth * std::cos(a) * 3.1f;
  *dzdy = depth * std::cos(a) * 0.6f * 2.0f * std::cos(2.0f * y) - 0.08f * std::sin(a) +
          0.04f * 5.3f * std::cos(b);
  return depth * std::sin(a) + 0.04f * std::sin(b);
}

namespace {

// The cloth's height field minus the ray's height at parameter t.
float ClothGap(const Vec3f& o, const Vec3f& d, float t) {
  const Vec3f p = o + d * t;
  float fx, fy;
  return p.z - ClothHeight(p.x, p.y, &fx, &fy);
}

}  // namespace

SceneHit HitScene(Scene scene, const CameraFrame& cam, int size, int px, int py, int width,
                  int height) {
  SceneHit h;
  const float S = float(size);
  const float x = 2.0f * (float(px) + 0.5f) / S - 1.0f, y = 1.0f - 2.0f * (float(py) + 0.5f) / S;
  const Vec3f o = cam.r * x + cam.u * y + cam.v * 3.0f, d = cam.v * -1.0f;
  float tu, tv;
  if (scene == Scene::kSphere) {
    const float b = Dot(o, d), c = Dot(o, o) - 1.0f, disc = b * b - c;
    if (disc < 0.0f) return h;
    const Vec3f p = o + d * (-b - std::sqrt(disc));
    h.n = Normalize(p);
    const float phi = std::atan2(h.n.x, h.n.z), lat = std::asin(std::clamp(h.n.y, -1.0f, 1.0f));
    h.t = Vec3f(std::cos(phi), 0.0f, -std::sin(phi));
    h.b = Cross(h.n, h.t);
    const float u = 0.5f + phi / float(M_PI);
    tu = u - std::floor(u);
    tv = 0.5f - lat / float(M_PI);
  } else {
    float t = o.z / cam.v.z;  // plane z = 0
    if (scene == Scene::kCloth) {
      // March from z = 0.4 down to z = −0.4 (the folds stay within ±0.3), then bisect.
      const float t0 = (o.z - 0.4f) / cam.v.z, t1 = (o.z + 0.4f) / cam.v.z;
      float a = t0, b = t0;
      bool found = false;
      for (int i = 1; i <= 128 && !found; ++i) {
        b = t0 + (t1 - t0) * float(i) / 128.0f;
        if (ClothGap(o, d, b) <= 0.0f)
          found = true;
        else
          a = b;
      }
      if (!found) return h;
      for (int i = 0; i < 20; ++i) {
        const float m = 0.5f * (a + b);
        if (ClothGap(o, d, m) <= 0.0f)
          b = m;
        else
          a = m;
      }
      t = b;
    }
    const Vec3f p = o + d * t;
    // The material keeps its aspect ratio: its longer side spans [−1, 1] (a leaf crop is not
    // square), the rest of the frame is background.
    const float big = float(std::max(width, height));
    const float ax = float(width) / big, ay = float(height) / big;
    if (p.x < -ax || p.x > ax || p.y < -ay || p.y > ay) return h;
    tu = 0.5f * (p.x / ax + 1.0f), tv = 0.5f * (1.0f - p.y / ay);
    if (scene == Scene::kCloth) {
      float fx, fy;
      ClothHeight(p.x, p.y, &fx, &fy);
      h.n = Normalize(Vec3f(-fx, -fy, 1.0f));
      h.t = Normalize(Vec3f(1.0f, 0.0f, fx));
      h.b = Cross(h.n, h.t);
    }
  }
  h.hit = true;
  h.tx = std::clamp(int(tu * float(width)), 0, width - 1);
  h.ty = std::clamp(int(tv * float(height)), 0, height - 1);
  return h;
}

float DisplayEncode(float c, const RenderOptions& o) {
  c *= float(o.exposure);
  if (o.tonemap == Tonemap::kReinhard) c = c / (1.0f + std::max(c, 0.0f));
  c = std::clamp(c, 0.0f, 1.0f);
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

}  // namespace matfit::render
