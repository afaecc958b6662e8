#include <tellus/cluster/Comm.hpp>

#include <chrono>
#include <cstdlib>
#include <deque>
#include <fstream>
#include <mpi.h>
#include <thread>
#include <unistd.h>

namespace tellus::cluster {
namespace {

constexpr int kTagState = 1;
constexpr int kTagAnswer = 2;
constexpr int kTagGo = 3;

using Clock = std::chrono::steady_clock;

/** Polls the requests until each is done or timeoutS passed; done[i] tells which finished. The
 * poll spins a little, then sleeps 50 us between rounds (the machine's cores are the channels'). */
void pollUntil(std::vector<MPI_Request>& requests, std::vector<char>& done, double timeoutS) {
  const auto end = Clock::now() + std::chrono::duration<double>(timeoutS);
  for (int round = 0;; ++round) {
    bool all = true;
    for (std::size_t i = 0; i < requests.size(); ++i) {
      if (done[i] != 0) continue;
      int flag = 0;
      if (MPI_Test(&requests[i], &flag, MPI_STATUS_IGNORE) != MPI_SUCCESS) flag = 0;
      done[i] = flag != 0 ? 1 : 0;
      all = all && flag != 0;
    }
    if (all || Clock::now() >= end) return;
    if (round > 200) std::this_thread::sleep_for(std::chrono::microseconds(50));
  }
}

/** One receive with a deadline; false (and the receive cancelled) when nothing came. */
bool receiveWithin(void* buffer, int bytes, MPI_Comm comm, int source, int tag, double timeoutS) {
  std::vector<MPI_Request> request(1);
  if (MPI_Irecv(buffer, bytes, MPI_BYTE, source, tag, comm, request.data()) != MPI_SUCCESS)
    return false;
  std::vector<char> done(1, 0);
  pollUntil(request, done, timeoutS);
  if (done[0] != 0) return true;
  MPI_Cancel(request.data());
  MPI_Request_free(request.data());
  return false;
}

/** Completes a send before its buffer is written again (within 1 s: a peer that takes none is
 * lost anyway, the send then cancelled). */
void complete(MPI_Request& pending) {
  if (pending == MPI_REQUEST_NULL) return;
  std::vector<MPI_Request> before{pending};
  std::vector<char> done(1, 0);
  pollUntil(before, done, 1.0);
  if (done[0] == 0) {
    MPI_Cancel(before.data());
    MPI_Request_free(before.data());
  }
  pending = MPI_REQUEST_NULL;
}

void sendWithout(const void* data, int bytes, MPI_Comm comm, int dest, int tag, MPI_Request& r) {
  if (MPI_Isend(data, bytes, MPI_BYTE, dest, tag, comm, &r) != MPI_SUCCESS) r = MPI_REQUEST_NULL;
}

} // namespace

struct Comm::Peers {
  struct Link {
    MPI_Comm comm = MPI_COMM_NULL;
    int rank = 0;
    bool joined = false; ///< an intercommunicator of MPI_Comm_accept / MPI_Comm_connect
    bool live = true;
    FrameState sent; ///< the buffer of the last state posted (MPI_Isend keeps reading it)
    int go = 0;      ///< the buffer of the last go posted
    int answer = 0;  ///< the buffer of the answer
    MPI_Request sending = MPI_REQUEST_NULL; ///< the state's send (one at a time)
    MPI_Request going = MPI_REQUEST_NULL;   ///< the go's send
  };
  std::deque<Link> links; ///< by peer (a deque: a join adds one, the others' buffers stay put)
};

Comm::Comm(int rank, int size) : rank_(rank), size_(size), peers_(std::make_unique<Peers>()) {
  peers_->links.resize(static_cast<std::size_t>(size));
  for (int i = 0; i < size; ++i) {
    peers_->links[static_cast<std::size_t>(i)].comm = MPI_COMM_WORLD;
    peers_->links[static_cast<std::size_t>(i)].rank = i;
  }
}

std::expected<std::unique_ptr<Comm>, std::string> Comm::init() {
  int initialised = 0;
  MPI_Initialized(&initialised);
  if (initialised != 0) return std::unexpected(std::string("MPI is already initialised"));
  if (MPI_Init(nullptr, nullptr) != MPI_SUCCESS)
    return std::unexpected(std::string("MPI_Init failed (started by mpirun?)"));
  // A rank that dies (under mpirun --enable-recovery) makes calls fail, not end this process.
  MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
  MPI_Comm_set_errhandler(MPI_COMM_SELF, MPI_ERRORS_RETURN);
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  return std::unique_ptr<Comm>(new Comm(rank, size));
}

Comm::~Comm() {
  for (Peers::Link& l : peers_->links)
    if (l.live) { // the last state (the end of the show) delivered
      complete(l.sending);
      complete(l.going);
    }
  for (Peers::Link& l : peers_->links)
    if (l.joined && l.comm != MPI_COMM_NULL) {
      if (l.live)
        MPI_Comm_disconnect(&l.comm);
      else
        MPI_Comm_free(&l.comm);
    }
  if (!port_.empty()) {
    MPI_Close_port(port_.data());
    std::error_code ec;
    std::filesystem::remove(portFile_, ec);
  }
  if (finalize_) MPI_Finalize();
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

void Comm::post(int peer, const FrameState& state) {
  Peers::Link& l = peers_->links.at(static_cast<std::size_t>(peer));
  complete(l.sending);
  l.sent = state;
  sendWithout(&l.sent, static_cast<int>(sizeof l.sent), l.comm, l.rank, kTagState, l.sending);
}

// The go's values: stop, swap, stop when a rank of the job died (no MPI_Finalize).
constexpr int kGoStop = 0;
constexpr int kGoSwap = 1;
constexpr int kGoStopRanksLost = 2;

void Comm::postGo(int peer, bool swap, bool ranksLost) {
  Peers::Link& l = peers_->links.at(static_cast<std::size_t>(peer));
  complete(l.going);
  l.go = swap ? kGoSwap : ranksLost ? kGoStopRanksLost : kGoStop;
  sendWithout(&l.go, static_cast<int>(sizeof l.go), l.comm, l.rank, kTagGo, l.going);
}

std::vector<int> Comm::collect(const std::vector<int>& peers, double timeoutS) {
  std::vector<MPI_Request> requests(peers.size(), MPI_REQUEST_NULL);
  std::vector<char> done(peers.size(), 0);
  for (std::size_t i = 0; i < peers.size(); ++i) {
    Peers::Link& l = peers_->links.at(static_cast<std::size_t>(peers[i]));
    if (MPI_Irecv(&l.answer, 1, MPI_INT, l.rank, kTagAnswer, l.comm, &requests[i]) != MPI_SUCCESS)
      done[i] = 2; // no receive: no answer
  }
  pollUntil(requests, done, timeoutS);
  std::vector<int> answers(peers.size(), -1);
  for (std::size_t i = 0; i < peers.size(); ++i) {
    if (done[i] == 1) {
      answers[i] = peers_->links[static_cast<std::size_t>(peers[i])].answer != 0 ? 1 : 0;
    } else if (done[i] == 0) {
      MPI_Cancel(&requests[i]);
      MPI_Request_free(&requests[i]);
    }
  }
  return answers;
}

std::expected<void, std::string> Comm::openPort(const std::filesystem::path& file) {
  char name[MPI_MAX_PORT_NAME] = {};
  if (MPI_Open_port(MPI_INFO_NULL, name) != MPI_SUCCESS)
    return std::unexpected(std::string("MPI_Open_port failed"));
  port_ = name;
  portFile_ = file;
  std::error_code ec;
  std::filesystem::remove(file.string() + ".join", ec);
  const std::filesystem::path tmp = file.string() + ".tmp";
  {
    std::ofstream f(tmp);
    f << port_ << '\n';
    if (!f) return std::unexpected(tmp.string() + ": cannot write the port's name");
  }
  std::filesystem::rename(tmp, file, ec);
  if (ec) return std::unexpected(file.string() + ": " + ec.message());
  return {};
}

std::optional<std::pair<int, std::string>> Comm::acceptJoin() {
  if (port_.empty()) return std::nullopt;
  const std::filesystem::path request = portFile_.string() + ".join";
  std::string name;
  {
    std::ifstream f(request);
    if (!f || !std::getline(f, name) || name.empty()) return std::nullopt;
  }
  std::error_code ec;
  std::filesystem::remove(request, ec);
  MPI_Comm inter = MPI_COMM_NULL;
  if (MPI_Comm_accept(port_.data(), MPI_INFO_NULL, 0, MPI_COMM_SELF, &inter) != MPI_SUCCESS)
    return std::nullopt;
  MPI_Comm_set_errhandler(inter, MPI_ERRORS_RETURN);
  Peers::Link l;
  l.comm = inter;
  l.rank = 0;
  l.joined = true;
  peers_->links.push_back(l);
  return std::pair{static_cast<int>(peers_->links.size()) - 1, name};
}

void Comm::forget(int peer) {
  Peers::Link& l = peers_->links.at(static_cast<std::size_t>(peer));
  l.live = false;
  for (MPI_Request* r : {&l.sending, &l.going})
    if (*r != MPI_REQUEST_NULL) MPI_Request_free(r); // a dead peer's sends never complete
}

std::expected<std::unique_ptr<Comm>, std::string>
Comm::join(const std::filesystem::path& portFile, const std::string& name, double timeoutS) {
  auto comm = init();
  if (!comm) return comm;
  std::string port;
  {
    std::ifstream f(portFile);
    if (!f || !std::getline(f, port) || port.empty())
      return std::unexpected(portFile.string() + ": no port's name (is the master running "
                                                 "with --port?)");
  }
  // The request: the name in PORTFILE.join, made whole (a link fails while another waits).
  const std::string request = portFile.string() + ".join";
  const std::string tmp = request + "." + std::to_string(::getpid());
  {
    std::ofstream f(tmp);
    f << name << '\n';
    if (!f) return std::unexpected(tmp + ": cannot write the join request");
  }
  const auto end = Clock::now() + std::chrono::duration<double>(timeoutS);
  while (::link(tmp.c_str(), request.c_str()) != 0) {
    if (Clock::now() >= end) {
      std::filesystem::remove(tmp);
      return std::unexpected(request + ": another channel's join request stays unanswered");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::filesystem::remove(tmp);
  MPI_Comm inter = MPI_COMM_NULL;
  if (MPI_Comm_connect(port.data(), MPI_INFO_NULL, 0, MPI_COMM_SELF, &inter) != MPI_SUCCESS)
    return std::unexpected("MPI_Comm_connect to " + portFile.string() +
                           "'s port failed (both mpirun jobs started with --ompi-server?)");
  MPI_Comm_set_errhandler(inter, MPI_ERRORS_RETURN);
  Comm& c = **comm;
  c.peers_->links.resize(1);
  c.peers_->links[0].comm = inter;
  c.peers_->links[0].rank = 0;
  c.peers_->links[0].joined = true;
  return comm;
}

std::optional<FrameState> Comm::receiveState(double timeoutS) {
  const Peers::Link& l = peers_->links.at(0);
  FrameState s;
  if (!receiveWithin(&s, static_cast<int>(sizeof s), l.comm, l.rank, kTagState, timeoutS))
    return std::nullopt;
  return s;
}

void Comm::answer(bool well) {
  Peers::Link& l = peers_->links.at(0);
  l.answer = well ? 1 : 0;
  MPI_Send(&l.answer, 1, MPI_INT, l.rank, kTagAnswer, l.comm);
}

std::optional<bool> Comm::receiveGo(double timeoutS) {
  const Peers::Link& l = peers_->links.at(0);
  int go = 0;
  if (!receiveWithin(&go, static_cast<int>(sizeof go), l.comm, l.rank, kTagGo, timeoutS))
    return std::nullopt;
  if (go == kGoStopRanksLost && !l.joined) skipFinalize(); // a joined channel's job lost none
  return go == kGoSwap;
}

} // namespace tellus::cluster
