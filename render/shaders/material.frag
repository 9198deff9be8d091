// Material preview: per pixel, hit the scene (plane or sphere, orthographic camera looking down
// −z), fetch the texel's parameters, evaluate the model in the tangent frame (shading.glsl),
// add ambient, then expose, tone-map and encode. Mirrors render/cpu_renderer.cc.
// Parameter planes (core/pack/shader_params.h): plane q is component q % 4 of layer q / 4.
uniform sampler2DArray u_params;
uniform sampler2DArray u_basis_table;  // rbf: the basis table, one R32F layer per term
uniform int u_table_size;              // rbf: nodes per side of u_basis_table
uniform ivec2 u_texels;     // material width, height
uniform int u_size;         // output is u_size × u_size pixels
uniform int u_scene;        // 0 plane, 1 sphere, 2 cloth
uniform int u_model;        // 0 mean, 1 lambert, 2 blinn-phong, 3 cook-torrance, 4 heinrich,
                            // 5 ptm, 6 hsh, 7 lafortune, 8 rbf
uniform int u_terms;        // ptm/hsh/rbf coefficients per channel, or lafortune lobes
uniform int u_coef_channels;  // ptm/hsh/rbf: 1 (grey) or 3
uniform bool u_basis_srgb;    // ptm/hsh: the basis sum is sRGB-encoded (decode after clamping)
uniform bool u_heinrich_specular, u_flat_normal;
uniform int u_leaf_base;    // −1: one-sided material; else the first leaf plane (two-sided)
uniform bool u_leaf_hl2;
uniform vec3 u_light;       // unit, world frame (toward the light)
uniform vec3 u_cam_v, u_cam_r, u_cam_u;  // camera: toward the camera, image right, image up
uniform vec3 u_intensity;   // light colour × intensity
uniform vec3 u_ambient;     // ambient × albedo is added
uniform float u_exposure;
uniform int u_tonemap;      // 0 clamp, 1 Reinhard
uniform bool u_display;     // true: exposure, tone map and sRGB encode; false: linear radiance
out vec4 o_color;

ivec2 g_texel;
float P(int q) { return texelFetch(u_params, ivec3(g_texel, q / 4), 0)[q % 4]; }

float EvaluateChannel(int c, vec3 l, vec3 v) {
  if (u_model == 0) return P(3 + c);
  if (u_model == 5 || u_model == 6 || u_model == 8) {
    float b[16];
    if (u_model == 5)
      PtmBasis(l, b);
    else if (u_model == 8)
      RbfTableBasis(u_basis_table, u_table_size, u_terms, l, b);
    else
      HshBasis(int(round(sqrt(float(u_terms)))), l, b);
    int base = 7 + (u_coef_channels == 1 ? 0 : c) * u_terms;
    float r = 0.0;
    for (int j = 0; j < u_terms; ++j) r += b[j] * P(base + j);
    return u_basis_srgb ? SrgbDecode(clamp(r, 0.0, 1.0)) : r;
  }
  vec3 n = vec3(P(0), P(1), P(2));
  if (u_model == 4) {
    float r = HeinrichDiffuse(P(3 + c), P(7 + c), n * P(10), l);
    if (u_heinrich_specular) {
      vec3 ns = u_flat_normal ? vec3(0.0, 0.0, 1.0) : n;
      r += HeinrichSpecular(P(11 + c), P(14), ns, l, v);
    }
    return r;
  }
  float r = Lambert(P(3 + c), n, l);
  if (u_model == 2) r += BlinnPhongSpecular(P(7), P(8), n, l, v);
  if (u_model == 3) r += CookTorranceSpecular(P(7), P(8), n, l, v);
  if (u_model == 7)
    for (int j = 0; j < u_terms; ++j)
      r += LafortuneLobe(P(7 + j), P(7 + u_terms + 2 * j), P(8 + u_terms + 2 * j), n, l, v);
  return r;
}

// render/scene.cc ClothHeight: folds over [−1, 1]²; returns (z, ∂z/∂x, ∂z/∂y).
vec3 ClothHeight(float x, float y) {
  float a = 3.1 * x + 0.6 * sin(2.0 * y), depth = 0.16 * (1.2 - 0.5 * y);
  float b = 5.3 * y + 1.3;
  float dzdx = depth * cos(a) * 3.1;
  float dzdy = depth * cos(a) * 0.6 * 2.0 * cos(2.0 * y) - 0.08 * sin(a) + 0.04 * 5.3 * cos(b);
  return vec3(depth * sin(a) + 0.04 * sin(b), dzdx, dzdy);
}

// core/shading/evaluate.cc EvaluateLeafTexel: the lower side's frame is (x, −y, −z).
float EvaluateLeafChannel(int c, vec3 l, vec3 v) {
  bool light_up = l.z > 0.0, view_up = v.z > 0.0;
  if (light_up && view_up) return EvaluateChannel(c, l, v);
  vec3 lower = vec3(l.x, -l.y, -l.z);
  if (!light_up && !view_up) return Lambert(P(u_leaf_base + 3 + c), vec3(0.0, 0.0, 1.0), lower);
  vec3 w = light_up ? l : lower;
  float rho_t = P(u_leaf_base + c);
  if (!u_leaf_hl2) return DiffuseTranslucency(rho_t, w);
  int hb = u_leaf_base + 6;
  return Hl2Translucency(rho_t, vec3(P(hb), P(hb + 1), P(hb + 2)), w);
}

