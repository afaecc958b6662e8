#!/usr/bin/env bash
# `tellus cluster` stopped by a failed frame after a rank of its job died (issue 28; labels gl
# and integration: run under xvfb-run). Open MPI 4.1's MPI_Finalize waits for every rank of the
# job, a dead one too: so once a rank is lost, no rank may finalize. mpirun --enable-recovery
# starts the master and two channels looping a view in real time; channel b is killed (-9) and
# reported lost; then channel a cannot write its digest (a folder stands where the file was), so
# its answer says it failed: the master says the frame failed and stops the show, telling the
# channel at the go that a rank was lost. Every process must be gone within 30 s (neither the
# master nor the channel waits in MPI_Finalize). KEEP=1 keeps the work folder.
set -euo pipefail
tellus=$1
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-cluster-stop.XXXXXX")
mpirun_pid=
cleanup() {
  if [ -n "$mpirun_pid" ]; then kill -9 "$mpirun_pid" 2>/dev/null || true; fi
  pkill -9 -f "$work/dome.json" 2>/dev/null || true
  [ -n "${KEEP:-}" ] || rm -rf "$work"
}
trap cleanup EXIT
fail() {
  echo "FAIL: $*" >&2
  tail -n 20 "$work/err" >&2 || true
  exit 1
}
. "$(dirname "$0")/cluster_support.sh"

echo '{"channels": [
 {"name": "a", "azimuth": 0, "elevation": 80, "hfov": 20, "vfov": 20, "width": 32, "height": 32},
 {"name": "b", "azimuth": 180, "elevation": 80, "hfov": 20, "vfov": 20, "width": 32, "height": 32}
]}' >"$work/dome.json"
mpirun --enable-recovery --oversubscribe -n 3 "$tellus" cluster "$work/dome.json" \
  --cache "$work/cache" --no-sun --no-atmosphere --no-stars --camera 10,20,8e6 --loop \
  --realtime --channel-timeout 3 --out "$work/o" >"$work/out" 2>"$work/err" &
mpirun_pid=$!
wait_for 60 test -s "$work/o/digest-b.txt" || fail "channel b drew no frame"
b=$(rank_pid "$mpirun_pid" 2) || fail "no rank 2"
kill -9 "$b"
wait_for 30 grep -q "channel b lost" "$work/err" || fail "channel b not reported lost"
# Channel a's next frame fails: its digest cannot be written (it appends a line each frame, so
# it may put the file back between the two: again until the folder stands).
folder() { rm -f "$work/o/digest-a.txt" && mkdir "$work/o/digest-a.txt" 2>/dev/null; }
wait_for 10 folder || fail "the digest stayed a file"
wait_for 30 grep -q "frame [0-9]* failed on a rank" "$work/err" || fail "no failed frame reported"
ended() { ! kill -0 "$mpirun_pid" 2>/dev/null; }
wait_for 30 ended || fail "mpirun still running 30 s after the failed frame (MPI_Finalize?)"
! pgrep -f "$work/dome.json" >/dev/null || fail "a rank is still running"
echo "ok"
