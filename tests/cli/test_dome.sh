#!/usr/bin/env bash
# `tellus render --dome` end to end (issue #7; label gl: run under xvfb-run): a square domemaster,
# black outside the circle, --dome FOV and --dome-tilt, --dome-method direct and cube (the same
# picture within a PSNR bound; direct is the default), renderer.dome of a configuration, a --path
# flight as numbered complete domemasters, and usage errors (exit 2).
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd) # png_pixels.py
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-dome.XXXXXX")
trap 'rm -rf "$work"' EXIT
cache="$work/cache"
fail() { echo "FAIL: $*" >&2; exit 1; }

# PNG size, and whether the corners are black and the centre is not (python: zlib only).
check() {
  PYTHONPATH="$here" python3 - "$1" "$2" <<'PY' || fail "domemaster $1"
import sys
from png_pixels import pixels
w, h, rows, _ = pixels(sys.argv[1])
assert f"{w}x{h}" == sys.argv[2], (w, h)
px = lambda x, y: tuple(rows[y][3 * x:3 * x + 3])
for x, y in ((0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)):
    assert px(x, y) == (0, 0, 0), (x, y, px(x, y))
assert px(w // 2, h // 2) != (0, 0, 0)
# Outside the circle (pixel centres beyond N/2 of the centre): black.
for y in range(h):
    for x in range(w):
        if ((x + 0.5 - w / 2) ** 2 + (y + 0.5 - h / 2) ** 2) ** 0.5 > w / 2:
            assert px(x, y) == (0, 0, 0), (x, y)
PY
}

# --no-stars here and in the methods' comparison below: the cube method resamples the stars'
# footprints (which the PSNR bound was not set for; tests/planet/TestStarsGl.cpp checks them).
out=$("$tellus" render --no-sun --no-atmosphere --cache "$cache" --dome --size 96 --camera 45,7,5e5,0,90 --no-stars \
      --background 40,60,120 --out "$work/d.png" --wait-complete --stats "$work/d.json")
echo "$out" | grep -q "96x96, complete" || fail "dome: $out"
check "$work/d.png" 96x96
# The FOV as the value after --dome, and a tilt: another image.
"$tellus" render --no-sun --no-atmosphere --cache "$cache" --dome 220 --dome-tilt 30 --size 96x96 --camera 45,7,5e5,0,60 \
  --background 40,60,120 --out "$work/e.png" --wait-complete >/dev/null || fail "--dome 220 --dome-tilt 30"
check "$work/e.png" 96x96
cmp -s "$work/d.png" "$work/e.png" && fail "--dome 220 --dome-tilt 30 drew the same image"
# The two methods: --dome-method direct is the default (the same bytes), cube draws the same
# picture (PSNR inside the circle over 30 dB: 96 px of Blue Marble, the cube's faces resampled),
# and --stats says which method drew the last frame.
for m in direct cube; do
  "$tellus" render --no-sun --no-atmosphere --cache "$cache" --dome --dome-method "$m" --size 96 --camera 45,7,5e5,0,90 \
    --no-stars --background 40,60,120 --out "$work/m-$m.png" --wait-complete --stats "$work/m-$m.json" >/dev/null ||
    fail "--dome-method $m"
  check "$work/m-$m.png" 96x96
  grep -q "\"dome_method\": \"$m\"" "$work/m-$m.json" || fail "--dome-method $m: $(grep dome_ "$work/m-$m.json")"
done
cmp -s "$work/d.png" "$work/m-direct.png" || fail "the default method is not direct"
PYTHONPATH="$here" python3 - "$work/m-direct.png" "$work/m-cube.png" <<'PY' || fail "direct and cube differ"
import math, sys
from png_pixels import pixels
w, h, a, n = pixels(sys.argv[1])
_, _, b, _ = pixels(sys.argv[2])
se, count = 0, 0
for y in range(h):
    for x in range(w):
        if math.hypot(x + 0.5 - w / 2, y + 0.5 - h / 2) <= w / 2:
            for c in range(3):
                se += (a[y][n * x + c] - b[y][n * x + c]) ** 2
                count += 1
psnr = 10 * math.log10(255 ** 2 / (se / count)) if se else 99
assert psnr > 30, psnr
PY
# renderer.dome of a configuration: the dome without --dome (the configuration's FOV and tilt).
data=$(cd "$(dirname "$0")/../../data" && pwd)
base() {
  cat <<YAML
cache: {root: $cache}
data_dir: $data
upstreams:
  - {name: local, type: local, path: bmng_2048x1024.jpg}
layers:
  - name: bluemarble
    upstream: local
    format: image/jpeg
    grid: {level_zero_delta: 36, tile_size: 512, levels: 3}
YAML
}
base >"$work/base.yaml"
{ base; printf 'renderer:\n  dome: {enabled: true, fov: 220, tilt: 30}\n'; } >"$work/dome.yaml"
"$tellus" render --no-sun --no-atmosphere --config "$work/base.yaml" --dome 220 --dome-tilt 30 --size 96 \
  --camera 45,7,5e5,0,60 --background 40,60,120 --out "$work/e2.png" --wait-complete >/dev/null 2>"$work/err.txt" ||
  fail "--config base.yaml --dome: $(cat "$work/err.txt")"
"$tellus" render --no-sun --no-atmosphere --config "$work/dome.yaml" --size 96x96 --camera 45,7,5e5,0,60 --background 40,60,120 \
  --out "$work/f.png" --wait-complete >/dev/null 2>"$work/err.txt" ||
  fail "renderer.dome: $(cat "$work/err.txt")"
check "$work/f.png" 96x96
cmp -s "$work/e2.png" "$work/f.png" || fail "renderer.dome did not draw what --dome 220 --dome-tilt 30 draws"
# renderer.dome.method: cube draws what --dome-method cube draws.
{ base; printf 'renderer:\n  dome: {method: cube}\n'; } >"$work/cube.yaml"
"$tellus" render --no-sun --no-atmosphere --config "$work/cube.yaml" --dome --size 96 --camera 45,7,5e5,0,90 --background 40,60,120 \
  --out "$work/g.png" --wait-complete >/dev/null 2>"$work/err.txt" || fail "renderer.dome.method: $(cat "$work/err.txt")"
"$tellus" render --no-sun --no-atmosphere --config "$work/base.yaml" --dome --dome-method cube --size 96 --camera 45,7,5e5,0,90 \
  --background 40,60,120 --out "$work/g2.png" --wait-complete >/dev/null 2>"$work/err.txt" ||
  fail "--config base.yaml --dome-method cube: $(cat "$work/err.txt")"
cmp -s "$work/g.png" "$work/g2.png" || fail "renderer.dome.method: cube did not draw what --dome-method cube draws"

# A flight: numbered domemasters, each complete.
cat >"$work/path.json" <<'JSON'
[{"time": 0, "lat": 45, "lon": 7, "alt": 8e5, "heading": 0, "tilt": 90},
 {"time": 1, "lat": 46, "lon": 8, "alt": 4e5, "heading": 30, "tilt": 80}]
JSON
out=$("$tellus" render --no-sun --no-atmosphere --cache "$cache" --dome --size 64 --background 40,60,120 --path "$work/path.json" \
      --frames "$work/frames" --fps 2 --wait-complete)
echo "$out" | grep -q "3 frames.*every frame complete" || fail "dome flight: $out"
for n in 0 1 2; do check "$work/frames/frame_0000$n.png" 64x64; done

usage() {
  local want=$1
  shift
  set +e
  "$tellus" render --no-sun --no-atmosphere --cache "$cache" --camera 0,0,1e7 "$@" --out "$work/bad.png" 2>"$work/err.txt" >/dev/null
  local rc=$?
  set -e
  [ $rc -eq 2 ] || fail "exit $rc (want 2) for: $* ($(cat "$work/err.txt"))"
  grep -q -- "$want" "$work/err.txt" || fail "message for $*: $(cat "$work/err.txt")"
  [ ! -e "$work/bad.png" ] || fail "an image was written for: $*"
}
usage "--dome FOV" --dome 230
usage "--dome FOV" --dome=0
usage "--dome FOV" --dome abc
usage "--dome-tilt" --dome --dome-tilt 400
usage "square" --dome --size 96x64
usage "--dome-method" --dome --dome-method flat
usage "unexpected argument" 220
echo "dome CLI: ok"
