// SelectKth: the k-th smallest element of a small array (per-texel medians and rank cut-offs),
// like std::nth_element but with branch-free partitions. Per-texel residuals are random data:
// std::nth_element's comparisons mispredict about half the time, and in lambert-robust the
// selections were half of the fit's time. The value returned is the same as
// std::nth_element's a[k] for any strict weak order `less`; the array is permuted.
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
  for (int i = lo + 1; i < hi; ++i)  // insertion sort of the last few
    for (int j = i; j > lo && less(a[j], a[j - 1]); --j) std::swap(a[j], a[j - 1]);
  return a[k];
}

template <typename T>
T SelectKth(T* a, int n, int k) {
  return SelectKth(a, n, k, [](const T& x, const T& y) { return x < y; });
}

}  // namespace matfit::fit
