#!/usr/bin/env bash
# What overlay layers cost in the renderer (issue #7): the same still view (the embedded default's
# Blue Marble, a warm cache) with 0, 1, 3 and 6 overlays (the Blue Marble again at half opacity),
# blended in one pass (as the GPU allows) and with one overlay a pass (overlays_per_pass: 1),
# alternated in one run, ROUNDS times; the median frame time of the second and third flights of
# the view in one renderer (--repeat 3: the first streams, the later ones only draw).
# Mesa llvmpipe under Xvfb renders on the CPU: every figure is a CPU figure; read the ratios.
# Usage: bench/layers.sh [path/to/tellus]   (ROUNDS=3, SIZE=800x600 by default)
set -euo pipefail
tellus=${1:-build/tools/tellus/tellus}
rounds=${ROUNDS:-3}
size=${SIZE:-800x600}
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-layers-bench.XXXXXX")
trap 'rm -rf "$work"' EXIT
cat >"$work/still.json" <<'JSON'
[{"time": 0, "lat": 30, "lon": 10, "alt": 1.2e7, "heading": 0, "tilt": 0},
 {"time": 2, "lat": 30, "lon": 10, "alt": 1.2e7, "heading": 0, "tilt": 0}]
JSON
printf 'renderer:\n  overlays_per_pass: 1\n' >"$work/onepass.tail"
render() { # overlays per-pass-config stats
  local args=()
  for _ in $(seq "$1"); do args+=(--overlay bluemarble,0.5); done
  # shellcheck disable=SC2086
  xvfb-run -a -s '-screen 0 1280x1024x24' "$tellus" render --cache "$work/cache" $2 \
    --path "$work/still.json" --frames "$work/frames" --fps 25 --size "$size" --repeat 3 \
    --no-terrain --stats "$3" "${args[@]}" >/dev/null
}
# The embedded default's configuration with one overlay a pass.
here=$(cd "$(dirname "$0")/.." && pwd)
sed "s|^data_dir: .*|data_dir: $here/data|" "$here/config/examples/default.yaml" >"$work/several.yaml"
cat "$work/onepass.tail" >>"$work/several.yaml"
render 0 "" "$work/warm.json" # warms the cache
echo "| overlays | blending | round | median frame ms (warm flights) | passes | overlays per pass |"
echo "|---|---|---|---|---|---|"
for r in $(seq "$rounds"); do
  for n in 0 1 3 6; do
    for mode in one several; do
      [ "$n" = 0 ] && [ "$mode" = several ] && continue
      cfg=""
      [ "$mode" = several ] && cfg="--config $work/several.yaml"
      render "$n" "$cfg" "$work/s.json"
      python3 - "$n" "$mode" "$r" "$work/s.json" <<'PY'
import json, statistics, sys
s = json.load(open(sys.argv[4]))
t = s["frame_times_ms"]
warm = t[len(t) // 3:]
print("| %s | %s | %s | %.2f | %d | %d |" % (sys.argv[1], "one pass" if sys.argv[2] == "one" else "one overlay a pass",
      sys.argv[3], statistics.median(warm), s["passes"], s["overlays_per_pass"]))
PY
    done
  done
done
