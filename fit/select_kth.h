// SelectKth: the k-th smallest element of a small array (per-texel medians and rank cut-offs),
// like std::nth_element but with branch-free partitions. Per-texel residuals are random data:
// std::nth_element's comparisons mispredict about half the time, and in lambert-robust the
// selections were half of the fit's time (`fit_bench --benchmark_filter=median_168`, the median
// of 168 random doubles: std::nth_element 1.9 µs, this 0.43 µs). The value returned is the same as
// std::nth_element's a[k] for any strict weak order `less`; the array is permuted (not left
// partitioned around a[k]).
#pragma once

#include <functional>
#include <utility>

namespace matfit::fit {

namespace select_detail {

inline constexpr int kCountBelow = 8;  // ranges this small are finished by counting

template <typename T, typename Less>
T MedianOfThree(const T* a, int lo, int hi, Less less) {
  T x = a[lo], y = a[lo + (hi - lo) / 2], z = a[hi - 1];
  if (less(y, x)) std::swap(x, y);
  if (less(z, y)) std::swap(y, z);
  if (less(y, x)) std::swap(x, y);
  return y;
}

// Lomuto, branch-free: every element of a[lo, hi) is swapped to `store`, which advances past it
// only when it goes left; returns the split: [lo, split) go left, [split, hi) do not.
template <typename T, typename Left>
int Partition(T* a, int lo, int hi, Left left) {
  int store = lo;
  for (int i = lo; i < hi; ++i) {
    const T v = a[i];
    a[i] = a[store], a[store] = v;
    store += left(v) ? 1 : 0;
  }
  return store;
}

// The k-th smallest of a[lo, hi) by counting, branch-free: the element with at most k − lo
// elements below it and more than k − lo at or below it.
template <typename T, typename Less>
T CountKth(const T* a, int lo, int hi, int k, Less less) {
  const int r = k - lo;
  for (int i = lo; i < hi; ++i) {
    int below = 0, at_or_below = 0;
    for (int j = lo; j < hi; ++j) {
      below += less(a[j], a[i]) ? 1 : 0;
      at_or_below += less(a[i], a[j]) ? 0 : 1;
    }
    if (below <= r && r < at_or_below) return a[i];
  }
  return a[k];  // unreachable for a strict weak order
}

}  // namespace select_detail

template <typename T, typename Less>
T SelectKth(T* a, int n, int k, Less less) {
  using namespace select_detail;
  int lo = 0, hi = n;  // the answer is in a[lo, hi)
  while (hi - lo > kCountBelow) {
    const T pivot = MedianOfThree(a, lo, hi, less);
    // [lo, split) < pivot ≤ [split, hi)
    const int split = Partition(a, lo, hi, [&](const T& v) { return less(v, pivot); });
    if (k < split) {
      hi = split;
    } else if (split > lo) {
      lo = split;
    } else {
      // The pivot is the smallest: split off the elements equal to it (this always makes
      // progress, even when many are equal).
      const int eq = Partition(a, lo, hi, [&](const T& v) { return !less(pivot, v); });
      if (k < eq) return pivot;
      lo = eq;
    }
  }
  return CountKth(a, lo, hi, k, less);
}

template <typename T>
T SelectKth(T* a, int n, int k) {
  return SelectKth(a, n, k, [](const T& x, const T& y) { return x < y; });
}

// The k1-th and k2-th smallest (k1 < k2), as two SelectKth calls would return them, sharing the
// partition passes while both ranks fall in the same part (a rank trim's two cut-offs cost about
// one selection and a half instead of two).
template <typename T, typename Less>
void SelectTwo(T* a, int n, int k1, int k2, Less less, T* v1, T* v2) {
  using namespace select_detail;
  int lo = 0, hi = n;  // both answers are in a[lo, hi)
  while (hi - lo > kCountBelow) {
    const T pivot = MedianOfThree(a, lo, hi, less);
    const int split = Partition(a, lo, hi, [&](const T& v) { return less(v, pivot); });
    if (k2 < split) {  // both left
      hi = split;
      continue;
    }
    if (k1 < split) {  // one each side: the parts are disjoint
      *v1 = SelectKth(a + lo, split - lo, k1 - lo, less);
      *v2 = SelectKth(a + split, hi - split, k2 - split, less);
      return;
    }
    if (split > lo) {  // both right
      lo = split;
      continue;
    }
    // The pivot is the smallest: split off the elements equal to it.
    const int eq = Partition(a, lo, hi, [&](const T& v) { return !less(pivot, v); });
    if (k1 >= eq) {
      lo = eq;
      continue;
    }
    *v1 = pivot;
    *v2 = k2 < eq ? pivot : SelectKth(a + eq, hi - eq, k2 - eq, less);
    return;
  }
  *v1 = CountKth(a, lo, hi, k1, less);
  *v2 = CountKth(a, lo, hi, k2, less);
}

// The k-th smallest of n finite doubles: SelectKth(a, n, k)'s value, by vector compressions where
// the CPU has AVX-512 (fit/select_kth.cc; fit_bench median_168: 1.8x SelectKth). `scratch`
// holds SelectScratchSize(n) doubles; a's contents are left unspecified (not a permutation).
double SelectKthFinite(double* a, int n, int k, double* scratch);
inline int SelectScratchSize(int n) { return 3 * (n + 8); }

}  // namespace matfit::fit
