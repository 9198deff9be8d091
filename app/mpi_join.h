// The MPI job that `matfit fit` and `matfit leaf` join when mpirun/srun started them
// (mpi/session.h, docs/scale-out.md): rank 0 prints; the other ranks stay quiet.
#pragma once

#include <memory>
#include <string>

#include "core/comm.h"
#include "mpi/session.h"

namespace matfit::app {

struct MpiJoin {
  std::unique_ptr<mpi::Session> session;  // leaves the job (MPI_Finalize) when destroyed
  const Comm* world = nullptr;            // null: one process
  bool root = true;                       // rank 0, or the only process
  std::string error;                      // set: this build cannot join the launcher's job
  int ranks() const { return world ? world->size() : 1; }
};

inline MpiJoin JoinMpi() {
  MpiJoin j;
  j.session = mpi::JoinIfLaunched(&j.error);
  if (j.session) j.world = &j.session->world(), j.root = j.world->rank() == 0;
  return j;
}

}  // namespace matfit::app
