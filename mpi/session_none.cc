// A build without MPI: a process started by a launcher is refused.
#include "mpi/session.h"

namespace matfit::mpi {

std::unique_ptr<Session> JoinIfLaunched(std::string* error) {
  if (LaunchedByMpi())
    *error =
        "this matfit was built without MPI, but an MPI launcher (mpirun/srun) started it: every "
        "rank would fit the whole dataset into the same pack. Install libopenmpi-dev and rebuild "
        "(CMake option MATFIT_WITH_MPI), or run matfit without the launcher";
  return nullptr;
}

}  // namespace matfit::mpi
