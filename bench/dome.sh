#!/usr/bin/env bash
# The dome's cost (issue #7): a domemaster frame (tellus render --dome, N x N, FOV 180) drawn by
# each method against flat frames of the same pixel density, the same view held and rendered
# settled (--repeat 2: the second pass, everything resident, gives each frame's cost without
# streaming), the configurations alternated in each round:
#   direct:    --dome-method direct (one pass through the fisheye map in the node shader);
#   cube:      --dome-method cube (five cube faces of 0.64 N, then the warp);
#   flat-face: 0.64N x 0.64N, 90-degree vertical FOV (one cube face: the dome's centre density,
#              N/pi px/rad, over a quarter of the dome's field);
#   flat-same: N x N, FOV 2 atan(pi/2) = 115.0 degrees (the dome's centre density, N/pi px/rad, in
#              an image of the dome's size).
# Mesa llvmpipe under Xvfb renders on the CPU: every figure is a CPU figure; read the ratios.
# Then the two methods' images of each view (--wait-complete) and their PSNR inside the circle.
# Usage: bench/dome.sh [path/to/tellus]   (N=1024 ROUNDS=3 by default)
set -euo pipefail
tellus=${1:-build/tools/tellus/tellus}
n=${N:-1024}
rounds=${ROUNDS:-3}
face=$(python3 -c "print(round(0.64 * $n))")
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-dome-bench.XXXXXX")
trap 'rm -rf "$work"' EXIT
data=$(cd "$(dirname "$0")/../data" && pwd)
config() { # the embedded default's imagery and terrain, a vertical FOV
  cat <<YAML
cache: {root: $work/cache}
data_dir: $data
renderer: {fov: $1}
upstreams:
  - {name: local, type: local, path: bmng_2048x1024.jpg}
  - {name: local-etopo, type: local, path: etopo20_int16.tif}
layers:
  - name: bluemarble
    upstream: local
    format: image/jpeg
    grid: {level_zero_delta: 36, tile_size: 512, levels: 3}
  - name: etopo
    upstream: local-etopo
    format: application/bil16
    grid: {level_zero_delta: 20, tile_size: 150, levels: 3}
    elevation: {encoding: bil16, scale: 1.0, offset: 0.0, no_data: -32768}
YAML
}
config 90 >"$work/fov90.yaml"
config 115.0 >"$work/fov115.yaml"
view() { # a pose held for 2 s at 10 fps
  printf '[{"time": 0, "lat": %s, "lon": %s, "alt": %s, "heading": %s, "tilt": %s},\n' "$@"
  printf ' {"time": 2, "lat": %s, "lon": %s, "alt": %s, "heading": %s, "tilt": %s}]\n' "$@"
}
view 45.5 7.5 5e5 0 90 >"$work/horizon.json"   # the Alps' horizon from 500 km, looking north
view 20 10 2e6 0 0 >"$work/down.json"          # straight down from 2,000 km
run() { # view, configuration name, arguments...
  local v=$1 name=$2
  shift 2
  xvfb-run -a -s '-screen 0 1280x1024x24' "$tellus" render --path "$work/$v.json" \
    --frames "$work/frames" --fps 10 --repeat 2 --stats "$work/s.json" "$@" >/dev/null
  python3 - "$v" "$name" "$work/s.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[3]))
t = s["frame_times_ms"][len(s["frame_times_ms"]) // 2:]  # the settled second pass
t.sort()
print("%s %s %.2f %.2f %d" % (sys.argv[1], sys.argv[2], t[len(t) // 2], t[0], s["nodes_drawn"]))
PY
}
for v in horizon down; do # warm the cache
  run "$v" warm --config "$work/fov90.yaml" --size "${face}x${face}" >/dev/null
done
for r in $(seq "$rounds"); do
  for v in horizon down; do
    run "$v" direct --config "$work/fov90.yaml" --dome --dome-method direct --size "$n"
    run "$v" cube --config "$work/fov90.yaml" --dome --dome-method cube --size "$n"
    run "$v" flat-face --config "$work/fov90.yaml" --size "${face}x${face}"
    run "$v" flat-same --config "$work/fov115.yaml" --size "${n}x${n}"
  done
done >"$work/results.txt"
cat "$work/results.txt"
echo
echo "| view | direct ${n}x${n}: median frame ms per round | cube ${n}x${n} | flat-face ${face}x${face} | flat-same ${n}x${n} | direct / flat-same per round (median) | cube / flat-same per round (median) | direct / cube per round (median) | direct / flat-face, cube / flat-face (medians) | nodes drawn direct / cube / face / same |"
echo "|---|---|---|---|---|---|---|---|---|---|"
python3 - "$work/results.txt" <<'PY'
import sys, collections
ms, nodes = collections.defaultdict(list), {}
for line in open(sys.argv[1]):
    v, c, t, lo, n = line.split()
    ms[(v, c)].append(float(t)); nodes[(v, c)] = n
med = lambda x: sorted(x)[len(x) // 2]
fmt = lambda x: " / ".join("%.1f" % y for y in x)
for v in ("horizon", "down"):
    # Ratios within each round (the configurations side by side), then their median.
    d, c, f, s = (ms[(v, k)] for k in ("direct", "cube", "flat-face", "flat-same"))
    ratio = lambda a, b: [x / y for x, y in zip(a, b)]
    rds, rcs, rdc = ratio(d, s), ratio(c, s), ratio(d, c)
    print("| %s | %s | %s | %s | %s | %s (**%.2f**) | %s (**%.2f**) | %s (**%.2f**) | %.2f, %.2f | %s / %s / %s / %s |" % (
        v, fmt(d), fmt(c), fmt(f), fmt(s),
        " / ".join("%.2f" % x for x in rds), med(rds),
        " / ".join("%.2f" % x for x in rcs), med(rcs),
        " / ".join("%.2f" % x for x in rdc), med(rdc),
        med(ratio(d, f)), med(ratio(c, f)),
        nodes[(v, "direct")], nodes[(v, "cube")], nodes[(v, "flat-face")], nodes[(v, "flat-same")]))
PY
# The images: each view by both methods, complete, and their PSNR inside the circle.
echo
here=$(cd "$(dirname "$0")/../tests/cli" && pwd) # png_pixels.py
camera() { python3 -c "import json; k = json.load(open('$work/$1.json'))[0]; print(','.join(str(k[x]) for x in ('lat', 'lon', 'alt', 'heading', 'tilt')))"; }
for v in horizon down; do
  for m in direct cube; do
    xvfb-run -a -s '-screen 0 1280x1024x24' "$tellus" render --config "$work/fov90.yaml" --dome \
      --dome-method "$m" --size "$n" --camera "$(camera "$v")" --wait-complete \
      --out "$work/$v-$m.png" --stats "$work/$v-$m.json" >/dev/null
  done
  PYTHONPATH="$here" python3 - "$work/$v-direct.png" "$work/$v-cube.png" "$work/$v-direct.json" "$v" <<'PY'
import json, math, sys
from png_pixels import pixels
w, h, a, n = pixels(sys.argv[1])
_, _, b, _ = pixels(sys.argv[2])
se, count, worst = 0, 0, 0
for y in range(h):
    for x in range(w):
        if math.hypot(x + 0.5 - w / 2, y + 0.5 - h / 2) > w / 2:
            continue
        for c in range(3):
            d = a[y][n * x + c] - b[y][n * x + c]
            se += d * d; count += 1; worst = max(worst, abs(d))
s = json.load(open(sys.argv[3]))
psnr = 10 * math.log10(255 ** 2 / (se / count)) if se else float("inf")
print("%s: direct vs cube PSNR %.2f dB inside the circle, max difference %d; direct: %s, estimated edge error %s px" % (
    sys.argv[4], psnr, worst, s["dome_method"], s["dome_error_px"]))
PY
done
if [ -n "${KEEP:-}" ]; then mkdir -p "$KEEP" && cp "$work"/*-direct.png "$work"/*-cube.png "$KEEP"/; fi
