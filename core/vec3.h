// Minimal 3-vector used by shading, light sets and readers (double precision by default).
#pragma once

#include <cmath>

namespace matfit {

template <typename T>
struct Vec3T {
  T x = 0, y = 0, z = 0;
  constexpr Vec3T() = default;
  constexpr Vec3T(T x_, T y_, T z_) : x(x_), y(y_), z(z_) {}
  template <typename U>
  constexpr explicit Vec3T(const Vec3T<U>& o) : x(T(o.x)), y(T(o.y)), z(T(o.z)) {}
  constexpr T operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr Vec3T operator+(const Vec3T& o) const { return {x + o.x, y + o.y, z + o.z}; }
  constexpr Vec3T operator-(const Vec3T& o) const { return {x - o.x, y - o.y, z - o.z}; }
  constexpr Vec3T operator-() const { return {-x, -y, -z}; }
  constexpr Vec3T operator*(T s) const { return {x * s, y * s, z * s}; }
  constexpr Vec3T operator/(T s) const { return {x / s, y / s, z / s}; }
  constexpr Vec3T& operator+=(const Vec3T& o) {
    x += o.x;
    y += o.y;
    z += o.z;
    return *this;
  }
  constexpr bool operator==(const Vec3T& o) const = default;
};

using Vec3 = Vec3T<double>;
using Vec3f = Vec3T<float>;

// Mixed scalar types are allowed (an autodiff vector against a constant one: the constant's
// components stay plain numbers, which halves the derivative arithmetic).
template <typename T, typename U>
constexpr auto Dot(const Vec3T<T>& a, const Vec3T<U>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <typename T>
constexpr Vec3T<T> Cross(const Vec3T<T>& a, const Vec3T<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <typename T>
inline T Length(const Vec3T<T>& a) {
  using std::sqrt;  // ADL: also works for autodiff scalar types
  return sqrt(Dot(a, a));
}
// Unit vector along a; a zero vector stays zero.
template <typename T>
inline Vec3T<T> Normalize(const Vec3T<T>& a) {
  const T len = Length(a);
  return len > T(0) ? a / len : a;
}
template <typename T>
inline bool IsFinite(const Vec3T<T>& a) {
  return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
}

// METHODS.md §0: (sinθ cosφ, sinθ sinφ, cosθ), θ polar from z, φ azimuth from x, in degrees.
Vec3 DirectionFromAnglesDeg(double theta_deg, double phi_deg);
// Inverse of the above: θ in [0, 180], φ in [0, 360).
void AnglesDegFromDirection(const Vec3& d, double* theta_deg, double* phi_deg);
// Angle between two directions in degrees (inputs need not be unit).
double AngleBetweenDeg(const Vec3& a, const Vec3& b);

}  // namespace matfit
