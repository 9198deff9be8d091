// GLSL port of core/shading/shading.h, core/shading/relight_basis.cc and
// core/shading/evaluate.cc: the same formulas, line for line, so previews agree with the fits.
// Vectors are unit, in the tangent frame (x right, y up, z out of the surface).

const float kPi = 3.14159265358979;

// ---- shading.h ----
float Clamp0(float x) { return x > 0.0 ? x : 0.0; }

// R = ρ · max(0, n·l)
float Lambert(float albedo, vec3 n, vec3 l) { return albedo * Clamp0(dot(n, l)); }

// R_s = k_s · max(0, n·h)^e · max(0, n·l)
float BlinnPhongSpecular(float ks, float e, vec3 n, vec3 l, vec3 v) {
  vec3 h = normalize(l + v);
  float nl = dot(n, l);
  if (!(nl > 0.0)) return 0.0;
  float nh = Clamp0(dot(n, h));
  if (!(nh > 0.0)) return 0.0;
  return ks * pow(nh, e) * nl;
}

float GgxD(float nh, float alpha) {
  float a2 = alpha * alpha;
  float d = nh * nh * (a2 - 1.0) + 1.0;
  return a2 / (kPi * d * d);
}
float GgxG1(float nx, float alpha) {
  float a2 = alpha * alpha;
  return 2.0 * nx / (nx + sqrt(a2 + (1.0 - a2) * nx * nx));
}
float SchlickFresnel(float f0, float vh) {
  float m = 1.0 - Clamp0(vh);
  float m2 = m * m;
  return f0 + (1.0 - f0) * m2 * m2 * m;
}
// R_s = π · D G F / (4 (n·l)(n·v)) · (n·l)
float CookTorranceSpecular(float f0, float roughness, vec3 n, vec3 l, vec3 v) {
  float nl = dot(n, l), nv = dot(n, v);
  if (!(nl > 0.0) || !(nv > 0.0)) return 0.0;
  vec3 h = normalize(l + v);
  float nh = Clamp0(dot(n, h));
  float alpha = roughness * roughness;
  float dgf = GgxD(nh, alpha) * GgxG1(nl, alpha) * GgxG1(nv, alpha) * SchlickFresnel(f0, dot(v, h));
  return kPi * dgf / (4.0 * nv);
}

// D = C_xy (l·v − (n·l)(n·v)) + (n·l)(n·v); R_s = ρ_s · max(0, D)^e · max(0, n·l)
float LafortuneLobe(float rho_s, float c_xy, float e, vec3 n, vec3 l, vec3 v) {
  float nl = dot(n, l), nv = dot(n, v);
  if (!(nl > 0.0) || !(nv > 0.0)) return 0.0;
  float d = c_xy * (dot(l, v) - nl * nv) + nl * nv;
  if (!(d > 0.0)) return 0.0;
  return rho_s * pow(d, e) * nl;
}

// Seed method A: t·a + t·(n_raw·l); L_spec · max(0, n_s·h)^e
float HeinrichDiffuse(float t, float ambient, vec3 n_raw, vec3 l) {
  return t * ambient + t * dot(n_raw, l);
}
float HeinrichSpecular(float l_spec, float e, vec3 n_s, vec3 l, vec3 v) {
  float nh = Clamp0(dot(n_s, normalize(l + v)));
  return l_spec * pow(nh, e);
}

// Leaf translucency: ρ_t Σ_i h_i √(3/(2π)) H_i·ω (HL2), or the diffuse BTDF ρ_t max(0, ω_z).
float Hl2Translucency(float rho_t, vec3 h, vec3 w) {
  const vec3 H1 = vec3(-0.40824829046386301, -0.70710678118654752, 0.57735026918962576);
  const vec3 H2 = vec3(-0.40824829046386301, 0.70710678118654752, 0.57735026918962576);
  const vec3 H3 = vec3(0.81649658092772603, 0.0, 0.57735026918962576);
  const float kScale = 0.69098829894267105;
  float r = h.x * kScale * dot(H1, w) + h.y * kScale * dot(H2, w) + h.z * kScale * dot(H3, w);
  return rho_t * Clamp0(r);
}
float DiffuseTranslucency(float rho_t, vec3 w) { return rho_t * Clamp0(w.z); }

