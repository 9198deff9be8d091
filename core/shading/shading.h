// CPU shading functions: the single source of truth for every model's forward evaluation.
// The synthetic generator, the fitters and the renderers all call these.
//
// Units: every function returns a reflectance factor R = π · f_r · (n·l)⁺, so a pixel value is
// p = I · R for a light of intensity I, and a white Lambertian surface lit head-on reads 1.
// Vectors are unit, in the tangent frame, pointing away from the surface (METHODS.md §0).
// Templates on the scalar so that autodiff types can differentiate them.
#pragma once

#include <cmath>
#include <type_traits>

#include "core/vec3.h"

namespace matfit::shading {

template <typename T>
inline T Clamp0(const T& x) {
  return x > T(0) ? x : T(0);
}

// Guards, written once for any scalar: on plain and autodiff types a branch, on lanes
// (lanes.h: eight lights at once) a per-lane select, found there by argument-dependent lookup.
template <typename T>
inline bool Positive(const T& x) {
  return x > T(0);
}
// f() where ok, else 0 (f is not called where !ok).
template <typename T, typename F>
inline T ZeroUnless(bool ok, F&& f) {
  return ok ? f() : T(0);
}

// x^e for x > 0. Plain std::pow on floating point; exp(e·ln x) on autodiff types, whose pow of
// two variables costs two scalar pows and a log per call where this costs one exp and one log.
template <typename T>
inline T PowPositive(const T& x, const T& e) {
  if constexpr (std::is_floating_point_v<T>) {
    return std::pow(x, e);
  } else {
    using std::exp;
    using std::log;
    return exp(e * log(x));
  }
}

// Lambert (METHODS.md §3): R = ρ · max(0, n·l).
// The light (and below, view and half) vectors may have a plain scalar type V while the
// parameters are autodiff T: they are constants of a fit.
template <typename T, typename V>
inline T Lambert(const T& albedo, const Vec3T<T>& n, const Vec3T<V>& l) {
  return albedo * Clamp0(Dot(n, l));
}

// Blinn–Phong specular lobe (METHODS.md §4), not energy-normalised, π folded into k_s:
// R_s = k_s · max(0, n·h)^e · max(0, n·l), h = normalize(l + v).
// The same with the half vector h given (fits precompute it: l and v are fixed per sample).
template <typename T, typename V>
inline T BlinnPhongSpecularHalf(const T& ks, const T& exponent, const Vec3T<T>& n,
                                const Vec3T<V>& l, const Vec3T<V>& h) {
  const T nl = Dot(n, l), nh = Dot(n, h);
  return ZeroUnless<T>(Positive(nl) && Positive(nh),
                       [&] { return ks * PowPositive(nh, exponent) * nl; });
}
template <typename T>
inline T BlinnPhongSpecular(const T& ks, const T& exponent, const Vec3T<T>& n, const Vec3T<T>& l,
                            const Vec3T<T>& v) {
  return BlinnPhongSpecularHalf(ks, exponent, n, l, Normalize(l + v));
}

// GGX / Trowbridge–Reitz normal distribution, α = r².
template <typename T>
inline T GgxD(const T& nh, const T& alpha) {
  const T a2 = alpha * alpha;
  const T d = nh * nh * (a2 - T(1)) + T(1);
  return a2 / (T(M_PI) * d * d);
}

// Smith G1 for GGX (separable masking-shadowing).
template <typename T>
inline T GgxG1(const T& nx, const T& alpha) {
  using std::sqrt;
  const T a2 = alpha * alpha;
  return T(2) * nx / (nx + sqrt(a2 + (T(1) - a2) * nx * nx));
}

// Schlick Fresnel: F = F0 + (1 − F0)(1 − v·h)^5; F0 = ((η − 1)/(η + 1))².
template <typename T>
inline T SchlickFresnel(const T& f0, const T& vh) {
  const T m = T(1) - Clamp0(vh);
  const T m2 = m * m;
  return f0 + (T(1) - f0) * m2 * m2 * m;
}
inline double F0FromIor(double eta) { return ((eta - 1) / (eta + 1)) * ((eta - 1) / (eta + 1)); }

// Cook–Torrance specular (METHODS.md §4), GGX D, Smith G, Schlick F:
// R_s = π · D G F / (4 (n·l)(n·v)) · (n·l).
// The same with the half vector h = normalize(l + v) given.
template <typename T, typename V>
inline T CookTorranceSpecularHalf(const T& f0, const T& roughness, const Vec3T<T>& n,
                                  const Vec3T<V>& l, const Vec3T<V>& v, const Vec3T<V>& h) {
  const T nl = Dot(n, l), nv = Dot(n, v);
  return ZeroUnless<T>(Positive(nl) && Positive(nv), [&] {
    const T nh = Clamp0(Dot(n, h));
    const T alpha = roughness * roughness;
    const T dgf =
        GgxD(nh, alpha) * GgxG1(nl, alpha) * GgxG1(nv, alpha) * SchlickFresnel(f0, T(Dot(v, h)));
    return T(M_PI) * dgf / (T(4) * nv);
  });
}
template <typename T>
inline T CookTorranceSpecular(const T& f0, const T& roughness, const Vec3T<T>& n, const Vec3T<T>& l,
                              const Vec3T<T>& v) {
  return CookTorranceSpecularHalf(f0, roughness, n, l, v, Normalize(l + v));
}

// glTF 2.0's dielectric (metallic 0; its Appendix B fresnel_mix with F90 = 1) as real-time
// viewers draw it: the Lambertian base takes what the Fresnel term leaves, and the lobe (the
// Cook–Torrance lobe above) is scaled by the multiple-scattering compensation
// ms = 1 + F0 (1/E − 1), E the lobe's directional albedo at F0 = 1 (Turquin 2019; three.js,
// Filament and Blender's multiscatter GGX): R = (1 − F(v·h)) ρ max(0, n·l) + ms R_s(F0, r).
// ms = 1 is the specification's single-scattering BRDF. The glTF stand-ins fit it.
template <typename T, typename V>
inline T GltfDielectricHalf(const T& rho, const T& f0, const T& roughness, const T& ms,
                            const Vec3T<T>& n, const Vec3T<V>& l, const Vec3T<V>& v,
                            const Vec3T<V>& h) {
  return (T(1) - SchlickFresnel(f0, T(Dot(v, h)))) * Lambert(rho, n, l) +
         ms * CookTorranceSpecularHalf(f0, roughness, n, l, v, h);
}

// Isotropic Lafortune lobe (METHODS.md §4) in the frame of the normal n, with C_z = 1 (the lobe
// amplitude absorbs the overall scale): D = C_xy (l·v − (n·l)(n·v)) + (n·l)(n·v);
// R_s = ρ_s · max(0, D)^e · max(0, n·l). C_xy = −1 is the classic mirror cosine lobe,
// C_xy > 0 retro-reflection, C_xy ≈ 0 an off-specular lobe toward the normal.
template <typename T, typename V>
inline T LafortuneLobe(const T& rho_s, const T& c_xy, const T& exponent, const Vec3T<T>& n,
                       const Vec3T<V>& l, const Vec3T<V>& v) {
  const T nl = Dot(n, l), nv = Dot(n, v);
  return ZeroUnless<T>(Positive(nl) && Positive(nv), [&] {
    const T d = c_xy * (T(Dot(l, v)) - nl * nv) + nl * nv;
    return ZeroUnless<T>(Positive(d), [&] { return rho_s * PowPositive(d, exponent) * nl; });
  });
}

// Seed method A (METHODS.md §2), one channel: diffuse part t·a + t·(n·l) with the fitted,
// unnormalised n and no clamp; specular part L_spec·max(0, n_s·h)^e with n_s the unit normal
// (or (0,0,1) in the improved variant), h = normalize(l + v).
template <typename T>
inline T HeinrichDiffuse(const T& t, const T& ambient, const Vec3T<T>& n_raw, const Vec3T<T>& l) {
  return t * ambient + t * Dot(n_raw, l);
}
template <typename T>
inline T HeinrichSpecular(const T& l_spec, const T& exponent, const Vec3T<T>& n_s,
                          const Vec3T<T>& l, const Vec3T<T>& v) {
  using std::pow;
  const T nh = Clamp0(Dot(n_s, Normalize(l + v)));
  return l_spec * pow(nh, exponent);
}

// Leaf translucency (METHODS.md §5). Half-Life-2 basis H_i (unit vectors) and the functions
// ℋ_i(ω) = √(3/(2π)) H_i·ω (unclamped; orthonormal on the hemisphere).
inline constexpr double kHl2[3][3] = {
    {-0.40824829046386301, -0.70710678118654752, 0.57735026918962576},
    {-0.40824829046386301, 0.70710678118654752, 0.57735026918962576},
    {0.81649658092772603, 0.0, 0.57735026918962576}};
inline constexpr double kHl2Scale = 0.69098829894267105;  // √(3/(2π))
// Diffuse translucency rebuilt from HL2 coefficients h_i: ρ_t Σ_i h_i ℋ_i(ω), ω the light
// direction in the frame of the lit side (z out of the lit surface).
template <typename T>
inline T Hl2Translucency(const T& rho_t, const T& h1, const T& h2, const T& h3, const Vec3T<T>& w) {
  const T hs[3] = {h1, h2, h3};
  T r(0);
  for (int i = 0; i < 3; ++i)
    r += hs[i] * T(kHl2Scale) * (T(kHl2[i][0]) * w.x + T(kHl2[i][1]) * w.y + T(kHl2[i][2]) * w.z);
  return rho_t * Clamp0(r);
}
// The fallback without HL2 coefficients: a diffuse BTDF, ρ_t max(0, ω_z) (what h_i = √(2π)/3
// reconstructs exactly).
template <typename T>
inline T DiffuseTranslucency(const T& rho_t, const Vec3T<T>& w) {
  return rho_t * Clamp0(w.z);
}

}  // namespace matfit::shading
