#!/usr/bin/env bash
# The cluster's synchronisation per frame (issue 28), both protocols side by side: the collective
# one (MPI_Bcast of the frame state + the barrier before the swap) and the live one `tellus cluster`
# runs (point to point with deadlines), with 2, 4 and 8 ranks on this machine (bench/RESULTS.md).
#   bench/cluster.sh [BUILD_DIR] [FRAMES] [RUNS]
set -euo pipefail
build=${1:-build}
frames=${2:-2000}
runs=${3:-7}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
echo "cores: $(nproc); $(mpirun --version | head -1)"
for k in 2 4 8; do
  mpirun --oversubscribe -n "$k" "$build/bench/tellus_bench_cluster_sync" "$frames" "$runs"
done
