#!/usr/bin/env bash
# Frame pacing of a fly-through (issue #5: "the longest frame during a fly-through compared with
# the median, goal <= 1.5x: uploads must not stutter") with the drawing on a processor of its own.
#
# On Mesa llvmpipe the "GPU" is the CPU: its rasteriser threads share the two cores with the
# decoders and the tile service's workers, so a frame that coincides with decoding is long for
# reasons a GPU machine does not have. This script flies the same paths twice per round, cold:
#   shared  every thread on every CPU (what bench/render.sh measures);
#   split   the main thread (update, intake, uploads, meshes, draw calls) and llvmpipe's
#           rasteriser (LP_NUM_THREADS=1) on CPU 0, everything else (decoders, tile workers, heights,
#           Xvfb) on CPU 1: drawing no longer shares a processor with background work, as on a
#           GPU, while the main thread still does every upload and mesh the renderer does.
# Threads are pinned from outside (a poller re-pins new threads every 5 ms by name: llvmpipe's are
# "llvmpipe-N", the main thread's id is the process id); the renderer itself is unchanged.
# Each flight is flown twice in one renderer (--repeat 2): pass 1 as streamed, pass 2 the same
# views with everything resident (each view's own cost). Needs 2 or more CPUs.
# Usage: bench/pacing.sh [path/to/tellus] [rounds]   (default build/tools/tellus/tellus, 3)
set -euo pipefail
tellus=${1:-build/tools/tellus/tellus}
rounds=${2:-3}
[ "$(nproc)" -ge 2 ] || { echo "pacing.sh: needs 2 CPUs" >&2; exit 2; }
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-pacing.XXXXXX")
trap 'rm -rf "$work"' EXIT
paths="$(dirname "$0")/paths" # the flights: the same as bench/render.sh's
cat >"$work/pin.py" <<'PY'
# Pins the threads of process PID: its main thread and llvmpipe's to CPU 0, the rest to CPU 1,
# until the process ends. Re-pins a thread whose name changes (llvmpipe names its threads after
# they start).
import os, sys, time
pid = int(sys.argv[1]); seen = {}
os.sched_setaffinity(0, {1})
while os.path.exists(f"/proc/{pid}"):
    try:
        tids = os.listdir(f"/proc/{pid}/task")
    except FileNotFoundError:
        break
    for t in tids:
        try:
            name = open(f"/proc/{pid}/task/{t}/comm").read().strip()
        except OSError:
            continue
        if seen.get(t) == name:
            continue
        cpu = 0 if int(t) == pid or name.startswith("llvmpipe") else 1
        try:
            os.sched_setaffinity(int(t), {cpu}); seen[t] = name
        except OSError:
            pass
    time.sleep(0.005)
PY
report() { # mode flight stats.json
  python3 - "$1" "$2" "$3" "$(dirname "$0")" <<'PY'
import sys
sys.path.insert(0, sys.argv[4])
from flight_stats import flight
f = flight(sys.argv[3])
print("| %s | %s | %.1f | %.1f | %.2f | %.2f | %.1f, %.2f | %.2f, %.2f, %.2f |" % (
    sys.argv[1], sys.argv[2], f["median"], f["longest"], f["longest"] / f["median"],
    f["p95"] / f["median"], f["settled_median"], f["settled_longest"] / f["settled_median"],
    f["ratio_median"], f["ratio_p95"], f["ratio_max"]))
PY
}
fly() { # mode flight
  local mode=$1 flight=$2 cache="$work/cache-$1-$2-$RANDOM"
  if [ "$mode" = split ]; then
    # Xvfb and xvfb-run on CPU 1; tellus starts there too and the poller moves its main thread.
    rm -f "$work/pid"
    LP_NUM_THREADS=1 taskset -c 1 xvfb-run -a -s '-screen 0 1280x1024x24' \
      sh -c 'echo $$ >"$0"; exec "$@"' "$work/pid" "$tellus" render \
      --cache "$cache" --path "$paths/$flight.json" --frames "$work/frames" --fps 25 \
      --size 1024x768 --repeat 2 --stats "$work/s.json" >/dev/null &
    local runner=$!
    while [ ! -s "$work/pid" ] && kill -0 "$runner" 2>/dev/null; do sleep 0.002; done
    [ -s "$work/pid" ] && python3 "$work/pin.py" "$(cat "$work/pid")" &
    wait "$runner"
    wait || true
  else
    xvfb-run -a -s '-screen 0 1280x1024x24' "$tellus" render --cache "$cache" \
      --path "$paths/$flight.json" --frames "$work/frames" --fps 25 --size 1024x768 --repeat 2 \
      --stats "$work/s.json" >/dev/null
  fi
  rm -rf "$cache" "$work/frames"
  report "$mode" "$flight" "$work/s.json"
}
echo "| threads | flight (101 frames, cold) | median ms | longest ms | longest / median | p95 / median | settled: median ms, longest / median | frame / settled frame: median, p95, max |"
echo "|---|---|---|---|---|---|---|---|"
for round in $(seq 1 "$rounds"); do
  for flight in level descent; do
    for mode in shared split; do
      fly "$mode" "$flight"
    done
  done
done
