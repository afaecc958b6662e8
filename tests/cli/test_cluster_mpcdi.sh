#!/usr/bin/env bash
# `tellus cluster --mpcdi` end to end (issue 28; labels gl and integration: run under xvfb-run):
# the five-channel dome written as a VESA MPCDI file (make_mpcdi.py: the "3d" profile, warps that
# change nothing, soft-edge alpha maps) renders the same channel images as the JSON configuration
# with the same masks as "blend" files (PSNR at least BOUND; measured: identical). A malformed
# file and CONFIG.json with --mpcdi are refused with a message. KEEP=1 keeps the work folder.
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd) # make_mpcdi.py, png_pixels.py
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-mpcdi.XXXXXX")
trap '[ -n "${KEEP:-}" ] || rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 # CI runs as root
bound=50 # dB per channel: the warp resamples at the pixel centres it came from
cluster() { mpirun --oversubscribe -n 6 "$tellus" cluster "$@"; }
opts=(--no-sun --no-atmosphere --no-stars --cache "$work/cache" --background 40,60,120
  --camera 45,7,3e5,0,0 --wait-complete)

# The dome of test_cluster.sh at twice the size (200 x 140 around, 140 x 140 at the top), each
# channel's blend the soft edge the MPCDI file's alpha map holds.
python3 - "$work" <<'PY'
import json, sys
work = sys.argv[1]
around = [{"name": n, "azimuth": a, "elevation": 20, "hfov": 110, "vfov": 90,
           "width": 200, "height": 140, "blend": f"{n}-alpha.png"}
          for n, a in (("north", 0), ("east", 90), ("south", 180), ("west", 270))]
top = {"name": "zenith", "azimuth": 0, "elevation": 90, "hfov": 100, "vfov": 100,
       "width": 140, "height": 140, "blend": "zenith-alpha.png"}
json.dump({"channels": around + [top]}, open(f"{work}/dome.json", "w"))
PY
python3 "$here/make_mpcdi.py" "$work/dome.json" "$work/dome.mpcdi" 33 "$work"
cluster "$work/dome.json" "${opts[@]}" --out "$work/json" >/dev/null || fail "cluster with JSON"
out=$(cluster --mpcdi "$work/dome.mpcdi" "${opts[@]}" --out "$work/mpcdi") ||
  fail "cluster with --mpcdi: $out"
echo "$out" | grep -q "1 frames of 5 channels" || fail "cluster said: $out"
for n in north east south west zenith; do
  a="$work/json/channel-$n-00000.png" b="$work/mpcdi/channel-$n-00000.png"
  [ -f "$b" ] || fail "no image of channel $n from the MPCDI file"
  p=$(PYTHONPATH="$here" python3 -c "
import math, sys
from png_pixels import pixels
wa, ha, ra, na = pixels(sys.argv[1]); wb, hb, rb, nb = pixels(sys.argv[2])
assert (wa, ha, na) == (wb, hb, nb), 'sizes differ'
se = sum((x - y) ** 2 for r, s in zip(ra, rb) for x, y in zip(r, s))
print(99.0 if se == 0 else round(10 * math.log10(255 ** 2 * wa * ha * na / se), 2))" "$a" "$b")
  echo "channel $n: MPCDI against JSON: $p dB"
  python3 -c "import sys; sys.exit(float(sys.argv[1]) < $bound)" "$p" ||
    fail "channel $n from the MPCDI file differs from the JSON configuration's: $p dB"
done
# The masks did something: the soft edge (weight 6 / 255 there) darkens the corner of north.
PYTHONPATH="$here" python3 -c "
import sys
from png_pixels import pixels
w, h, rows, n = pixels(sys.argv[1])
sys.exit(sum(rows[0][:3]) >= 20)" "$work/mpcdi/channel-north-00000.png" || fail "the alpha map was not applied"

# Refused: not a zip; CONFIG.json and --mpcdi together.
echo "not a zip" >"$work/bad.mpcdi"
set +e
msg=$(cluster --mpcdi "$work/bad.mpcdi" "${opts[@]}" --out "$work/u" 2>&1)
rc=$?
set -e
[ $rc -ne 0 ] && echo "$msg" | grep -q "bad.mpcdi: not a zip archive" ||
  fail "a malformed MPCDI file not refused: $rc $msg"
set +e
msg=$(cluster "$work/dome.json" --mpcdi "$work/dome.mpcdi" "${opts[@]}" --out "$work/u" 2>&1)
rc=$?
set -e
[ $rc -ne 0 ] && echo "$msg" | grep -q "CONFIG.json or --mpcdi FILE.mpcdi (not both)" ||
  fail "CONFIG.json with --mpcdi not refused: $rc $msg"
echo "ok"
