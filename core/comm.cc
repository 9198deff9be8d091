#include "core/comm.h"

namespace matfit {
namespace {

template <typename T>
void Sum(const Comm& comm, T* values, int n) {
  const std::string mine(reinterpret_cast<const char*>(values), size_t(n) * sizeof(T));
  const std::vector<std::string> all = comm.AllGather(mine);
  for (int k = 0; k < n; ++k) values[k] = 0;
  for (const std::string& b : all) {
    for (int k = 0; k < n && size_t(k + 1) * sizeof(T) <= b.size(); ++k) {
      T v;
      std::memcpy(&v, b.data() + size_t(k) * sizeof(T), sizeof v);
      values[k] += v;
    }
  }
}

}  // namespace

void SumAcross(const Comm& comm, double* values, int n) { Sum(comm, values, n); }
void SumAcross(const Comm& comm, int64_t* values, int n) { Sum(comm, values, n); }

bool AllOk(const Comm& comm, bool ok, const std::string& message, std::string* why) {
  const std::vector<std::string> all = comm.AllGather(ok ? std::string() : "!" + message);
  for (const std::string& m : all)
    if (!m.empty()) {
      if (why) *why = m.substr(1);
      return false;
    }
  return true;
}

}  // namespace matfit