float ClothGap(vec3 o, vec3 d, float t) {
  vec3 p = o + d * t;
  return p.z - ClothHeight(p.x, p.y).x;
}

float EncodeSrgb(float x) {
  return x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
}

void main() {
  // Pixel centre in image coordinates (row 0 at the top); render/scene.cc HitScene.
  float px = floor(gl_FragCoord.x) + 0.5;
  float py = float(u_size) - floor(gl_FragCoord.y) - 0.5;
  float S = float(u_size);
  float x = 2.0 * px / S - 1.0, y = 1.0 - 2.0 * py / S;
  vec3 o = u_cam_r * x + u_cam_u * y + u_cam_v * 3.0, d = u_cam_v * -1.0;
  vec3 T = vec3(1.0, 0.0, 0.0), B = vec3(0.0, 1.0, 0.0), N = vec3(0.0, 0.0, 1.0);
  float tu, tv;  // texture coordinates in [0, 1), tv from the top row
  if (u_scene == 1) {
    float b = dot(o, d), c = dot(o, o) - 1.0, disc = b * b - c;
    if (disc < 0.0) {
      o_color = vec4(0.0);
      return;
    }
    N = normalize(o + d * (-b - sqrt(disc)));
    float phi = atan(N.x, N.z), lat = asin(clamp(N.y, -1.0, 1.0));
    T = vec3(cos(phi), 0.0, -sin(phi));
    B = cross(N, T);
    tu = fract(0.5 + phi / kPi);
    tv = 0.5 - lat / kPi;
  } else {
    float t = o.z / u_cam_v.z;  // plane z = 0
    if (u_scene == 2) {
      float t0 = (o.z - 0.4) / u_cam_v.z, t1 = (o.z + 0.4) / u_cam_v.z;
      float a = t0, bt = t0;
      bool found = false;
      for (int i = 1; i <= 128 && !found; ++i) {
        bt = t0 + (t1 - t0) * float(i) / 128.0;
        if (ClothGap(o, d, bt) <= 0.0) found = true; else a = bt;
      }
      if (!found) {
        o_color = vec4(0.0);
        return;
      }
      for (int i = 0; i < 20; ++i) {
        float m = 0.5 * (a + bt);
        if (ClothGap(o, d, m) <= 0.0) bt = m; else a = m;
      }
      t = bt;
    }
    vec3 p = o + d * t;
    // The material keeps its aspect ratio (render/scene.cc).
    float big = float(max(u_texels.x, u_texels.y));
    float ax = float(u_texels.x) / big, ay = float(u_texels.y) / big;
    if (p.x < -ax || p.x > ax || p.y < -ay || p.y > ay) {
      o_color = vec4(0.0);
      return;
    }
    tu = 0.5 * (p.x / ax + 1.0);
    tv = 0.5 * (1.0 - p.y / ay);
    if (u_scene == 2) {
      vec3 f = ClothHeight(p.x, p.y);
      N = normalize(vec3(-f.y, -f.z, 1.0));
      T = normalize(vec3(1.0, 0.0, f.y));
      B = cross(N, T);
    }
  }
  g_texel = clamp(ivec2(int(tu * float(u_texels.x)), int(tv * float(u_texels.y))), ivec2(0),
                  u_texels - 1);
  if (P(6) < 0.5) {  // mask: background
    o_color = vec4(0.0);
    return;
  }
  vec3 v = u_cam_v;
  vec3 lt = vec3(dot(u_light, T), dot(u_light, B), dot(u_light, N));
  vec3 vt = vec3(dot(v, T), dot(v, B), dot(v, N));
  vec3 f = vec3(0.0);
  if (u_leaf_base >= 0)  // two-sided: light from behind is transmitted
    f = vec3(EvaluateLeafChannel(0, lt, vt), EvaluateLeafChannel(1, lt, vt),
             EvaluateLeafChannel(2, lt, vt));
  else if (dot(u_light, N) > 0.0)  // the light is above this point's horizon
    f = vec3(EvaluateChannel(0, lt, vt), EvaluateChannel(1, lt, vt), EvaluateChannel(2, lt, vt));
  vec3 color = u_intensity * f + u_ambient * vec3(P(3), P(4), P(5));
  if (u_display) {
    color *= u_exposure;
    color = u_tonemap == 1 ? color / (1.0 + max(color, vec3(0.0))) : color;
    color = clamp(color, 0.0, 1.0);
    color = vec3(EncodeSrgb(color.r), EncodeSrgb(color.g), EncodeSrgb(color.b));
  }
  o_color = vec4(color, 1.0);
}
