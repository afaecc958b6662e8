#!/usr/bin/env bash
# The sun and the night side in `tellus render` (issue 23; label gl: run under xvfb-run): the
# embedded default lit at its fixed time (recorded in --stats), --no-sun and --no-night, --time
# (ISO 8601 UTC or now, bad values exit 2), renderer.time with --time over it, and a flight whose
# keyframes' "utc" runs the sun.
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd) # png_pixels.py
src=$(cd "$here/../.." && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-sun.XXXXXX")
trap 'rm -rf "$work"' EXIT
cache="$work/cache"
fail() { echo "FAIL: $*" >&2; exit 1; }
render() { "$tellus" render --cache "$cache" --size 128x128 --wait-complete "$@" >/dev/null; }
stat() { python3 -c "import json,sys; s=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }

# The default: lit, at 2024-03-20T12:00:00Z, the night lights on (hidden with --no-sun).
render --camera 0,0,2e7 --out "$work/lit.png" --stats "$work/lit.json" || fail "default render"
[ "$(stat "$work/lit.json" 's["scene_time"]')" = "2024-03-20T12:00:00Z" ] || fail "scene_time: $(grep scene_time "$work/lit.json")"
[ "$(stat "$work/lit.json" 's["sunlight"]')" = "True" ] || fail "not lit by default"
[ "$(stat "$work/lit.json" '[(l["name"], l["night"], l["visible"]) for l in s["layers"]]')" = \
  "[('bluemarble', False, True), ('nightlights', True, True)]" ] || fail "layers: $(grep name "$work/lit.json")"
render --camera 0,0,2e7 --out "$work/unlit.png" --stats "$work/unlit.json" --no-sun || fail "--no-sun"
[ "$(stat "$work/unlit.json" 's["sunlight"]')" = "False" ] || fail "--no-sun still lit"
[ "$(stat "$work/unlit.json" 's["layers"][1]["visible"]')" = "False" ] || fail "--no-sun: night lights shown"
cmp -s "$work/lit.png" "$work/unlit.png" && fail "--no-sun drew the lit image"

# Dusk over Europe (2024-03-20T18:00Z, the sun over 88 W): the day side (the Atlantic, left) the
# same with and without the night lights, the night side (Europe, right) brighter with them.
render --camera 45,5,2e7 --time 2024-03-20T18:00:00Z --out "$work/dusk.png" --stats "$work/dusk.json" ||
  fail "dusk"
[ "$(stat "$work/dusk.json" 's["scene_time"]')" = "2024-03-20T18:00:00Z" ] || fail "--time not recorded"
render --camera 45,5,2e7 --time 2024-03-20T18:00:00Z --no-night --out "$work/dark.png" || fail "--no-night"
PYTHONPATH="$here" python3 - "$work/dusk.png" "$work/dark.png" <<'PY' || fail "the night lights are not on the night side only"
import sys
from png_pixels import pixels
w, h, a, n = pixels(sys.argv[1])
_, _, b, _ = pixels(sys.argv[2])
def strip(rows, x0, x1):  # the sum of the channels over columns x0..x1, rows 55..72
    return sum(rows[y][x * n + c] for y in range(55, 73) for x in range(x0, x1) for c in range(3))
day_a, day_b = strip(a, 35, 50), strip(b, 35, 50)
night_a, night_b = strip(a, 80, 95), strip(b, 80, 95)
print(f"day side {day_a} vs {day_b}, night side {night_a} vs {night_b}")
sys.exit(0 if day_a == day_b and day_a > 0 and night_a > night_b + 200 else 1)
PY

# now: the wall clock's time (within a minute).
render --camera 0,0,2e7 --time now --out "$work/now.png" --stats "$work/now.json" || fail "--time now"
python3 -c "import json,sys,time; s=json.load(open(sys.argv[1])); sys.exit(0 if abs(s['scene_time_unix'] - time.time()) < 60 else 1)" \
  "$work/now.json" || fail "--time now: $(grep scene_time "$work/now.json")"
set +e
"$tellus" render --cache "$cache" --camera 0,0,2e7 --out "$work/x.png" --time 2024-13-01 2>"$work/err.txt" >/dev/null
rc=$?
set -e
[ $rc -eq 2 ] || fail "--time 2024-13-01: exit $rc, not a usage error"
grep -q "ISO 8601" "$work/err.txt" || fail "--time message: $(cat "$work/err.txt")"

# renderer.time in the configuration; --time wins over it.
sed "s|^data_dir: .*|data_dir: $src/data|; s|^renderer:|renderer:\n  time: 2024-06-20T20:51:00Z|" \
  "$src/config/examples/default.yaml" >"$work/timed.yaml"
"$tellus" render --config "$work/timed.yaml" --cache "$cache" --size 64x64 --camera 0,0,2e7 \
  --out "$work/t.png" --stats "$work/t.json" --wait-complete >/dev/null || fail "renderer.time"
[ "$(stat "$work/t.json" 's["scene_time"]')" = "2024-06-20T20:51:00Z" ] || fail "renderer.time not used"
"$tellus" render --config "$work/timed.yaml" --cache "$cache" --size 64x64 --camera 0,0,2e7 \
  --time 2000-01-01 --out "$work/t.png" --stats "$work/t.json" --wait-complete >/dev/null || fail "--time over it"
[ "$(stat "$work/t.json" 's["scene_time"]')" = "2000-01-01T00:00:00Z" ] || fail "--time did not win"

# A flight whose keyframes carry "utc": a day in two seconds, the globe seen from one place.
cat >"$work/path.json" <<'JSON'
[{"time": 0, "lat": 0, "lon": 0, "alt": 2e7, "utc": "2024-03-20T00:00:00Z"},
 {"time": 2, "lat": 0, "lon": 0, "alt": 2e7, "utc": "2024-03-21T00:00:00Z"}]
JSON
"$tellus" render --cache "$cache" --path "$work/path.json" --frames "$work/frames" --fps 2 \
  --size 64x64 --wait-complete --stats "$work/path.json.stats" >/dev/null || fail "flight"
cmp -s "$work/frames/frame_00000.png" "$work/frames/frame_00002.png" && fail "midnight and noon look alike"
[ "$(stat "$work/path.json.stats" 's["scene_time"]')" = "2024-03-21T00:00:00Z" ] || fail "flight's last time"
echo "sun CLI: ok"
