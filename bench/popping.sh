#!/usr/bin/env bash
# Popping on a scripted descent (issue 23, "No popping"): 20,000 km over the Atlantic down to 5 km
# over the Alps in 10 s, then 2 s held still (bench/paths/descent_low.json, at FPS=12), rendered twice per configuration: as
# streamed (one renderer frame per flight frame, a cold cache: what a viewer sees) and settled
# (every frame complete, --wait-complete, its own cold cache). bench/popping.py defines the metric
# (the streamed frames' change minus the settled frames' change, per pixel). Time to a complete
# frame: the settled flight's seconds per frame, and one view (the descent's last) --wait-complete
# from a cold cache. Mesa llvmpipe under Xvfb renders on the CPU: times are CPU figures.
# Usage: bench/popping.sh [path/to/tellus] ["label:extra args" ...]
#   default configurations: the build's defaults ("default:")
set -euo pipefail
tellus=${1:-build/tools/tellus/tellus}
shift || true
configs=("$@")
[ ${#configs[@]} -eq 0 ] && configs=("default:")
size=${SIZE:-512x384}
fps=${FPS:-12}
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-popping.XXXXXX")
[ -n "${KEEP:-}" ] || trap 'rm -rf "$work"' EXIT # KEEP=1: the frames stay (the path is printed)
[ -z "${KEEP:-}" ] || echo "frames in $work"
run() { xvfb-run -a -s '-screen 0 1280x1024x24' "$tellus" render "$@" >/dev/null; }
echo "| configuration | frames | popping max | worst frame p99.9 | worst frame p99 | mean p99.9 | 8x8 blocks max | held frames: n, max, worst p99.9 | settled s / frame | one view to complete s |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for c in "${configs[@]}"; do
  name=${c%%:*}
  read -r -a args <<<"${c#*:}"
  d="$work/$name"
  mkdir -p "$d"
  # As streamed, with an upload budget a frame (STREAM_UPLOAD bytes, default 512 KiB: half a 512 x 512
  # tile) standing in for a viewer's frame time: llvmpipe draws a frame in ~0.5 s under load, during
  # which every tile would arrive (the flight advances 1/FPS s), hiding what a real-time view shows.
  run --cache "$d/cs" --path "$here/paths/descent_low.json" --frames "$d/s" --fps "$fps" --size "$size" \
    --upload-per-frame "${STREAM_UPLOAD:-524288}" "${args[@]}"
  t0=$(date +%s.%N)
  run --cache "$d/cc" --path "$here/paths/descent_low.json" --frames "$d/c" --fps "$fps" --size "$size" \
    --wait-complete=120 "${args[@]}"
  t1=$(date +%s.%N)
  run --cache "$d/cv" --camera 46.4,7.9,5000,30,60 --out "$d/v.png" --size "$size" --wait-complete=120 \
    --stats "$d/v.json" "${args[@]}"
  python3 - "$name" "$d" "$t0" "$t1" "$here" <<'PY'
import json, sys
sys.path.insert(0, sys.argv[5])
from popping import popping
name, d, t0, t1 = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
p = popping(d + "/s", d + "/c")
v = json.load(open(d + "/v.json"))
print("| %s | %d | %d | %.1f | %.1f | %.2f | %.1f | %d, %d, %.1f | %.3f | %.2f |" % (name, p["frames"], p["max"],
      p["p999_worst"], p["p99_worst"], p["p999_mean"], p["block8_max"], p["held_frames"], p["held_max"],
      p["held_p999_worst"], (t1 - t0) / p["frames"], v["seconds"]))
PY
done
