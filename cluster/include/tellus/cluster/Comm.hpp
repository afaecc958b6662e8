#pragma once
/**
 * @file Comm.hpp
 * @brief The cluster's communicator (issue 28): one process per rank, started by Open MPI's
 * `mpirun -n K`; rank 0 the master, the others one channel each. The state of a frame goes out by
 * MPI_Bcast; the frame lock is a collective that no rank leaves before every rank has entered
 * (MPI_Allreduce of "this rank is well": the barrier before the swap, which also tells every
 * rank when one failed, so that none waits for it for ever). No MPI type in this header (MPI is
 * PRIVATE to tellus::cluster). One Comm per process; its thread only.
 */

#include <tellus/cluster/FrameState.hpp>

#include <expected>
#include <memory>
#include <string>

namespace tellus::cluster {

class Comm {
public:
  /** MPI_Init (once a process): fails with a message when MPI cannot start. */
  static std::expected<std::unique_ptr<Comm>, std::string> init();
  ~Comm(); ///< MPI_Finalize
  Comm(const Comm&) = delete;
  Comm& operator=(const Comm&) = delete;

  int rank() const noexcept { return rank_; }
  int size() const noexcept { return size_; }
  /** Rank 0's state to every rank (a collective: every rank calls it). */
  void broadcast(FrameState& state);
  /** The barrier: returns once every rank has called it, with whether every rank passed true. */
  bool allWell(bool well);
  /** The smallest and largest of a value over the ranks (a collective; benchmarks, checks). */
  void minMax(double value, double& min, double& max);
  /** MPI_Abort: ends every rank (a rank that cannot go on and cannot tell the others). */
  [[noreturn]] void abort(int code);

private:
  Comm(int rank, int size) : rank_(rank), size_(size) {}
  int rank_ = 0;
  int size_ = 1;
};

} // namespace tellus::cluster