// ---- relight_basis.cc ----
// core/color.h SrgbToLinear: the decode of an sRGB-encoded basis sum (MaterialMaps::basis_srgb).
float SrgbDecode(float x) {
  return x <= 0.04045 ? x / 12.92 : pow((x + 0.055) / 1.055, 2.4);
}

void PtmBasis(vec3 l, out float b[16]) {
  b[0] = l.x * l.x;
  b[1] = l.y * l.y;
  b[2] = l.x * l.y;
  b[3] = l.x;
  b[4] = l.y;
  b[5] = 1.0;
}

// Associated Legendre P_l^m(x), m ≥ 0, Condon–Shortley phase.
float Legendre(int l, int m, float x) {
  float pmm = 1.0;
  if (m > 0) {
    float somx2 = sqrt(max(0.0, (1.0 - x) * (1.0 + x)));
    float fact = 1.0;
    for (int i = 1; i <= m; ++i) {
      pmm *= -fact * somx2;
      fact += 2.0;
    }
  }
  if (l == m) return pmm;
  float pmmp1 = x * float(2 * m + 1) * pmm;
  if (l == m + 1) return pmmp1;
  float pll = 0.0;
  for (int ll = m + 2; ll <= l; ++ll) {
    pll = (float(2 * ll - 1) * x * pmmp1 - float(ll + m - 1) * pmm) / float(ll - m);
    pmm = pmmp1;
    pmmp1 = pll;
  }
  return pll;
}
float Factorial(int n) {
  float f = 1.0;
  for (int i = 2; i <= n; ++i) f *= float(i);
  return f;
}
void HshBasis(int order, vec3 dir, out float b[16]) {
  float x = 2.0 * clamp(dir.z, 0.0, 1.0) - 1.0;
  float phi = (dir.x == 0.0 && dir.y == 0.0) ? 0.0 : atan(dir.y, dir.x);  // atan(0, 0) is undefined in GLSL
  for (int l = 0; l < order; ++l)
    for (int m = -l; m <= l; ++m) {
      int am = abs(m);
      float k = sqrt(float(2 * l + 1) * Factorial(l - am) / (2.0 * kPi * Factorial(l + am)));
      float v = k * Legendre(l, am, x);
      if (m > 0) v *= sqrt(2.0) * cos(float(m) * phi);
      if (m < 0) v *= sqrt(2.0) * sin(float(am) * phi);
      b[l * l + l + m] = v;
    }
}

// RbfTableBasis: k planes of a G × G table over (x, y) = (θ / 90°)(cos φ, sin φ), clamped to the
// horizon, bilinear between nodes (node (i, j) at x = −1 + 2i/(G − 1), y = −1 + 2j/(G − 1)).
void RbfTableBasis(highp sampler2DArray table, int G, int k, vec3 l, out float b[16]) {
  float theta = acos(clamp(l.z, -1.0, 1.0));
  float s = length(l.xy);
  float rho = min(1.0, theta / (0.5 * kPi));
  vec2 xy = s > 0.0 ? rho * l.xy / s : vec2(l.z < 0.0 ? 1.0 : 0.0, 0.0);
  vec2 f = (xy + 1.0) * 0.5 * float(G - 1);
  ivec2 i0 = clamp(ivec2(floor(f)), ivec2(0), ivec2(G - 2));
  vec2 t = f - vec2(i0);
  for (int q = 0; q < k; ++q) {
    float t00 = texelFetch(table, ivec3(i0, q), 0).r;
    float t10 = texelFetch(table, ivec3(i0 + ivec2(1, 0), q), 0).r;
    float t01 = texelFetch(table, ivec3(i0 + ivec2(0, 1), q), 0).r;
    float t11 = texelFetch(table, ivec3(i0 + ivec2(1, 1), q), 0).r;
    b[q] = (1.0 - t.y) * ((1.0 - t.x) * t00 + t.x * t10) + t.y * ((1.0 - t.x) * t01 + t.x * t11);
  }
}
