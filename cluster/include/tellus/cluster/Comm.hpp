#pragma once
/**
 * @file Comm.hpp
 * @brief The cluster's communicator (issue 28): one process per rank, started by Open MPI's
 * `mpirun -n K`; rank 0 the master, the others one channel each. The state of a frame goes out by
 * MPI_Bcast; the frame lock is a collective that no rank leaves before every rank has entered
 * (MPI_Allreduce of "this rank is well": the barrier before the swap, which also tells every
 * rank when one failed, so that none waits for it for ever). No MPI type in this header (MPI is
 * PRIVATE to tellus::cluster). One Comm per process; its thread only.
 *
 * The live cluster (a channel may die and come back: docs/design/cluster.md) talks point to point
 * with deadlines instead: the master posts each frame's state to every channel it still has
 * (`post`), collects their answers until a deadline (`collect`: a channel that did not answer is
 * lost), then tells those that answered to swap (`postGo`). A channel killed under
 * `mpirun --enable-recovery` leaves the others running (every call returns, MPI_ERRORS_RETURN). A
 * restarted channel joins as its own mpirun job through the master's port (MPI_Open_port,
 * MPI_Comm_accept / MPI_Comm_connect, the port's name in a file; both jobs started with
 * `--ompi-server`). A peer is a number: 1 .. size-1 the world's ranks, then the channels joined.
 */

#include <tellus/cluster/FrameState.hpp>

#include <cstdint>
#include <expected>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace tellus::cluster {

class Comm {
public:
  /** MPI_Init (once a process): fails with a message when MPI cannot start. */
  static std::expected<std::unique_ptr<Comm>, std::string> init();
  ~Comm(); ///< MPI_Finalize (the port closed, joined peers disconnected)
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

  /** At the end, exit without MPI_Finalize: in Open MPI 4.1 it waits for every rank of the job,
   * a dead one too, for ever (the process ends; mpirun --enable-recovery reports it). */
  void skipFinalize() noexcept { finalize_ = false; }

  // --- the master's side of the live cluster ---
  /** Sends the state to a peer without waiting (a lost peer's send fails quietly). */
  void post(int peer, const FrameState& state);
  /** Tells a peer that answered whether to swap (true) or stop (false); without waiting. A stop
   * with ranksLost: a rank of the job died, so the peer must not finalize MPI (skipFinalize). */
  void postGo(int peer, bool swap, bool ranksLost = false);
  /** Every peer's answer to the state last posted, waited for until timeoutS: 1 well, 0 not
   * well, -1 none in time (the peer is then lost: its pending receive is cancelled). */
  std::vector<int> collect(const std::vector<int>& peers, double timeoutS);
  /** Opens a port for channels to rejoin and writes its name into file (+ file.join: below). */
  std::expected<void, std::string> openPort(const std::filesystem::path& file);
  /** A channel waiting to join (its name in the port's file.join, then MPI_Comm_connect) is
   * accepted: its peer and name; nullopt when none waits. Blocks while the join completes. */
  std::optional<std::pair<int, std::string>> acceptJoin();
  /** Forgets a lost peer (its communicator freed when it had joined through the port). */
  void forget(int peer);

  // --- a channel's side ---
  /** MPI_Init, then joins the master behind the port named in portFile as channel `name`: the
   * master is then peer 0 of this Comm. */
  static std::expected<std::unique_ptr<Comm>, std::string>
  join(const std::filesystem::path& portFile, const std::string& name, double timeoutS);
  /** The master's next state, nullopt when none came in timeoutS. */
  std::optional<FrameState> receiveState(double timeoutS);
  /** The answer to the state drawn: whether this channel is well. */
  void answer(bool well);
  /** The master's go: true swap, false stop; nullopt when none came in timeoutS. A stop that
   * says a rank of the master's job died calls skipFinalize() here (not in a channel joined
   * through the port: its own job lost none), so that the exit does not wait in MPI_Finalize
   * for the dead rank. */
  std::optional<bool> receiveGo(double timeoutS);

private:
  struct Peers; ///< the communicators of the peers (MPI's types stay in Comm.cpp)
  Comm(int rank, int size);
  int rank_ = 0;
  int size_ = 1;
  std::unique_ptr<Peers> peers_;
  std::string port_;
  bool finalize_ = true;
  std::filesystem::path portFile_;
};

} // namespace tellus::cluster
