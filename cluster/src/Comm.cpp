#include <tellus/cluster/Comm.hpp>

#include <cstdlib>
#include <mpi.h>

namespace tellus::cluster {

std::expected<std::unique_ptr<Comm>, std::string> Comm::init() {
  int initialised = 0;
  MPI_Initialized(&initialised);
  if (initialised != 0) return std::unexpected(std::string("MPI is already initialised"));
  if (MPI_Init(nullptr, nullptr) != MPI_SUCCESS)
    return std::unexpected(std::string("MPI_Init failed (started by mpirun?)"));
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  return std::unique_ptr<Comm>(new Comm(rank, size));
}

Comm::~Comm() {
  MPI_Finalize();
}

void Comm::broadcast(FrameState& state) {
  MPI_Bcast(&state, static_cast<int>(sizeof state), MPI_BYTE, 0, MPI_COMM_WORLD);
}

bool Comm::allWell(bool well) {
  int in = well ? 1 : 0, out = 0;
  MPI_Allreduce(&in, &out, 1, MPI_INT, MPI_LAND, MPI_COMM_WORLD);
  return out != 0;
}

void Comm::minMax(double value, double& min, double& max) {
  MPI_Allreduce(&value, &min, 1, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
  MPI_Allreduce(&value, &max, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
}

void Comm::abort(int code) {
  MPI_Abort(MPI_COMM_WORLD, code);
  std::abort();
}

} // namespace tellus::cluster
