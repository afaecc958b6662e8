#!/usr/bin/env bash
# Other bodies on the command line (issue 26): `tellus height --body moon` reads the Moon's
# elevation layer (a flat 1500 m local raster) and not the Earth's; unknown bodies and a body
# without heights are refused; with `render` (needs a display): the Moon and Mars of the embedded
# default against their bundled maps at known coordinates, a configured Moon imagery layer drawn,
# and an Earth layer refused for the Moon.
# Usage: test_bodies.sh TELLUS height|render
set -euo pipefail
tellus=$1
mode=$2
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
data=$(cd "$here/../../data" && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-bodies.XXXXXX")
trap '[ -n "${KEEP:-}" ] || rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
pixel() { python3 "$here/png_pixels.py" "$@"; }

# A grey Moon map (one degree a pixel) and the Moon's flat 1500 m heights.
PYTHONPATH="$here" python3 - "$work" <<'PY'
import sys
from png_pixels import write
d = sys.argv[1]
write(d + "/moon.png", 360, 180, [170, 170, 170] * (360 * 180), False)
open(d + "/moon.pgw", "w").write("1\n0\n0\n-1\n-179.5\n89.5\n")
PY
gdal_create -q -of GTiff -ot Int16 -outsize 360 180 -bands 1 -burn 1500 -a_srs EPSG:4326 \
  -a_ullr -180 90 180 -90 -co TFW=YES "$work/moonheights.tif" || fail "gdal_create"
cat >"$work/bodies.yaml" <<YAML
data_dir: $data
cache: {root: $work/cache}
upstreams:
  - {name: local, type: local, path: bmng_2048x1024.jpg}
  - {name: etopo, type: local, path: etopo20_int16.tif}
  - {name: moonmap, type: local, path: $work/moon.png}
  - {name: moondem, type: local, path: $work/moonheights.tif}
layers:
  - {name: bluemarble, upstream: local, format: image/jpeg, grid: {levels: 3}}
  - name: etopo
    upstream: etopo
    format: application/bil16
    grid: {level_zero_delta: 20, tile_size: 150, levels: 3}
  - {name: moon, upstream: moonmap, body: moon, format: image/png, grid: {levels: 2}}
  - name: moonheights
    upstream: moondem
    body: moon
    format: application/bil16
    grid: {level_zero_delta: 20, tile_size: 150, levels: 2}
YAML

if [ "$mode" = height ]; then
  got=$("$tellus" height --config "$work/bodies.yaml" --body moon --lat 10 --lon -170 2>"$work/err") ||
    fail "height --body moon: $(cat "$work/err")"
  [ "$got" = 1500.00 ] || fail "height --body moon: $got, want 1500.00 ($(cat "$work/err"))"
  grep -q "moonheights" "$work/err" || fail "height --body moon used $(cat "$work/err")"
  # The Moon has no sea: its heights are above its own sphere, and the message says so.
  grep -q "above the reference surface of moon" "$work/err" && ! grep -q "sea level" "$work/err" ||
    fail "height --body moon says: $(cat "$work/err")"
  # The poles and the 180-degree meridian.
  for p in "90 0" "-90 0" "90 180" "-90 -180" "10 180" "-10 -180"; do
    read -r lat lon <<<"$p"
    got=$("$tellus" height --config "$work/bodies.yaml" --body moon --lat $lat --lon $lon 2>/dev/null)
    [ "$got" = 1500.00 ] || fail "height --body moon at $lat, $lon: $got"
  done
  earth=$("$tellus" height --config "$work/bodies.yaml" --lat 10 --lon -170 2>"$work/err") ||
    fail "height on the Earth: $(cat "$work/err")"
  [ "$earth" != 1500.00 ] || fail "the Earth's height came from the Moon's layer"
  rc=0
  "$tellus" height --config "$work/bodies.yaml" --body pluto --lat 0 --lon 0 2>"$work/err" || rc=$?
  [ "$rc" = 2 ] || fail "--body pluto: exit $rc, want 2"
  grep -q "no body\|must name a body" "$work/err" || fail "--body pluto said: $(cat "$work/err")"
  rc=0
  "$tellus" height --config "$work/bodies.yaml" --body mars --lat 0 --lon 0 2>"$work/err" || rc=$?
  [ "$rc" = 1 ] || fail "--body mars (no heights): exit $rc, want 1"
  grep -q "no elevation layer" "$work/err" || fail "--body mars said: $(cat "$work/err")"
  echo "ok: height --body"
  exit 0
fi

# render on the embedded default: the bundled Moon and Mars maps (data/README.md), unlit and
# without air, straight down at known places (maria, highlands, Hellas, Syrtis Major, Tharsis):
# the image's centre is the map's colour there, the mean of its 3x3 pixels around the place read
# by GDAL from the bundled file and its world file, within what the tiles' resampling and JPEG
# coding leave (24 levels); then no air around the Moon.
mapcolour() { # map lat lon step: the mean R G B of the map's 3x3 samples around the place
  python3 - "$@" <<'PY'
import subprocess, sys
m, lat, lon, st = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
s = [0, 0, 0]
for dy in (-1, 0, 1):
    for dx in (-1, 0, 1):
        out = subprocess.run(["gdallocationinfo", "-valonly", "-geoloc", m, str(lon + dx * st),
                              str(lat + dy * st)], capture_output=True, text=True, check=True)
        s = [a + int(v) for a, v in zip(s, out.stdout.split())]
print(" ".join(str(round(v / 9)) for v in s))
PY
}
for p in "moon 17 59" "moon -30 10" "moon 0 0" "mars -42 70" "mars 8.4 69.5" "mars 20 -110"; do
  read -r body lat lon <<<"$p"
  map=$data/moon_2048x1024.jpg step=0.176
  [ "$body" = mars ] && map=$data/mars_512x256.jpg step=0.703
  "$tellus" render --body "$body" --cache "$work/c2" --camera "$lat,$lon,3e5" \
    --size 32x32 --no-stars --no-sun --no-atmosphere --wait-complete --out "$work/shot-$body.png" \
    2>"$work/err" || fail "render --body $body: $(cat "$work/err")"
  read -r r g b < <(pixel "$work/shot-$body.png" 16 16)
  read -r -a want < <(mapcolour "$map" "$lat" "$lon" "$step")
  for got in "$r ${want[0]}" "$g ${want[1]}" "$b ${want[2]}"; do
    read -r x y <<<"$got"
    d=$((x - y))
    [ "${d#-}" -le 24 ] || fail "$body at $lat, $lon: rendered $r $g $b, the map has ${want[*]}"
  done
done
"$tellus" render --body moon --offline --cache "$work/c1" --camera 0,0,4e6 --size 128x128 \
  --no-stars --out "$work/bare.png" 2>"$work/err" || fail "render --body moon: $(cat "$work/err")"
read -r r g b < <(pixel "$work/bare.png" 2 2)
[ "$((r + g + b))" = 0 ] || fail "the sky around the Moon is $r $g $b, want black (no air)"
# The configured Moon map, unlit: grey, and the disc the Moon's size (98 px radius for 256 px:
# asin(1737.4 / 5737.4) is 17.6 degrees, tan(17.6) / tan(22.5) x 128; the Earth's radius would fill
# the frame).
"$tellus" render --config "$work/bodies.yaml" --body moon --no-sun --no-stars --camera 0,0,4e6 \
  --wait-complete --size 256x256 --out "$work/moon.png" 2>"$work/err" || fail "render moon map: $(cat "$work/err")"
read -r r g b < <(pixel "$work/moon.png" 128 128)
[ "$r" -ge 160 ] && [ "$r" -le 180 ] || fail "the Moon's map at the centre: $r $g $b, want 170"
read -r r g b < <(pixel "$work/moon.png" $((128 + 104)) 128)
[ "$r" = 0 ] || fail "beyond the Moon's limb: $r $g $b, want black"
read -r r g b < <(pixel "$work/moon.png" $((128 + 92)) 128)
[ "$r" -ge 160 ] || fail "inside the Moon's limb: $r $g $b, want grey"
rc=0
"$tellus" render --config "$work/bodies.yaml" --body moon --layer bluemarble --camera 0,0,4e6 \
  --out "$work/x.png" 2>"$work/err" || rc=$?
[ "$rc" = 2 ] && grep -q "lies on the earth" "$work/err" ||
  fail "an Earth layer on the Moon: exit $rc, $(cat "$work/err")"
echo "ok: render --body"
