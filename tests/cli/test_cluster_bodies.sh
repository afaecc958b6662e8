#!/usr/bin/env bash
# `tellus cluster` with a flight between bodies (issue 28 with issue 26's keyframe "body"; labels
# gl and integration: run under xvfb-run): bench/paths/earth-to-moon-dome.json (2,000 km over
# the Earth, then 500 km over the Moon) played by a master and two channels at 1 frame a second.
# The master chooses the body orbited each frame and sends its index with the state; every channel
# has a renderer per body and draws with the one named. Each channel's frames are those of
# `tellus render --channel CONFIG,NAME --path` (which switches bodies by itself; PSNR >= 40 dB):
# the Earth's renderer near the Earth, the Moon's quadtree at the end, not the coarse globe the
# Earth's renderer would draw there (checked against `--body earth`). The digests of every rank
# agree. Again with --window and --preview: the windows' images are the same, and the master's
# preview of the last frame is `tellus render --dome`'s of it (its renderers switch too). KEEP=1
# keeps the work folder.
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd)
path="$here/../../bench/paths/earth-to-moon-dome.json"
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-cluster-bodies.XXXXXX")
trap '[ -n "${KEEP:-}" ] || rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 # CI runs as root

echo '{"channels": [
 {"name": "a", "azimuth": 0, "elevation": 75, "hfov": 30, "vfov": 30, "width": 48, "height": 48},
 {"name": "b", "azimuth": 180, "elevation": 15, "hfov": 60, "vfov": 60, "width": 48, "height": 48}
]}' >"$work/dome.json"
common=(--cache "$work/cache" --path "$path" --fps 1 --wait-complete --no-stars)
out=$(mpirun --oversubscribe -n 3 "$tellus" cluster "$work/dome.json" "${common[@]}" \
  --out "$work/o" 2>&1) || fail "cluster: $out"
out=$(mpirun --oversubscribe -n 3 "$tellus" cluster "$work/dome.json" "${common[@]}" \
  --window --preview 96 --out "$work/w" 2>&1) || fail "cluster --window --preview: $out"
"$tellus" render --dome --size 96x96 "${common[@]}" --frames "$work/dome" >"$work/render.log" 2>&1 ||
  fail "render --dome: $(cat "$work/render.log")"
for ch in a b; do
  cmp -s "$work/o/digest-master.txt" "$work/o/digest-$ch.txt" || fail "channel $ch drew other states"
  for body in switch earth; do
    extra=()
    [ "$body" = earth ] && extra=(--body earth)
    "$tellus" render --channel "$work/dome.json,$ch" "${common[@]}" --frames "$work/$ch-$body" \
      "${extra[@]}" >"$work/render.log" 2>&1 || fail "render --channel $ch: $(cat "$work/render.log")"
  done
done
PYTHONPATH="$here" python3 - "$work" <<'PY' || fail "the channels' frames are not those of render --channel"
import math, sys
from png_pixels import pixels

def psnr(a, b):
    wa, ha, ra, na = pixels(a)
    wb, hb, rb, nb = pixels(b)
    assert (wa, ha) == (wb, hb), (a, b)
    se = sum((ra[y][x * na + c] - rb[y][x * nb + c]) ** 2
             for y in range(ha) for x in range(wa) for c in range(3))
    mse = se / (wa * ha * 3.0)
    return math.inf if mse == 0 else 10 * math.log10(255.0 ** 2 / mse)

work = sys.argv[1]
for ch in "ab":
    for n in range(5):
        got = "%s/o/channel-%s-%05d.png" % (work, ch, n)
        want = "%s/%s-switch/frame_%05d.png" % (work, ch, n)
        p = psnr(got, want)
        print("channel %s frame %d: %.1f dB against render --channel" % (ch, n, p))
        assert p >= 40.0, (ch, n, p)
    # The last frame is over the Moon: the Earth's renderer (its coarse Moon) draws another one.
    coarse = psnr("%s/o/channel-%s-00004.png" % (work, ch), "%s/%s-earth/frame_00004.png" % (work, ch))
    print("channel %s frame 4: %.1f dB against the Earth's renderer" % (ch, coarse))
    assert coarse < 40.0, coarse
    for n in range(5):
        p = psnr("%s/w/channel-%s-%05d.png" % (work, ch, n), "%s/o/channel-%s-%05d.png" % (work, ch, n))
        assert p >= 40.0, ("--window", ch, n, p)
p = psnr("%s/w/preview.png" % work, "%s/dome/frame_00004.png" % work)
print("the preview of the last frame: %.1f dB against render --dome" % p)
assert p >= 40.0, p
PY
echo "ok"
