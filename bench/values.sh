#!/usr/bin/env bash
# What a layer of values costs in the renderer against a picture layer (issue 24; goal <= 1.1x per
# frame). The same upstream data (the bundled ETOPO 20' grid, data/etopo20_int16.tif) on the same
# grid (36-degree level zero, 256-pixel tiles, 3 levels) is drawn over the Blue Marble at half
# opacity once as a picture layer (8-bit PNG tiles the local upstream renders from it: an RGBA8
# texture) and once as a layer of values (BIL16 tiles: an R32F texture coloured on the GPU by the
# `terrain` map), in the same views at the same size, alternated round after round in one run. A
# view is a still flight of FRAMES frames flown twice in one renderer (--repeat 2) with
# --wait-complete (the first frame waits until every tile is drawn, so the others only draw); the
# figures are the medians over the last two thirds of the frames of the frame time (wall,
# glFinish included) and of the process's CPU time per frame (all threads: llvmpipe's too). The
# look of issue 23 (sun, atmosphere, stars) is off so that the globe pass, where the two differ,
# is most of the frame.
# Mesa llvmpipe under Xvfb renders on the CPU: every figure is a CPU figure; read the ratios.
# Usage: bench/values.sh [path/to/tellus]   (ROUNDS=3, SIZE=800x600, FRAMES=20 by default)
set -euo pipefail
tellus=${1:-build/tools/tellus/tellus}
rounds=${ROUNDS:-3}
size=${SIZE:-800x600}
frames=${FRAMES:-20}
here=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-values-bench.XXXXXX")
trap 'rm -rf "$work"' EXIT

cat >"$work/bench.yaml" <<YAML
cache: {size_limit: 0}
data_dir: $here/data
upstreams:
  - {name: local, type: local, path: bmng_2048x1024.jpg}
  - {name: local-etopo, type: local, path: etopo20_int16.tif}
layers:
  - name: bluemarble
    upstream: local
    format: image/jpeg
    grid: {level_zero_delta: 36, tile_size: 512, levels: 3}
  - name: etopo-picture            # the heights as 8-bit grey pictures (PNG)
    upstream: local-etopo
    format: image/png
    kind: imagery
    grid: {level_zero_delta: 36, tile_size: 256, levels: 3}
  - name: etopo-values             # the same heights as values (BIL16), coloured on the GPU
    upstream: local-etopo
    format: application/bil16
    kind: values
    grid: {level_zero_delta: 36, tile_size: 256, levels: 3}
    values: {encoding: int16, no_data: -32768, unit: m, colour_map: terrain, range: [-8000, 8000]}
renderer:
  layers:
    - layer: bluemarble
YAML
still() { # NAME LAT LON ALT TILT
  python3 - "$work/$1.json" "$2" "$3" "$4" "$5" "$frames" <<'PY'
import json, sys
path, lat, lon, alt, tilt, frames = sys.argv[1], *map(float, sys.argv[2:6]), int(sys.argv[6])
key = {"lat": lat, "lon": lon, "alt": alt, "heading": 0, "tilt": tilt}
json.dump([dict(key, time=0), dict(key, time=(frames - 1) / 25)], open(path, "w"))
PY
}
still globe 30 10 1.2e7 0
still region 45 5 1.5e6 40
render() { # VIEW LAYER STATS
  xvfb-run -a -s '-screen 0 1280x1024x24' "$tellus" render --config "$work/bench.yaml" \
    --cache "$work/cache" --path "$work/$1.json" --frames "$work/frames" --fps 25 --size "$size" \
    --repeat 2 --wait-complete --no-terrain --no-sun --no-atmosphere --no-stars \
    --overlay "$2,0.5" --stats "$3" >/dev/null
}
median() { # STATS KEY -> median of the later two thirds
  python3 -c "import json,statistics,sys; t=json.load(open(sys.argv[1]))[sys.argv[2]]; print('%.2f' % statistics.median(t[len(t)//3:]))" "$1" "$2"
}
echo "| view | round | picture frame ms | values frame ms | ratio | picture CPU ms | values CPU ms | ratio |"
echo "|---|---|---|---|---|---|---|---|"
for r in $(seq "$rounds"); do
  for view in globe region; do
    # Alternate which goes first, so that a trend in the machine's load favours neither.
    order="etopo-picture etopo-values"
    [ $((r % 2)) = 0 ] && order="etopo-values etopo-picture"
    for layer in $order; do
      render "$view" "$layer" "$work/$layer.json"
    done
    pf=$(median "$work/etopo-picture.json" frame_times_ms)
    vf=$(median "$work/etopo-values.json" frame_times_ms)
    pc=$(median "$work/etopo-picture.json" frame_cpu_ms)
    vc=$(median "$work/etopo-values.json" frame_cpu_ms)
    python3 -c "import sys; pf,vf,pc,vc=map(float,sys.argv[3:]); print('| %s | %s | %.2f | %.2f | %.2fx | %.2f | %.2f | %.2fx |' % (sys.argv[1], sys.argv[2], pf, vf, vf/pf, pc, vc, vc/pc))" \
      "$view" "$r" "$pf" "$vf" "$pc" "$vc"
  done
done
