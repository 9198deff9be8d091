// Gauss–Jordan elimination with partial pivoting on small dense systems: the seed's solver, used
// by the literal per-texel reference fits. Sizes are template parameters so each reference gets
// fully unrolled loops (a fair baseline, not a deliberately slow one).
#pragma once

#include <cmath>
#include <utility>

namespace matfit::fit {

// Reduces the K × K row-major a to the identity, applying the same row operations to the R
// columns of rhs (K × R); false when a pivot's magnitude is ≤ 1e-12.
template <int K, int R>
bool GaussJordanEliminate(double* a, double* rhs) {
  for (int col = 0; col < K; ++col) {
    int piv = col;
    for (int i = col + 1; i < K; ++i)
      if (std::abs(a[i * K + col]) > std::abs(a[piv * K + col])) piv = i;
    if (!(std::abs(a[piv * K + col]) > 1e-12)) return false;
    if (piv != col) {
      for (int j = 0; j < K; ++j) std::swap(a[col * K + j], a[piv * K + j]);
      for (int j = 0; j < R; ++j) std::swap(rhs[col * R + j], rhs[piv * R + j]);
    }
    const double d = 1.0 / a[col * K + col];
    for (int j = 0; j < K; ++j) a[col * K + j] *= d;
    for (int j = 0; j < R; ++j) rhs[col * R + j] *= d;
    for (int i = 0; i < K; ++i) {
      if (i == col) continue;
      const double f = a[i * K + col];
      if (f == 0) continue;
      for (int j = 0; j < K; ++j) a[i * K + j] -= f * a[col * K + j];
      for (int j = 0; j < R; ++j) rhs[i * R + j] -= f * rhs[col * R + j];
    }
  }
  return true;
}

// Inverts the K × K row-major a in place.
template <int K>
bool GaussJordanInvert(double* a) {
  double inv[K * K] = {};
  for (int i = 0; i < K; ++i) inv[i * K + i] = 1;
  if (!GaussJordanEliminate<K, K>(a, inv)) return false;
  for (int i = 0; i < K * K; ++i) a[i] = inv[i];
  return true;
}

// Solves a x = b in place (b becomes x; a is destroyed).
template <int K>
bool GaussJordanSolve(double* a, double* b) {
  return GaussJordanEliminate<K, 1>(a, b);
}

}  // namespace matfit::fit
