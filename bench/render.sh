#!/usr/bin/env bash
# tellus render --stats for a few views (cold cache, then warm) and a descent flight (frame times as
# streamed against the same views settled), on the embedded default. Mesa llvmpipe under Xvfb
# renders on the CPU: frame times are CPU figures.
# Usage: bench/render.sh [path/to/tellus]   (default build/tools/tellus/tellus)
set -euo pipefail
tellus=${1:-build/tools/tellus/tellus}
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-render-bench.XXXXXX")
trap 'rm -rf "$work"' EXIT
row() {
  python3 - "$1" "$2" "$3" <<'PY'
import json, sys
s = json.load(open(sys.argv[3]))
print("| %s | %s | %.2f | %d | %d / %d | %d | %d | %.1f | %.3f | %.1f | %.1f |" % (
    sys.argv[1], sys.argv[2], s["seconds"], s["frames"], s["nodes_drawn"], s["nodes_visible"],
    s["max_level"], s["tiles_received"], s["bytes_uploaded"] / 2**20, s["longest_update_ms"],
    s["median_frame_ms"], s["longest_frame_ms"]))
PY
}
echo "| view | cache | s to complete | frames | drawn / visible nodes | level | tiles | MiB uploaded | longest update ms | median frame ms | longest frame ms |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for v in "0,0,2e7" "45.5,7.5,2e6,30,40" "90,0,1e6" "0,180,1e6"; do
  for c in cold warm; do
    xvfb-run -a -s '-screen 0 1280x1024x24' "$tellus" render --cache "$work/cache-$v" --camera "$v" \
      --size 1024x768 --out "$work/v.png" --wait-complete --stats "$work/s.json" >/dev/null
    row "$v" "$c" "$work/s.json"
  done
done
# The flights (bench/paths/): the descent, 20,000 km over the Atlantic to 20 km over the Alps,
# tilted 60 degrees at the end; a level pass, 2,000 km up, 60 degrees east along 30 N, tilted 30
# degrees: level-2 tiles (and heights) stream in all the way, while every view costs about the
# same to draw (unlike the descent, whose views differ 4-8x on llvmpipe).
paths="$(dirname "$0")/paths"
# Each flight as streamed, flown twice in one renderer (--repeat 2): the first pass is what a viewer
# sees; in the second everything is resident, so it gives each view's cost without streaming.
# Stutter is the first pass's frame against the same view in the second (frame by frame).
for flight in descent level; do
echo
echo "| $flight, 101 frames | cache | s | median ms | p95 ms | longest ms | longest / median | p95 / median | settled: median ms, longest / median | frame / settled frame: median, p95, max |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for c in cold warm; do
  xvfb-run -a -s '-screen 0 1280x1024x24' "$tellus" render --cache "$work/cache-$flight" \
    --path "$paths/$flight.json" --frames "$work/frames" --fps 25 --size 1024x768 --repeat 2 \
    --stats "$work/s.json" >/dev/null
  python3 - "$c" "$work/s.json" "$(dirname "$0")" <<'PY2'
import sys
sys.path.insert(0, sys.argv[3])
from flight_stats import flight
f = flight(sys.argv[2])
print("| as streamed | %s | %.2f | %.1f | %.1f | %.1f | %.2f | %.2f | %.1f, %.2f | %.2f, %.2f, %.2f |" % (
    sys.argv[1], f["seconds"], f["median"], f["p95"], f["longest"], f["longest"] / f["median"],
    f["p95"] / f["median"], f["settled_median"], f["settled_longest"] / f["settled_median"],
    f["ratio_median"], f["ratio_p95"], f["ratio_max"]))
PY2
done
done
