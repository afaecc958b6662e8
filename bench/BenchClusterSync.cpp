// The cost of the cluster's synchronisation per frame (issue 28; docs/design/cluster.md): the
// master's MPI_Bcast of the frame state and the barrier before the swap (an MPI_Allreduce of
// "well"), nothing drawn. Run under mpirun with the ranks to measure (bench/cluster.sh: 2, 4 and
// 8 on one machine). Prints, on rank 0, the median over runs of the mean per frame, and the
// slowest run. A plain main, not Google Benchmark: every rank must run the same iterations.
#include <tellus/cluster/Comm.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::atoi(argv[1]) : 2000;
  const int runs = argc > 2 ? std::atoi(argv[2]) : 7;
  auto comm = tellus::cluster::Comm::init();
  if (!comm || frames < 1 || runs < 1) {
    std::fprintf(stderr, "BenchClusterSync [FRAMES [RUNS]] under mpirun\n");
    return 2;
  }
  std::vector<double> usPerFrame;
  for (int run = 0; run < runs + 1; ++run) { // the first run warms up, not counted
    comm.value()->allWell(true);
    const auto t0 = std::chrono::steady_clock::now();
    for (int n = 0; n < frames; ++n) {
      tellus::cluster::FrameState s;
      if (comm.value()->rank() == 0) s.frame = n;
      comm.value()->broadcast(s);
      if (s.frame != n || !comm.value()->allWell(true)) return 1;
    }
    const double us =
        std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
    double lo = 0.0, hi = 0.0;
    comm.value()->minMax(us, lo, hi); // the slowest rank's time is the run's
    if (run > 0) usPerFrame.push_back(hi / frames);
  }
  if (comm.value()->rank() == 0) {
    std::sort(usPerFrame.begin(), usPerFrame.end());
    std::printf("ranks %d: broadcast + barrier %.2f us per frame (median of %d runs of %d "
                "frames; slowest run %.2f us)\n",
                comm.value()->size(),
                usPerFrame[usPerFrame.size() / 2],
                runs,
                frames,
                usPerFrame.back());
  }
  return 0;
}
