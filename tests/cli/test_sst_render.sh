#!/usr/bin/env bash
# Real scientific data in `tellus render` (issue 24; label gl): config/examples/sst.yaml draws the
# bundled COADS January sea-surface temperature as a layer of values (magma, -2 to 32 degrees C,
# opaque) over the Blue Marble. The centre pixel of a view
#   - over the equatorial Pacific (0, 160 W; 26.6-27.0 C in the source's four cells around it) is
#     a magma colour of 25-29 C (within 4 of a table entry with an index of that range), where the
#     Blue Marble alone is ocean blue;
#   - over the North Atlantic (50 N, 25 W; 11-13 C) is a magma colour of a lower index;
#   - over the Sahara (no data) is the Blue Marble's own pixel (within 2: the imagery shows).
# Usage: test_sst_render.sh path/to/tellus
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/../.." && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-sst-render.XXXXXX")
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
pixel() { python3 "$here/png_pixels.py" "$@"; }

sed "s|^data_dir: .*|data_dir: $src/data|" "$src/config/examples/sst.yaml" >"$work/sst.yaml"
python3 - "$work/sst.yaml" "$work/plain.yaml" <<'PY'
import sys
text = open(sys.argv[1]).read()
head = text[:text.index("renderer:")]
open(sys.argv[2], "w").write(head + "renderer:\n  layers:\n    - layer: bluemarble\n")
PY
render() { # CONFIG LAT LON OUT
  "$tellus" render --no-sun --no-atmosphere --no-stars --config "$1" --cache "$work/cache" \
    --camera "$2,$3,3e6" --size 64x64 --out "$4" --wait-complete >/dev/null || fail "render $1 $2,$3"
}
centre() { # NAME LAT LON [plain] -> "R G B [R0 G0 B0]": with the SST [and the Blue Marble alone]
  render "$work/sst.yaml" "$2" "$3" "$work/$1.png"
  local plain=""
  if [ "${4:-}" = plain ]; then
    render "$work/plain.yaml" "$2" "$3" "$work/$1-plain.png"
    plain=$(pixel "$work/$1-plain.png" 32 32)
  fi
  echo "$(pixel "$work/$1.png" 32 32) $plain"
}
pacific=$(centre pacific 0 -160 plain)
atlantic=$(centre atlantic 50 -25)
sahara=$(centre sahara 23 10 plain)
python3 - "$pacific" "$atlantic" "$sahara" "$src/values/src/ColourMapTables.cpp" <<'PY'
import re, sys
pacific, atlantic, sahara = ([int(v) for v in a.split()] for a in sys.argv[1:4])
table = open(sys.argv[4]).read()
body = table[table.index("k_magma = {{"):]
body = body[:body.index("}};")]
magma = [tuple(map(int, t)) for t in re.findall(r"\{(\d+), (\d+), (\d+)\}", body)]
assert len(magma) == 256, len(magma)
index = lambda c: int((c + 2) / 34 * 256)

def nearest(rgb, lo, hi):
    """The index in [lo, hi] of the magma entry closest to rgb, or None beyond 4 per channel."""
    best = min(range(lo, hi + 1), key=lambda i: max(abs(a - b) for a, b in zip(rgb, magma[i])))
    return best if max(abs(a - b) for a, b in zip(rgb, magma[best])) <= 4 else None

bad = []
p = nearest(pacific[:3], index(25), index(29))
if p is None:
    bad.append(f"the Pacific at 0, 160 W is {pacific[:3]}, no magma colour of 25-29 C")
if not pacific[5] > pacific[3] + 20:
    bad.append(f"the Blue Marble alone is not ocean blue there: {pacific[3:]}")
a = nearest(atlantic[:3], 0, 255)
if a is None or p is None or not a < p - 20:
    bad.append(f"the North Atlantic {atlantic[:3]} (index {a}) is not colder than the Pacific ({p})")
if max(abs(x - y) for x, y in zip(sahara[:3], sahara[3:])) > 2:
    bad.append(f"the Sahara is {sahara[:3]} with the SST layer, {sahara[3:]} without: not the imagery")
if bad:
    sys.exit("FAIL: " + "\n".join(bad))
print(f"Pacific magma[{p}], North Atlantic magma[{a}], Sahara {sahara[:3]}")
PY
echo "sst render: ok"
