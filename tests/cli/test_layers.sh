#!/usr/bin/env bash
# Layers in `tellus render` as a user configures them (issue #7; label gl: needs an X display):
# an overlay with its own transparency at an opacity (renderer.layers and --overlay), a regional
# dataset inside the base layer (the smallest covering dataset wins), the layers in --stats, a
# flight whose keyframes name layer times, and the errors of a bad layer setting.
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd)
data=$(cd "$here/../../data" && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-layers.XXXXXX")
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
pixel() { python3 "$here/png_pixels.py" "$@"; }
# near R G B WANT_R WANT_G WANT_B TOLERANCE
near() { python3 -c "import sys; v=list(map(int,sys.argv[1:7])); t=int(sys.argv[7]); sys.exit(0 if all(abs(a-b)<=t for a,b in zip(v[:3],v[3:])) else 1)" "$@"; }

# Inputs: a red band from 30 to 60 degrees north (opaque there, transparent elsewhere, one degree
# a pixel), and a green regional image over 0-18 E, 36-54 N (0.05 degrees a pixel).
PYTHONPATH="$here" python3 - "$work" <<'PY'
import sys
from png_pixels import write
d = sys.argv[1]
values = []
for y in range(180):
    lat = 89.5 - y
    values += ([255, 0, 0, 255] if 30 <= lat <= 60 else [0, 0, 0, 0]) * 360
write(d + "/band.png", 360, 180, values, True)
open(d + "/band.pgw", "w").write("1\n0\n0\n-1\n-179.5\n89.5\n")
write(d + "/alps.png", 360, 360, [0, 200, 0] * (360 * 360), False)
open(d + "/alps.pgw", "w").write("0.05\n0\n0\n-0.05\n0.025\n53.975\n")
PY
cat >"$work/layers.yaml" <<YAML
data_dir: $data
cache: {root: $work/cache}
upstreams:
  - {name: local, type: local, path: bmng_2048x1024.jpg}
  - {name: band, type: local, path: $work/band.png}
  - {name: alps, type: local, path: $work/alps.png}
layers:
  - name: bluemarble
    upstream: local
    format: image/jpeg
    grid: {level_zero_delta: 36, tile_size: 512, levels: 3}
  - name: alps
    upstream: alps
    format: image/png
    grid: {level_zero_delta: 36, tile_size: 512, levels: 6, sector: [0, 36, 18, 54]}
  - name: band
    upstream: band
    format: image/png
    grid: {level_zero_delta: 36, tile_size: 512, levels: 2}
renderer:
  layers:
    - layer: bluemarble
      regional: [alps]
    - layer: band
      opacity: 0.5
YAML

# Over the regional dataset, inside the band: green under half red.
"$tellus" render --no-sun --no-atmosphere --config "$work/layers.yaml" --camera 45,9,8e5 --size 160x120 \
  --out "$work/alps.png" --wait-complete --stats "$work/alps.json" >/dev/null || fail "render"
read -r r g b < <(pixel "$work/alps.png" 80 60)
near "$r" "$g" "$b" 128 100 0 4 || fail "regional green under half red: $r $g $b"
python3 - "$work/alps.json" <<'PY' || fail "the layers in --stats"
import json, sys
s = json.load(open(sys.argv[1]))
assert s["complete"] is True, s
names = [l["name"] for l in s["layers"]]
assert names == ["bluemarble", "band"], names
band = s["layers"][1]
assert band["opacity"] == 0.5 and band["visible"] is True and band["tiles_received"] > 0, band
assert s["passes"] == 1 and s["overlays_per_pass"] >= 1, s
PY

# Outside the regional dataset and south of the band: the Blue Marble alone. The same view
# without the overlay (--config with no renderer.layers, then --overlay band,1): opaque red.
"$tellus" render --no-sun --no-atmosphere --config "$work/layers.yaml" --camera 10,-30,8e5 --size 160x120 \
  --out "$work/ocean.png" --wait-complete >/dev/null || fail "render outside"
read -r r g b < <(pixel "$work/ocean.png" 80 60)
[ "$b" -gt "$r" ] || fail "the Atlantic under no overlay should be blue: $r $g $b"
sed '/^renderer:/,$d' "$work/layers.yaml" >"$work/plain.yaml"
"$tellus" render --no-sun --no-atmosphere --config "$work/plain.yaml" --overlay band,1 --camera 45,-100,8e5 \
  --size 160x120 --out "$work/red.png" --wait-complete >/dev/null || fail "--overlay"
read -r r g b < <(pixel "$work/red.png" 80 60)
near "$r" "$g" "$b" 255 0 0 2 || fail "--overlay band,1 should be opaque red: $r $g $b"

# Regional heights (renderer.terrain.regional): a flat 1234 m DEM over 0-18 E, 36-54 N inside the
# bundled ETOPO; `tellus height` reads the regional one inside it and ETOPO outside.
gdal_create -q -of GTiff -ot Int16 -outsize 180 180 -bands 1 -burn 1234 -a_srs EPSG:4326 \
  -a_ullr 0 54 18 36 -co TFW=YES "$work/dem.tif" || fail "gdal_create"
cat >"$work/heights.yaml" <<YAML
data_dir: $data
cache: {root: $work/hcache}
upstreams:
  - {name: local, type: local, path: bmng_2048x1024.jpg}
  - {name: etopo, type: local, path: etopo20_int16.tif}
  - {name: dem, type: local, path: $work/dem.tif}
layers:
  - {name: bluemarble, upstream: local, format: image/jpeg, grid: {levels: 3}}
  - name: etopo
    upstream: etopo
    format: application/bil16
    grid: {level_zero_delta: 20, tile_size: 150, levels: 3}
  - name: dem
    upstream: dem
    format: application/bil16
    grid: {level_zero_delta: 20, tile_size: 150, levels: 6, sector: [0, 36, 18, 54]}
renderer:
  terrain: {layer: etopo, regional: [dem]}
YAML
[ "$("$tellus" height --config "$work/heights.yaml" --lat 45 --lon 9 2>/dev/null)" = 1234.00 ] ||
  fail "regional height: $("$tellus" height --config "$work/heights.yaml" --lat 45 --lon 9 2>&1)"
outside=$("$tellus" height --config "$work/heights.yaml" --lat 45 --lon 30 2>/dev/null)
etopo=$(sed '/^renderer:/,$d' "$work/heights.yaml" >"$work/etopo.yaml" &&
  "$tellus" height --config "$work/etopo.yaml" --lat 45 --lon 30 2>/dev/null)
[ "$outside" = "$etopo" ] || fail "outside the regional DEM: $outside, ETOPO alone: $etopo"

# A flight whose keyframes switch the overlay's time (a layer with a TIME dimension): every frame
# is complete, and the layer ends at the last time named.
sed 's|    grid: {level_zero_delta: 36, tile_size: 512, levels: 2}|&\n    time: {values: [2020-01-01, 2020-02-01]}|' \
  "$work/layers.yaml" >"$work/timed.yaml"
cat >"$work/timed.json" <<'JSON'
[{"time": 0, "lat": 45, "lon": 9, "alt": 8e5, "times": {"band": "2020-01-01"}},
 {"time": 0.04, "lat": 45, "lon": 9, "alt": 8e5, "times": {"band": "2020-02-01"}},
 {"time": 0.08, "lat": 45, "lon": 9, "alt": 8e5}]
JSON
"$tellus" render --no-sun --no-atmosphere --config "$work/timed.yaml" --path "$work/timed.json" --frames "$work/frames" \
  --size 64x48 --wait-complete --stats "$work/timed-stats.json" >"$work/timed.txt" ||
  fail "timed flight: $(cat "$work/timed.txt")"
grep -q "every frame complete" "$work/timed.txt" || fail "$(cat "$work/timed.txt")"
[ -f "$work/frames/frame_00002.png" ] || fail "three frames expected: $(ls "$work/frames")"
python3 - "$work/timed-stats.json" <<'PY' || fail "the layer's time after the flight"
import json, sys
band = json.load(open(sys.argv[1]))["layers"][1]
assert band["time"] == "2020-02-01" and band["pending_time"] == "" and band["swaps"] >= 2, band
PY

# A flight whose keyframes name a layer's time: a name that is not drawn is a usage error.
cat >"$work/path.json" <<'JSON'
[{"time": 0, "lat": 45, "lon": 9, "alt": 8e5, "times": {"nope": "2020-01-01"}},
 {"time": 0.04, "lat": 45, "lon": 9, "alt": 8e5}]
JSON
set +e
"$tellus" render --no-sun --no-atmosphere --config "$work/layers.yaml" --path "$work/path.json" --frames "$work/f" \
  --size 64x48 >"$work/bad.txt" 2>&1
code=$?
set -e
[ "$code" = 2 ] || fail "a time for a layer not drawn: exit $code: $(cat "$work/bad.txt")"
grep -q "not drawn" "$work/bad.txt" || fail "$(cat "$work/bad.txt")"

# Bad settings are refused with the reason.
set +e
"$tellus" render --no-sun --no-atmosphere --config "$work/plain.yaml" --overlay band,1.5 --camera 0,0,1e7 \
  --out "$work/x.png" >"$work/bad.txt" 2>&1
code=$?
set -e
[ "$code" = 2 ] && grep -q "OPACITY in \[0, 1\]" "$work/bad.txt" || fail "opacity 1.5: $code $(cat "$work/bad.txt")"
sed 's/regional: \[alps\]/regional: [band, alps]/; s/tile_size: 512, levels: 2}/tile_size: 256, levels: 2}/' \
  "$work/layers.yaml" >"$work/badgrid.yaml"
set +e
"$tellus" render --no-sun --no-atmosphere --config "$work/badgrid.yaml" --camera 0,0,1e7 --out "$work/x.png" \
  >"$work/bad.txt" 2>&1
code=$?
set -e
[ "$code" != 0 ] && grep -q "another grid" "$work/bad.txt" || fail "regional on another grid: $code $(cat "$work/bad.txt")"
echo "layers: ok"
