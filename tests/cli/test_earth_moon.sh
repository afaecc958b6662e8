#!/usr/bin/env bash
# The Earth and the Moon in one scene on the command line (issue 26, label gl): the dome show of
# bench/paths/earth-to-moon-dome.json (2,000 km over the sub-lunar point out to 30,000 km short of
# the Moon, 2024-01-18 03:52 UTC) rendered small with `--bodies moon` on the embedded default: its
# last frame has the Moon's disc at the dome's centre (the axis at the zenith points at it), and
# the same frame without --bodies has none; unknown bodies are refused.
# Usage: test_earth_moon.sh TELLUS
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
path="$here/../../bench/paths/earth-to-moon-dome.json"
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-earth-moon.XXXXXX")
trap '[ -n "${KEEP:-}" ] || rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

for scene in two one; do
  extra=()
  [ "$scene" = two ] && extra=(--bodies moon)
  "$tellus" render --cache "$work/cache" --path "$path" --frames "$work/$scene" --fps 1 \
    --size 256x256 --dome 180 --wait-complete --no-stars "${extra[@]}" >"$work/out" 2>&1 ||
    fail "render ($scene): $(cat "$work/out")"
  [ -f "$work/$scene/frame_00004.png" ] || fail "no frame 4 ($scene): $(ls "$work/$scene")"
done
# The brightest pixel within 8 pixels of the centre (the Moon's radius here: 4.7 px), and the
# count of lit pixels there.
PYTHONPATH="$here" python3 - "$work/two/frame_00004.png" "$work/one/frame_00004.png" <<'PY' ||
import sys
from png_pixels import pixels

def centre(path):
    w, h, rows, n = pixels(path)
    best, lit = 0, 0
    for y in range(h // 2 - 8, h // 2 + 8):
        for x in range(w // 2 - 8, w // 2 + 8):
            v = max(rows[y][x * n:x * n + 3])
            best = max(best, v)
            lit += v > 40
    return best, lit

two, one = centre(sys.argv[1]), centre(sys.argv[2])
print("with the Moon: brightest %d, %d lit; without: brightest %d, %d lit" % (two + one))
assert two[0] > 80 and 10 <= two[1] <= 120, two
assert one[1] == 0, one
PY
  fail "the Moon's disc at the dome's centre"
rc=0
"$tellus" render --cache "$work/cache" --camera 0,0,2e7 --size 64x64 --out "$work/x.png" \
  --bodies moon,pluto 2>"$work/err" || rc=$?
[ "$rc" = 2 ] || fail "--bodies pluto: exit $rc, want 2"
grep -q "pluto" "$work/err" || fail "--bodies pluto said: $(cat "$work/err")"
echo "ok: the Earth and the Moon in one dome show"
