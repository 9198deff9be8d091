// Eight lanes of double for evaluating the shading functions (shading.h) on eight lights at once:
// L8 (plain lanes: the light, half and view vectors), Dual<N> (lanes carrying N forward-mode
// derivatives: the fit's parameters) and Mask (one truth value per lane). The shading functions
// are written once for any scalar; their guards (Positive, ZeroUnless, Clamp0) are a branch on
// the scalar types and a per-lane select here, found by argument-dependent lookup. Exp and Log
// are lane versions of the libm functions (within 2 ulp of them; Exp flushes results below
// e^−708 to 0), so a lane evaluation equals the scalar one to rounding. Every helper is
// always_inline: the AVX-512 and AVX2 clones that use them must not call a baseline copy (whose
// vector arguments would be passed differently). GCC vector extensions:
// a function inlining these into an AVX-512 clone gets 512-bit arithmetic, elsewhere GCC splits
// them into the ISA's widths.
#pragma once

#include <cstdint>

namespace matfit::lanes {

using D8 = double __attribute__((vector_size(64)));
using I8 = int64_t __attribute__((vector_size(64)));

// All bits set in a lane where true.
struct Mask {
  I8 m;
};
[[gnu::always_inline]] inline Mask operator&&(Mask a, Mask b) { return {a.m & b.m}; }
[[gnu::always_inline]] inline Mask operator||(Mask a, Mask b) { return {a.m | b.m}; }
[[gnu::always_inline]] inline Mask operator!(Mask a) { return {~a.m}; }
// By halving the vector (three shuffles and ORs, one extract): GCC 12 extracts every lane of
// the plain loop to a general register.
[[gnu::always_inline]] inline bool Any(Mask a) {
  I8 r = a.m | __builtin_shufflevector(a.m, a.m, 4, 5, 6, 7, 0, 1, 2, 3);
  r |= __builtin_shufflevector(r, r, 2, 3, 0, 1, 6, 7, 4, 5);
  r |= __builtin_shufflevector(r, r, 1, 0, 3, 2, 5, 4, 7, 6);
  return r[0] != 0;
}

struct L8 {
  D8 v;
  L8() : v(D8{}) {}
  L8(double s) : v(D8{} + s) {}  // NOLINT: a constant in every lane (Vec3T's `T x = 0`)
  explicit L8(D8 d) : v(d) {}
  double operator[](int k) const { return v[k]; }
};
[[gnu::always_inline]] inline L8 operator+(L8 a, L8 b) { return L8(a.v + b.v); }
[[gnu::always_inline]] inline L8 operator-(L8 a, L8 b) { return L8(a.v - b.v); }
[[gnu::always_inline]] inline L8 operator*(L8 a, L8 b) { return L8(a.v * b.v); }
[[gnu::always_inline]] inline L8 operator/(L8 a, L8 b) { return L8(a.v / b.v); }
[[gnu::always_inline]] inline L8 operator-(L8 a) { return L8(-a.v); }
[[gnu::always_inline]] inline L8& operator+=(L8& a, L8 b) { return a.v += b.v, a; }
[[gnu::always_inline]] inline Mask operator>(L8 a, L8 b) { return {a.v > b.v}; }
[[gnu::always_inline]] inline Mask operator<(L8 a, L8 b) { return {a.v < b.v}; }
[[gnu::always_inline]] inline L8 Select(Mask m, L8 a, L8 b) { return L8(m.m ? a.v : b.v); }
[[gnu::always_inline]] inline L8 Load(const double* p) {
  L8 r;
  __builtin_memcpy(&r.v, p, sizeof(D8));
  return r;
}
[[gnu::always_inline]] inline double Sum(L8 a) {  // lanes in order
  double s = 0;
  for (int k = 0; k < 8; ++k) s += a.v[k];
  return s;
}

[[gnu::always_inline]] inline L8 Sqrt(L8 x) {
  L8 r;
  for (int k = 0; k < 8; ++k) r.v[k] = __builtin_sqrt(x.v[k]);
  return r;
}

// e^x = 2^k e^r with k = round(x / ln 2), r = x − k ln 2 (ln 2 in two parts, |r| ≤ 0.347), e^r
// by its Taylor polynomial to r¹³ (truncation < 5e-18). x > 709.78: +inf; x < −708: 0 (libm
// gives values below 3.3e-308 there, the last normal ones down to −708.4, then subnormals; the
// 2^(k−1) scaling below needs k ≥ −1021); NaN: NaN.
[[gnu::always_inline]] inline L8 Exp(L8 x) {
  const D8 big = D8{} + 0x1.8p52;  // adding and subtracting it rounds to an integer
  // NaN lanes go through as 0 (their result is NaN, set below): no NaN reaches the conversion.
  const D8 xc = x.v < -708.0 ? D8{} - 708.0 : (x.v > 709.8 ? D8{} + 709.8 : x.v);
  const D8 xr = x.v != x.v ? D8{} : xc;
  const D8 kd = (xr * 1.4426950408889634 + big) - big;
  const D8 r = (xr - kd * 6.93147180369123816490e-01) - kd * 1.90821492927058770002e-10;
  constexpr double c[14] = {1.0,
                            1.0,
                            1.0 / 2,
                            1.0 / 6,
                            1.0 / 24,
                            1.0 / 120,
                            1.0 / 720,
                            1.0 / 5040,
                            1.0 / 40320,
                            1.0 / 362880,
                            1.0 / 3628800,
                            1.0 / 39916800,
                            1.0 / 479001600,
                            1.0 / 6227020800.0};
  // The terms from r³ on by Estrin's scheme (pairs, then quads, then octets in r², r⁴, r⁸),
  // the last three by Horner's, whose final steps keep the result as accurate as Horner's
  // alone: a dependency chain of 12 operations from r instead of Horner's 26.
  const D8 r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
  D8 q[6];  // c₃ + c₄ r, c₅ + c₆ r, …, c₁₃ (pair j: c_{2j+3} + c_{2j+4} r)
  for (int j = 0; j < 5; ++j) q[j] = c[2 * j + 3] + c[2 * j + 4] * r;
  q[5] = D8{} + c[13];
  const D8 q01 = q[0] + q[1] * r2, q23 = q[2] + q[3] * r2, q45 = q[4] + q[5] * r2;
  const D8 t = (q01 + q23 * r4) + q45 * r8;  // Σ_{j≥3} c_j r^(j−3)
  const D8 p = ((t * r + c[2]) * r + c[1]) * r + c[0];
  // 2^(k−1) · 2p: −1021 ≤ k ≤ 1024 keeps 2^(k−1)'s exponent field normal.
  const I8 k = __builtin_convertvector(kd, I8) - 1;
  const D8 scale = (D8)((k + 1023) << 52);
  D8 e = (p + p) * scale;
  e = x.v > 709.782712893384 ? D8{} + __builtin_inf() : e;
  e = x.v < -708.0 ? D8{} : e;
  e = x.v != x.v ? x.v : e;
  return L8(e);
}

// ln x = e ln 2 + ln(1 + f), x = 2^e (1 + f) with 1 + f in [√½, √2); ln(1 + f) = 2 atanh(s),
// s = f / (2 + f), in fdlibm's form (its polynomial in s²). x = 0: −inf; x < 0 or NaN: NaN;
// +inf: +inf; subnormals scaled by 2^54 first.
[[gnu::always_inline]] inline L8 Log(L8 x) {
  const I8 sub = x.v < 0x1p-1022;
  const D8 xs = sub ? x.v * 0x1p54 : x.v;
  const I8 bits = (I8)xs;
  I8 e = ((bits >> 52) & 0x7ff) - 1023 - (sub & 54);
  D8 m = (D8)((bits & 0x000fffffffffffffLL) | 0x3ff0000000000000LL);
  const I8 high = m > 1.4142135623730951;
  m = high ? m * 0.5 : m;
  e -= high;  // high is −1 where true
  const D8 f = m - 1.0;
  const D8 s = f / (2.0 + f), z = s * s, w = z * z;
  // fdlibm's two polynomials in w, the longer by Estrin's scheme (pairs in w, then w²): a
  // shorter chain than Horner's, the same terms.
  const D8 w2 = w * w;
  const D8 t1 = w * (3.999999999940941908e-01 +
                     w * (2.222219843214978396e-01 + w * 1.531383769920937332e-01));
  const D8 t2 = z * ((6.666666666666735130e-01 + w * 2.857142874366239149e-01) +
                     w2 * (1.818357216161805012e-01 + w * 1.479819860511658591e-01));
  const D8 R = t2 + t1, hfsq = 0.5 * f * f;
  const D8 ed = __builtin_convertvector(e, D8);
  D8 l = ed * 6.93147180369123816490e-01 -
         ((hfsq - (s * (hfsq + R) + ed * 1.90821492927058770002e-10)) - f);
  l = x.v == __builtin_inf() ? x.v : l;
  l = x.v == 0.0 ? D8{} - __builtin_inf() : l;
  l = (x.v < 0.0) | (x.v != x.v) ? D8{} + __builtin_nan("") : l;
  return L8(l);
}

// Eight lanes of a value and its derivatives in N variables.
template <int N>
struct Dual {
  L8 a, v[N];
  Dual() = default;
  explicit Dual(double s) : a(s) {}
  explicit Dual(L8 s) : a(s) {}
};

template <int N>
[[gnu::always_inline]] inline Dual<N> operator+(const Dual<N>& x, const Dual<N>& y) {
  Dual<N> r(x.a + y.a);
  for (int k = 0; k < N; ++k) r.v[k] = x.v[k] + y.v[k];
  return r;
}
template <int N>
[[gnu::always_inline]] inline Dual<N>& operator+=(Dual<N>& x, const Dual<N>& y) {
  return x = x + y;
}
template <int N>
[[gnu::always_inline]] inline Dual<N> operator-(const Dual<N>& x, const Dual<N>& y) {
  Dual<N> r(x.a - y.a);
  for (int k = 0; k < N; ++k) r.v[k] = x.v[k] - y.v[k];
  return r;
}
template <int N>
[[gnu::always_inline]] inline Dual<N> operator-(const Dual<N>& x) {
  Dual<N> r(-x.a);
  for (int k = 0; k < N; ++k) r.v[k] = -x.v[k];
  return r;
}
template <int N>
[[gnu::always_inline]] inline Dual<N> operator*(const Dual<N>& x, const Dual<N>& y) {
  Dual<N> r(x.a * y.a);
  for (int k = 0; k < N; ++k) r.v[k] = x.a * y.v[k] + x.v[k] * y.a;
  return r;
}
template <int N>
[[gnu::always_inline]] inline Dual<N> operator*(const Dual<N>& x, L8 s) {
  Dual<N> r(x.a * s);
  for (int k = 0; k < N; ++k) r.v[k] = x.v[k] * s;
  return r;
}
template <int N>
[[gnu::always_inline]] inline Dual<N> operator*(L8 s, const Dual<N>& x) {
  return x * s;
}
template <int N>
[[gnu::always_inline]] inline Dual<N> operator/(const Dual<N>& x, const Dual<N>& y) {
  const L8 inv = L8(1.0) / y.a, q = x.a * inv;
  Dual<N> r(q);
  for (int k = 0; k < N; ++k) r.v[k] = (x.v[k] - q * y.v[k]) * inv;
  return r;
}
template <int N>
[[gnu::always_inline]] inline Mask operator>(const Dual<N>& x, const Dual<N>& y) {
  return x.a > y.a;
}
template <int N>
[[gnu::always_inline]] inline Dual<N> Select(Mask m, const Dual<N>& x, const Dual<N>& y) {
  Dual<N> r(Select(m, x.a, y.a));
  for (int k = 0; k < N; ++k) r.v[k] = Select(m, x.v[k], y.v[k]);
  return r;
}
template <int N>
[[gnu::always_inline]] inline Dual<N> exp(const Dual<N>& x) {
  const L8 e = Exp(x.a);
  Dual<N> r(e);
  for (int k = 0; k < N; ++k) r.v[k] = e * x.v[k];
  return r;
}
template <int N>
[[gnu::always_inline]] inline Dual<N> log(const Dual<N>& x) {
  const L8 inv = L8(1.0) / x.a;
  Dual<N> r(Log(x.a));
  for (int k = 0; k < N; ++k) r.v[k] = x.v[k] * inv;
  return r;
}
template <int N>
[[gnu::always_inline]] inline Dual<N> sqrt(const Dual<N>& x) {
  const L8 s = Sqrt(x.a), h = L8(0.5) / s;
  Dual<N> r(s);
  for (int k = 0; k < N; ++k) r.v[k] = x.v[k] * h;
  return r;
}

// The shading functions' guards (shading.h) on lanes.
template <int N>
[[gnu::always_inline]] inline Mask Positive(const Dual<N>& x) {
  return x.a > L8(0.0);
}
template <int N>
[[gnu::always_inline]] inline Dual<N> Clamp0(const Dual<N>& x) {
  return Select(Positive(x), x, Dual<N>(0.0));
}
// f() in every lane, 0 where !ok (f may give NaN or Inf there: the select drops it).
template <typename T, typename F>
[[gnu::always_inline]] inline T ZeroUnless(Mask ok, F&& f) {
  return Select(ok, f(), T(0.0));
}

}  // namespace matfit::lanes
