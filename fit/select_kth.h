// SelectKth: the k-th smallest element of a small array (per-texel medians and rank cut-offs),
// like std::nth_element but with branch-free partitions. Per-texel residuals are random data:
// std::nth_element's comparisons mispredict about half the time, and in lambert-robust the
// selections were half of the fit's time. The value returned is the same as
// std::nth_element's a[k] for any strict weak order `less`; the array is permuted (not left
// partitioned around a[k]).
#pragma once

#include <utility>

namespace matfit::fit {

template <typename T, typename Less>
T SelectKth(T* a, int n, int k, Less less) {
  int lo = 0, hi = n;  // the answer is in a[lo, hi)
  while (hi - lo > 16) {
    // Median-of-three pivot.
    T x = a[lo], y = a[lo + (hi - lo) / 2], z = a[hi - 1];
    if (less(y, x)) std::swap(x, y);
    if (less(z, y)) std::swap(y, z);
    if (less(y, x)) std::swap(x, y);
    const T pivot = y;
    // Lomuto, branch-free: every element is swapped to `store`, which advances past it only
    // when it belongs left: [lo, store) < pivot ≤ [store, hi).
    int store = lo;
    for (int i = lo; i < hi; ++i) {
      const T v = a[i];
      a[i] = a[store], a[store] = v;
      store += less(v, pivot) ? 1 : 0;
    }
    if (k < store) {
      hi = store;
      continue;
    }
    // [store, hi) ≥ pivot: split off the elements equal to the pivot (none less than it, so
    // this always makes progress, even when many are equal).
    int eq = store;
    for (int i = store; i < hi; ++i) {
      const T v = a[i];
      a[i] = a[eq], a[eq] = v;
      eq += less(pivot, v) ? 0 : 1;
    }
    if (k < eq) return a[k];  // equal to the pivot
    lo = eq;
  }
  // The last few by counting, branch-free: the answer is the element with fewer than k − lo
  // elements below it and more than k − lo at or below it.
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

template <typename T>
T SelectKth(T* a, int n, int k) {
  return SelectKth(a, n, k, [](const T& x, const T& y) { return x < y; });
}

}  // namespace matfit::fit
