#!/usr/bin/env bash
# The Earth and the Moon in one scene on the command line (issue 26, label gl): the dome show of
# bench/paths/earth-to-moon-dome.json (2,000 km over the Earth, then 500 km over the Moon's near
# side at full moon, 2024-01-25 17:54 UTC: its keyframes name their body) rendered small on the
# embedded default twice, orbiting the Earth (the Moon a coarse globe with its bundled map) and
# orbiting the Moon (`--body moon`: its quadtree and bundled layer; the Earth the coarse globe):
# the last frame looks straight down at the lit Moon both ways, alike; then without --body, the
# camera switching to the body it is near (planet/OrbitChoice.hpp): the Earth's frames while near
# the Earth, and the last frame the Moon's quadtree, as `--body moon` draws it (PSNR >= 40 dB),
# not the coarse globe; --stats says the Moon is orbited from frame 4 on. Unknown bodies are
# refused.
# Usage: test_earth_moon.sh TELLUS
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
path="$here/../../bench/paths/earth-to-moon-dome.json"
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-earth-moon.XXXXXX")
trap '[ -n "${KEEP:-}" ] || rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

for scene in earth moon switch; do
  body=(--body "$scene")
  [ "$scene" = switch ] && body=()
  "$tellus" render --cache "$work/cache" --path "$path" --frames "$work/$scene" --fps 1 \
    --size 256x256 --dome 180 --wait-complete --no-stars --stats "$work/$scene.json" \
    "${body[@]}" >"$work/out" 2>&1 || fail "render over the $scene: $(cat "$work/out")"
  [ -f "$work/$scene/frame_00004.png" ] || fail "no frame 4 ($scene): $(ls "$work/$scene")"
done
# The mean of the central 32 x 32 pixels of the last frame: the lit Moon, as bright and coloured
# whichever body is orbited (the coarse globe against the quadtree, the same map).
PYTHONPATH="$here" python3 - "$work/earth/frame_00004.png" "$work/moon/frame_00004.png" <<'PY' ||
import sys
from png_pixels import pixels

def centre(path):
    w, h, rows, n = pixels(path)
    s = [0, 0, 0]
    for y in range(h // 2 - 16, h // 2 + 16):
        for x in range(w // 2 - 16, w // 2 + 16):
            for c in range(3):
                s[c] += rows[y][x * n + c]
    return [v / 1024.0 for v in s]

earth, moon = centre(sys.argv[1]), centre(sys.argv[2])
print("centre over the Earth %s, over the Moon %s" % (earth, moon))
assert min(earth) > 40 and min(moon) > 40, (earth, moon)
assert all(abs(a - b) < 20 for a, b in zip(earth, moon)), (earth, moon)
PY
  fail "the Moon at the end of the flight"
# Switching: the frames near the Earth are the Earth's renderer's, the last the Moon's quadtree.
for i in 0 1 2 3; do
  cmp -s "$work/switch/frame_0000$i.png" "$work/earth/frame_0000$i.png" ||
    fail "frame $i of the flight without --body is not the one over the Earth"
done
PYTHONPATH="$here" python3 - "$work/switch/frame_00004.png" "$work/moon/frame_00004.png" \
  "$work/earth/frame_00004.png" "$work/switch.json" <<'PY' ||
import json, math, sys
from png_pixels import pixels

def psnr(a, b):
    wa, ha, ra, na = pixels(a)
    wb, hb, rb, nb = pixels(b)
    assert (wa, ha) == (wb, hb)
    se = sum((ra[y][x * na + c] - rb[y][x * nb + c]) ** 2
             for y in range(ha) for x in range(wa) for c in range(3))
    mse = se / (wa * ha * 3.0)
    return math.inf if mse == 0 else 10 * math.log10(255.0 ** 2 / mse)

moon, coarse = psnr(sys.argv[1], sys.argv[2]), psnr(sys.argv[1], sys.argv[3])
print("last frame without --body: %.1f dB against --body moon, %.1f dB against --body earth"
      % (moon, coarse))
assert moon >= 40.0, moon
assert coarse < moon and coarse < 60.0, coarse  # the coarse globe is not what is drawn
stats = json.load(open(sys.argv[4]))
assert stats["body"] == "moon", stats["body"]
assert stats["orbit_switches"] == [{"frame": 4, "body": "moon"}], stats["orbit_switches"]
PY
  fail "the flight without --body does not land on the Moon's quadtree"
rc=0
"$tellus" render --cache "$work/cache" --camera 0,0,2e7 --size 64x64 --out "$work/x.png" \
  --bodies moon,pluto 2>"$work/err" || rc=$?
[ "$rc" = 2 ] || fail "--bodies pluto: exit $rc, want 2"
grep -q "pluto" "$work/err" || fail "--bodies pluto said: $(cat "$work/err")"
echo "ok: the Earth and the Moon in one dome show"
