#!/usr/bin/env bash
# Popping on a scripted descent (issue 23, "No popping"; docs/design/popping.md): 20,000 km over the
# Atlantic down to 5 km over the Alps in 10 s, then 2 s held still (bench/paths/descent_low.json),
# over imagery and heights with new detail at every level (the synthetic WMS upstream
# bench/popping_upstream.py, configured by bench/popping.yaml; the embedded default has no detail
# past level 2, so nothing there pops), for each configuration side by side:
#   - as streamed: one renderer frame per flight frame at FPS (the fades run on the flight's
#     clock, frame n at n / FPS), with a real-time budget a frame: at most STREAM_UPLOAD texture
#     bytes uploaded a frame (default 256 KiB, a quarter of a 512 x 512 RGBA tile), so textures
#     arrive through the descent as they do in a viewer, not all between two slow llvmpipe frames;
#   - with --probe-frames: before frame k changes anything, frame k-1's state drawn from frame k's
#     camera (Q_k). Popping P_k(p) = max over RGB of |S_k(p) - Q_k(p)| (0-255) over the pixels Q_k
#     draws (background pixels and their 8 neighbours left out): the change of frame k that the
#     camera's motion does not explain, because Q_k has the same camera and the old state.
#     Reported (bench/popping.py): the largest value, the largest over a 2 x 2-pixel area (a
#     one-pixel crack that flickers is no pop), the worst frame's 99.9th and 99th percentiles,
#     the mean over frames of the 99.9th percentile and of the mean, the largest 8 x 8-block
#     mean, the frames whose largest value is over 32;
#   - settled (--wait-complete=300, every frame complete, no fading): its seconds a frame, and the
#     older form of the metric against it (max(0, dS_k - dC_k); bench/popping.py explains why it
#     is not the measure);
#   - time to a complete frame: one view (the descent's last pose) --wait-complete from a cold
#     cache (its seconds from --stats).
# Every run has its own cold tellus cache; the upstream keeps its answers in memory, and a warm-up
# flight (settled, at FPS 4) fills it first, so no configuration pays for generating tiles.
# Mesa llvmpipe under Xvfb renders on the CPU: times are CPU figures.
# Usage: bench/popping.sh [path/to/tellus] ["label:extra args" ...]
#   default configurations: "before:--no-fade-in --no-geomorph" and "after:" (the defaults)
#   SIZE (512x384), FPS (25), STREAM_UPLOAD (262144), KEEP=1 keeps the frames (the path is printed)
set -euo pipefail
tellus=${1:-build/tools/tellus/tellus}
shift || true
configs=("$@")
[ ${#configs[@]} -eq 0 ] && configs=("before:--no-fade-in --no-geomorph" "after:")
size=${SIZE:-512x384}
fps=${FPS:-25}
upload=${STREAM_UPLOAD:-262144}
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-popping.XXXXXX")
server=""
cleanup() {
  [ -z "$server" ] || kill "$server" 2>/dev/null || true
  [ -n "${KEEP:-}" ] || rm -rf "$work"
}
trap cleanup EXIT
[ -z "${KEEP:-}" ] || echo "frames in $work"
python3 "$here/popping_upstream.py" "$work/port" &
server=$!
for _ in $(seq 100); do [ -s "$work/port" ] && break; sleep 0.2; done
[ -s "$work/port" ] || { echo "popping.sh: the synthetic upstream did not start" >&2; exit 1; }
sed "s|@URL@|http://127.0.0.1:$(cat "$work/port")/wms|" "$here/popping.yaml" >"$work/popping.yaml"
path="$here/paths/descent_low.json"
run() { xvfb-run -a -s '-screen 0 1280x1024x24' "$tellus" render --config "$work/popping.yaml" --size "$size" "$@" >/dev/null; }
run --cache "$work/warm" --path "$path" --frames "$work/warm-frames" --fps 4 --wait-complete=300
for c in "${configs[@]}"; do
  name=${c%%:*}
  read -r -a args <<<"${c#*:}"
  d="$work/$name"
  mkdir -p "$d"
  t0=$(date +%s.%N)
  run --cache "$d/cc" --path "$path" --frames "$d/c" --fps "$fps" --wait-complete=300 "${args[@]}"
  t1=$(date +%s.%N)
  echo "$t0 $t1" >"$d/settled-times"
  run --cache "$d/cv" --camera 46.4,7.9,5000,30,60 --out "$d/v.png" --wait-complete=300 \
    --stats "$d/v.json" "${args[@]}"
  run --cache "$d/cs" --path "$path" --frames "$d/s" --probe-frames "$d/q" --fps "$fps" \
    --upload-per-frame "$upload" --background 255,0,255 "${args[@]}"
done
echo "| configuration | frames | popping max | max over 2x2 px | worst frame p99.9 | worst frame p99 | mean p99.9 | mean of means | 8x8 blocks max | frames max > 32 | older form: max, mean p99.9 | settled s / frame | one view to complete s |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
for c in "${configs[@]}"; do
  name=${c%%:*}
  python3 - "$name" "$work/$name" "$here" <<'PY'
import json, sys
sys.path.insert(0, sys.argv[3])
from popping import popping, settled_form
name, d = sys.argv[1], sys.argv[2]
p = popping(d + "/s", d + "/q")
p.update(settled_form(d + "/s", d + "/c"))
t0, t1 = (float(x) for x in open(d + "/settled-times").read().split())
v = json.load(open(d + "/v.json"))
print("| %s | %d | %d | %d | %.1f | %.1f | %.2f | %.3f | %.1f | %d | %d, %.2f | %.3f | %.2f |" % (name,
      p["frames"], p["max"], p["max_2x2"], p["p999_worst"], p["p99_worst"], p["p999_mean"], p["mean_mean"], p["block8_max"],
      p["frames_max_over_32"], p["settled_max"], p["settled_p999_mean"], (t1 - t0) / p["frames"], v["seconds"]))
PY
done
