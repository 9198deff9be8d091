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

SceneHit HitScene(Scene scene, int size, int px, int py, int width, int height) {
  SceneHit h;
  const float S = float(size), cx = float(px) + 0.5f, cy = float(py) + 0.5f;
  float tu, tv;
  if (scene == Scene::kPlane) {
    tu = cx / S, tv = cy / S;
  } else if (scene == Scene::kCloth) {
    tu = cx / S, tv = cy / S;
    float fx, fy;
    ClothHeight(2.0f * cx / S - 1.0f, 1.0f - 2.0f * cy / S, &fx, &fy);
    h.n = Normalize(Vec3f(-fx, -fy, 1.0f));
    h.t = Normalize(Vec3f(1.0f, 0.0f, fx));
    h.b = Cross(h.n, h.t);
  } else {
    const float x = 2.0f * cx / S - 1.0f, y = 1.0f - 2.0f * cy / S, r2 = x * x + y * y;
    if (r2 > 1.0f) return h;
    h.n = Vec3f(x, y, std::sqrt(1.0f - r2));
    const float phi = std::atan2(h.n.x, h.n.z), lat = std::asin(std::clamp(h.n.y, -1.0f, 1.0f));
    h.t = Vec3f(std::cos(phi), 0.0f, -std::sin(phi));
    h.b = Cross(h.n, h.t);
    const float u = 0.5f + phi / float(M_PI);
    tu = u - std::floor(u);
    tv = 0.5f - lat / float(M_PI);
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
