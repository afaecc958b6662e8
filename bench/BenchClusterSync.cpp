// The cost of the cluster's synchronisation per frame (issue 28; docs/design/cluster.md and
// cluster-live.md), nothing drawn, both protocols side by side in one run: the collective one (the
// master's MPI_Bcast of the frame state and the barrier before the swap, an MPI_Allreduce of
// "well") and the live one that `tellus cluster` runs (point to point with deadlines: the master
// posts the state to every channel, collects their answers, posts the go; a channel receives the
// state, answers, receives the go). Run under mpirun with the ranks to measure (bench/cluster.sh:
// 2, 4 and 8 on one machine). Runs alternate between the protocols (the first of each warms up);
// prints, on rank 0, each one's median over runs of the mean per frame, its slowest run, and the
// ratio live / collective. A plain main, not Google Benchmark: every rank must run the same
// iterations.
#include <tellus/cluster/Comm.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <vector>

namespace {

using tellus::cluster::Comm;
using tellus::cluster::FrameState;

bool collectiveFrame(Comm& comm, int n) {
  FrameState s;
  if (comm.rank() == 0) s.frame = n;
  comm.broadcast(s);
  return s.frame == n && comm.allWell(true);
}

/** The live protocol's frame (ClusterMaster.cpp / ClusterChannel.cpp without the drawing). */
bool liveFrame(Comm& comm, const std::vector<int>& channels, int n) {
  constexpr double kDeadlineS = 10.0;
  if (comm.rank() == 0) {
    FrameState s;
    s.frame = n;
    for (const int peer : channels)
      comm.post(peer, s);
    const std::vector<int> answers = comm.collect(channels, kDeadlineS);
    const bool well = std::all_of(answers.begin(), answers.end(), [](int a) { return a == 1; });
    for (const int peer : channels)
      comm.postGo(peer, well);
    return well;
  }
  const auto s = comm.receiveState(kDeadlineS);
  if (!s || s->frame != n) return false;
  comm.answer(true);
  const auto go = comm.receiveGo(kDeadlineS);
  return go && *go;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

} // namespace

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::atoi(argv[1]) : 2000;
  const int runs = argc > 2 ? std::atoi(argv[2]) : 7;
  auto made = Comm::init();
  if (!made || frames < 1 || runs < 1) {
    std::fprintf(stderr, "BenchClusterSync [FRAMES [RUNS]] under mpirun\n");
    return 2;
  }
  Comm& comm = **made;
  std::vector<int> channels(static_cast<std::size_t>(comm.size() - 1));
  std::iota(channels.begin(), channels.end(), 1);
  std::vector<double> collective, live;            // us per frame, the slowest rank's
  for (int run = 0; run < 2 * (runs + 1); ++run) { // the first run of each warms up, not counted
    const bool isLive = run % 2 == 1;
    comm.allWell(true);
    const auto t0 = std::chrono::steady_clock::now();
    for (int n = 0; n < frames; ++n)
      if (!(isLive ? liveFrame(comm, channels, n) : collectiveFrame(comm, n))) return 1;
    const double us =
        std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
    double lo = 0.0, hi = 0.0;
    comm.minMax(us, lo, hi); // the slowest rank's time is the run's
    if (run > 1) (isLive ? live : collective).push_back(hi / frames);
  }
  if (comm.rank() == 0) {
    const double c = median(collective), l = median(live);
    std::printf("ranks %d: collective (broadcast + barrier) %.2f us per frame (slowest run %.2f); "
                "live (point to point with deadlines) %.2f us (slowest run %.2f); live / "
                "collective %.2fx (medians of %d runs of %d frames each)\n",
                comm.size(),
                c,
                *std::max_element(collective.begin(), collective.end()),
                l,
                *std::max_element(live.begin(), live.end()),
                l / c,
                runs,
                frames);
  }
  return 0;
}
