// The MPI job a process was started in (mpirun, or srun with PMI/PMIx): `matfit fit` joins it and
// fits one band of rows per rank (docs/scale-out.md). Built with OpenMPI when MATFIT_WITH_MPI
// finds it; without it a process started by a launcher is refused (every rank would fit the
// whole dataset into the same pack).
#pragma once

#include <memory>
#include <string>

#include "core/comm.h"

namespace matfit::mpi {

class Session {
 public:
  virtual ~Session() = default;  // leaves the job (MPI_Finalize)
  virtual const Comm& world() const = 0;
  // Ends every rank of the job (MPI_Abort): for a failure the other ranks cannot learn of.
  [[noreturn]] virtual void Abort(int code) = 0;
};

// Whether an MPI launcher started this process (its environment says so).
bool LaunchedByMpi();

// Joins the job when LaunchedByMpi(): the session, or nullptr with *error set when this build has
// no MPI. nullptr with *error empty when the process was not launched by MPI.
std::unique_ptr<Session> JoinIfLaunched(std::string* error);

}  // namespace matfit::mpi
