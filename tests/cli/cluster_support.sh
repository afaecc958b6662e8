# Sourced by the scripts that run `tellus cluster` under mpirun (test_cluster_live.sh,
# test_cluster_stop.sh, test_cluster_times.sh, bench/cluster_rejoin.sh): polling and finding a
# rank's process. Also lets Open MPI run as root (CI is root).
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

# wait_for SECONDS COMMAND...: polls the command until it succeeds (false after SECONDS).
wait_for() {
  local end=$((SECONDS + $1))
  shift
  until "$@"; do
    [ $SECONDS -lt $end ] || return 1
    sleep 0.1
  done
}

# rank_pid MPIRUN_PID RANK: the pid of that rank (mpirun's child with it in its environment).
# grep -z reads the NUL-separated file itself: `tr | grep -q` under pipefail failed whenever
# grep quit before tr had written a large environment (tr's SIGPIPE; once in CI).
rank_pid() {
  for p in $(pgrep -P "$1"); do
    if grep -qxz "OMPI_COMM_WORLD_RANK=$2" "/proc/$p/environ"; then
      echo "$p"
      return 0
    fi
  done
  return 1
}
