#!/usr/bin/env bash
# The dome's cost (issue #7): a domemaster frame (tellus render --dome, N x N, FOV 180, cube faces
# of 0.64 N) against flat frames of the same pixel density, the same view held and rendered
# settled (--repeat 2: the second pass, everything resident, gives each frame's cost without
# streaming), the configurations alternated in each round:
#   flat-face: 0.64N x 0.64N, 90-degree vertical FOV (one cube face: the dome's centre density,
#              N/pi px/rad, over a quarter of the dome's field);
#   flat-same: N x N, FOV 2 atan(pi/2) = 115.0 degrees (the dome's centre density, N/pi px/rad, in
#              an image of the dome's size).
# Mesa llvmpipe under Xvfb renders on the CPU: every figure is a CPU figure; read the ratios.
# Usage: bench/dome.sh [path/to/tellus]   (N=1024 ROUNDS=2 by default)
set -euo pipefail
tellus=${1:-build/tools/tellus/tellus}
n=${N:-1024}
rounds=${ROUNDS:-2}
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
    run "$v" dome --config "$work/fov90.yaml" --dome --size "$n"
    run "$v" flat-face --config "$work/fov90.yaml" --size "${face}x${face}"
    run "$v" flat-same --config "$work/fov115.yaml" --size "${n}x${n}"
  done
done >"$work/results.txt"
cat "$work/results.txt"
echo
echo "| view | dome ${n}x${n}: median frame ms per round | flat-face ${face}x${face} | flat-same ${n}x${n} | dome / flat-face per round (median) | dome / flat-same per round (median) | fastest frames: dome / flat-face, dome / flat-same | nodes drawn dome / face / same |"
echo "|---|---|---|---|---|---|---|---|"
python3 - "$work/results.txt" <<'PY'
import sys, collections
ms, fastest, nodes = collections.defaultdict(list), collections.defaultdict(list), {}
for line in open(sys.argv[1]):
    v, c, t, lo, n = line.split()
    ms[(v, c)].append(float(t)); fastest[(v, c)].append(float(lo)); nodes[(v, c)] = n
med = lambda x: sorted(x)[len(x) // 2]
for v in ("horizon", "down"):
    # Ratios within each round (the configurations side by side), then their median; and the
    # fastest frame of each configuration over all rounds (the least disturbed by other load).
    d, f, s = ms[(v, "dome")], ms[(v, "flat-face")], ms[(v, "flat-same")]
    rf = [a / b for a, b in zip(d, f)]; rs = [a / b for a, b in zip(d, s)]
    lo = lambda c: min(fastest[(v, c)])
    print("| %s | %s | %s | %s | %s (**%.2f**) | %s (**%.2f**) | %.2f, %.2f | %s / %s / %s |" % (
        v, " / ".join("%.1f" % x for x in d), " / ".join("%.1f" % x for x in f),
        " / ".join("%.1f" % x for x in s), " / ".join("%.2f" % x for x in rf), med(rf),
        " / ".join("%.2f" % x for x in rs), med(rs), lo("dome") / lo("flat-face"),
        lo("dome") / lo("flat-same"), nodes[(v, "dome")], nodes[(v, "flat-face")],
        nodes[(v, "flat-same")]))
PY
