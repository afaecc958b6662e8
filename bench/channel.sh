#!/usr/bin/env bash
# A projector channel's frame (issue 28) against flat frames of the same resolution: `tellus render
# --channel CONFIG.json,NAME` (the channel's frustum turned off the camera's pose as `tellus
# cluster` draws it) and `tellus render --size` of the channel's size, the same pose held and
# rendered settled (--repeat 2: the second pass, everything resident, gives each frame's cost
# without streaming), the configurations alternated in each round:
#   north:      the test dome's north channel, 110 x 90 degrees at elevation 20, W x H;
#   flat-same:  W x H, vertical FOV 90 (the channel's field and pixels, along the camera's axis);
#   flat-45:    W x H at the default vertical FOV of 45 degrees;
#   zenith:     the zenith channel, 100 x 100 degrees, H x H, and flat-zenith: H x H at FOV 100.
# Mesa llvmpipe under Xvfb renders on the CPU: every figure is a CPU figure; read the ratios.
# Usage: bench/channel.sh [path/to/tellus]   (W=1024 ROUNDS=3 by default; H = W tan 45 / tan 55)
set -euo pipefail
tellus=${1:-build/tools/tellus/tellus}
w=${W:-1024}
rounds=${ROUNDS:-3}
h=$(python3 -c "import math; print(round($w * math.tan(math.radians(45)) / math.tan(math.radians(55))))")
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-channel-bench.XXXXXX")
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
for f in 45 90 100; do config $f >"$work/fov$f.yaml"; done
cat >"$work/dome.json" <<JSON
{"channels": [
  {"name": "north", "azimuth": 0, "elevation": 20, "hfov": 110, "vfov": 90, "width": $w, "height": $h},
  {"name": "zenith", "azimuth": 0, "elevation": 90, "hfov": 100, "vfov": 100, "width": $h, "height": $h}]}
JSON
view() { # a pose held for 2 s at 10 fps
  printf '[{"time": 0, "lat": %s, "lon": %s, "alt": %s, "heading": %s, "tilt": %s},\n' "$@"
  printf ' {"time": 2, "lat": %s, "lon": %s, "alt": %s, "heading": %s, "tilt": %s}]\n' "$@"
}
view 45 7 3e5 0 0 >"$work/down.json"        # the cluster test's: 300 km over the Alps, axis down
view 45.5 7.5 5e5 0 60 >"$work/tilted.json" # 500 km up, the dome's axis 60 degrees off the nadir
run() { # view, configuration name, arguments...
  local v=$1 name=$2
  shift 2
  xvfb-run -a -s '-screen 0 1280x1024x24' "$tellus" render --path "$work/$v.json" \
    --frames "$work/frames" --fps 10 --repeat 2 --no-sun --no-atmosphere --stats "$work/s.json" \
    "$@" >/dev/null
  python3 - "$v" "$name" "$work/s.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[3]))
t = sorted(s["frame_times_ms"][len(s["frame_times_ms"]) // 2:])  # the settled second pass
print("%s %s %.2f %d" % (sys.argv[1], sys.argv[2], t[len(t) // 2], s["nodes_drawn"]))
PY
}
for v in down tilted; do run "$v" warm --config "$work/fov90.yaml" --size "${w}x${h}" >/dev/null; done
for r in $(seq "$rounds"); do
  for v in down tilted; do
    run "$v" north --config "$work/fov90.yaml" --channel "$work/dome.json,north"
    run "$v" flat-same --config "$work/fov90.yaml" --size "${w}x${h}"
    run "$v" flat-45 --config "$work/fov45.yaml" --size "${w}x${h}"
    run "$v" zenith --config "$work/fov90.yaml" --channel "$work/dome.json,zenith"
    run "$v" flat-zenith --config "$work/fov100.yaml" --size "${h}x${h}"
  done
done >"$work/results.txt"
cat "$work/results.txt"
echo
echo "| view | north ${w}x${h}: median frame ms per round | flat-same | flat-45 | north / flat-same (median) | north / flat-45 (median) | zenith ${h}x${h} | flat-zenith | zenith / flat-zenith (median) | nodes drawn north / same / 45 / zenith / flat-zenith |"
echo "|---|---|---|---|---|---|---|---|---|---|"
python3 - "$work/results.txt" <<'PY'
import sys, collections
ms, nodes = collections.defaultdict(list), {}
for line in open(sys.argv[1]):
    v, c, t, n = line.split()
    ms[(v, c)].append(float(t)); nodes[(v, c)] = n
med = lambda x: sorted(x)[len(x) // 2]
fmt = lambda x: " / ".join("%.1f" % y for y in x)
ratio = lambda a, b: [x / y for x, y in zip(a, b)]
for v in ("down", "tilted"):
    n, s, f, z, fz = (ms[(v, k)] for k in ("north", "flat-same", "flat-45", "zenith", "flat-zenith"))
    a, b, c = ratio(n, s), ratio(n, f), ratio(z, fz)
    print("| %s | %s | %s | %s | %s (**%.2f**) | %s (**%.2f**) | %s | %s | %s (**%.2f**) | %s |" % (
        v, fmt(n), fmt(s), fmt(f), " / ".join("%.2f" % x for x in a), med(a),
        " / ".join("%.2f" % x for x in b), med(b), fmt(z), fmt(fz),
        " / ".join("%.2f" % x for x in c), med(c),
        " / ".join(nodes[(v, k)] for k in ("north", "flat-same", "flat-45", "zenith", "flat-zenith"))))
PY
