// Communication between the processes of one distributed computation (MPI ranks; mpi/). Core code
// sees only this interface: a stack split into row bands across ranks (LightStack::band) reduces
// its stack-wide figures through it, and a single process never has one.
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

namespace matfit {

class Comm {
 public:
  virtual ~Comm() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  // Collectives: every rank calls them in the same order.
  // Every rank's bytes, in rank order, on every rank.
  virtual std::vector<std::string> AllGather(const std::string& mine) const = 0;
  // Every rank's bytes, in rank order, on rank `root` (empty elsewhere).
  virtual std::vector<std::string> Gather(const std::string& mine, int root) const = 0;
};

// Sums over the ranks, element by element, added in rank order: every rank gets the same bits.
void SumAcross(const Comm& comm, double* values, int n);
void SumAcross(const Comm& comm, int64_t* values, int n);

// The ranks' vectors one after another, in rank order (on every rank / on root only).
template <typename T>
std::vector<T> ConcatAcross(const Comm& comm, const std::vector<T>& mine, int root = -1) {
  static_assert(std::is_trivially_copyable_v<T>);
  const std::string bytes(reinterpret_cast<const char*>(mine.data()), mine.size() * sizeof(T));
  const std::vector<std::string> all = root < 0 ? comm.AllGather(bytes) : comm.Gather(bytes, root);
  size_t total = 0;
  for (const auto& b : all) total += b.size() / sizeof(T);
  std::vector<T> out(total);
  char* at = reinterpret_cast<char*>(out.data());
  for (const auto& b : all)
    if (!b.empty()) std::memcpy(at, b.data(), b.size()), at += b.size();
  return out;
}

// Whether every rank's `ok` is true, and the first failing rank's message (rank order) in *why.
bool AllOk(const Comm& comm, bool ok, const std::string& message, std::string* why);

}  // namespace matfit
