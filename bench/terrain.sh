#!/usr/bin/env bash
# Terrain costs in the renderer (issue #6): the same flights with terrain and edge fixing (the
# default), with terrain but no edge fixing (cracks), and without terrain, alternated in one run,
# ROUNDS times; median frame time and the time spent building meshes (heights + edge fixing).
# Mesa llvmpipe under Xvfb renders on the CPU: every figure is a CPU figure; read the ratios.
# Usage: bench/terrain.sh [path/to/tellus]   (ROUNDS=3 by default)
set -euo pipefail
tellus=${1:-build/tools/tellus/tellus}
rounds=${ROUNDS:-3}
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-terrain-bench.XXXXXX")
trap 'rm -rf "$work"' EXIT
# A fixed oblique view of the Alps held for 3 s, and a descent over the Himalaya.
cat >"$work/fixed.json" <<'JSON'
[{"time": 0, "lat": 45.8, "lon": 7.6, "alt": 60000, "heading": 20, "tilt": 70},
 {"time": 3, "lat": 45.8, "lon": 7.6, "alt": 60000, "heading": 20, "tilt": 70}]
JSON
cat >"$work/descent.json" <<'JSON'
[{"time": 0, "lat": 20, "lon": 80, "alt": 3e6, "heading": 0, "tilt": 0},
 {"time": 3, "lat": 27.9, "lon": 86.9, "alt": 3e4, "heading": 10, "tilt": 70}]
JSON
# Warm the cache (tiles rendered by the tile service once).
for f in fixed descent; do
  xvfb-run -a -s '-screen 0 1280x1024x24' "$tellus" render --cache "$work/cache" --path "$work/$f.json" \
    --frames "$work/frames" --fps 25 --size 800x600 >/dev/null
done
echo "| flight | configuration | round | median frame ms | longest frame ms | mesh ms total | meshes built | nodes drawn (last) | edges fixed (last) | zero-area triangles (last) |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for r in $(seq "$rounds"); do
  for f in fixed descent; do
    for c in "terrain, edges fixed:" "terrain, no edge fixing:--edge-fixing off" "no terrain:--no-terrain"; do
      name=${c%%:*}
      args=${c#*:}
      # shellcheck disable=SC2086
      xvfb-run -a -s '-screen 0 1280x1024x24' "$tellus" render --cache "$work/cache" --path "$work/$f.json" \
        --frames "$work/frames" --fps 25 --size 800x600 --stats "$work/s.json" $args >/dev/null
      python3 - "$f" "$name" "$r" "$work/s.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[4]))
print("| %s | %s | %s | %.1f | %.1f | %.1f | %d | %d | %d | %d |" % (sys.argv[1], sys.argv[2], sys.argv[3],
      s["median_frame_ms"], s["longest_frame_ms"], s.get("mesh_ms_total", 0.0), s.get("meshes_built", 0), s["nodes_drawn"],
      s.get("edges_fixed", 0), s.get("zero_area_triangles", 0)))
PY
    done
  done
done
