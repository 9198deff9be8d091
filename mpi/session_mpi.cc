// OpenMPI: the world communicator as a matfit::Comm. Collectives run on the main thread only
// (MPI_THREAD_FUNNELED); the fit's worker threads never call MPI.
#include <mpi.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <vector>

#include "mpi/session.h"

namespace matfit::mpi {
namespace {

// Gathers variable-sized byte strings in rounds of at most kRound bytes per rank, so that every
// count and displacement fits MPI's int.
class WorldComm : public Comm {
 public:
  WorldComm() {
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  std::vector<std::string> AllGather(const std::string& mine) const override {
    return Collect(mine, -1);
  }
  std::vector<std::string> Gather(const std::string& mine, int root) const override {
    return Collect(mine, root);
  }

 private:
  std::vector<std::string> Collect(const std::string& mine, int root) const {
    const bool all = root < 0;
    long long my_size = (long long)mine.size();
    std::vector<long long> sizes(static_cast<size_t>(size_), 0);
    MPI_Allgather(&my_size, 1, MPI_LONG_LONG, sizes.data(), 1, MPI_LONG_LONG, MPI_COMM_WORLD);
    const long long round = std::max<long long>(1, (1ll << 30) / size_);
    long long most = 0;
    for (long long s : sizes) most = std::max(most, s);
    const bool keep = all || rank_ == root;
    std::vector<std::string> out(static_cast<size_t>(size_));
    if (keep)
      for (int r = 0; r < size_; ++r) out[size_t(r)].resize(size_t(sizes[size_t(r)]));
    std::vector<int> counts(static_cast<size_t>(size_)), displs(static_cast<size_t>(size_));
    std::vector<char> buffer;
    for (long long at = 0; at < most || (at == 0 && most == 0); at += round) {
      int total = 0;
      for (int r = 0; r < size_; ++r) {
        const long long left = std::max<long long>(0, sizes[size_t(r)] - at);
        counts[size_t(r)] = int(std::min(left, round));
        displs[size_t(r)] = total;
        total += counts[size_t(r)];
      }
      if (keep) buffer.resize(size_t(std::max(total, 1)));
      const int n = counts[size_t(rank_)];
      const char* send = n > 0 ? mine.data() + at : nullptr;
      if (all)
        MPI_Allgatherv(send, n, MPI_BYTE, buffer.data(), counts.data(), displs.data(), MPI_BYTE,
                       MPI_COMM_WORLD);
      else
        MPI_Gatherv(send, n, MPI_BYTE, keep ? buffer.data() : nullptr, counts.data(), displs.data(),
                    MPI_BYTE, root, MPI_COMM_WORLD);
      if (keep)
        for (int r = 0; r < size_; ++r)
          if (counts[size_t(r)] > 0)
            std::copy_n(buffer.data() + displs[size_t(r)], counts[size_t(r)],
                        out[size_t(r)].data() + at);
      if (most == 0) break;
    }
    return out;
  }

  int rank_ = 0, size_ = 1;
};

class MpiSession : public Session {
 public:
  MpiSession() : world_() {}
  ~MpiSession() override { MPI_Finalize(); }
  const Comm& world() const override { return world_; }
  [[noreturn]] void Abort(int code) override {
    MPI_Abort(MPI_COMM_WORLD, code);
    std::abort();
  }

 private:
  WorldComm world_;
};

}  // namespace

std::unique_ptr<Session> JoinIfLaunched(std::string* error) {
  if (!LaunchedByMpi()) return nullptr;
  int provided = 0;
  if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
    *error = "MPI_Init_thread failed: the MPI launcher's environment is broken";
    return nullptr;
  }
  if (provided < MPI_THREAD_FUNNELED) {
    MPI_Finalize();
    *error = "the MPI library does not provide MPI_THREAD_FUNNELED";
    return nullptr;
  }
  // Failures in MPI calls end the job with MPI's own message (the default handler).
  return std::make_unique<MpiSession>();
}

}  // namespace matfit::mpi
