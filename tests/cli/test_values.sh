#!/usr/bin/env bash
# The thesis's figure 25 in `tellus render` (issue 24; label gl): config/examples/heights.yaml
# draws the bundled ETOPO heights as a layer of values, coloured by the `terrain` map and blended
# at half opacity over the Blue Marble. At a point of deep ocean (mid-Atlantic) and one of land
# (the Sahara) the overlay's colour, recovered from the render with and without it
# (c = (with - (1 - 0.5) x without) / 0.5, within 4 of 255 for the two 8-bit roundings), is an
# ocean blue (the map's lower half: blue well above red) and a land green (its upper half's low
# end: green above red and blue). A value layer's errors are refused clearly.
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/../.." && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-values.XXXXXX")
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
pixel() { python3 "$here/png_pixels.py" "$@"; }

sed "s|^data_dir: .*|data_dir: $src/data|" "$src/config/examples/heights.yaml" >"$work/heights.yaml"
# The same without the overlay: renderer.layers the Blue Marble alone.
python3 - "$work/heights.yaml" "$work/plain.yaml" <<'PY'
import sys
text = open(sys.argv[1]).read()
head = text[:text.index("renderer:")]
open(sys.argv[2], "w").write(head + "renderer:\n  layers:\n    - layer: bluemarble\n")
PY
render() { # CONFIG LAT LON OUT
  "$tellus" render --no-sun --no-atmosphere --no-stars --config "$1" --cache "$work/cache" \
    --camera "$2,$3,3e6" --size 64x64 --out "$4" --wait-complete >/dev/null || fail "render $1 $2,$3"
}
overlay_colour() { # LAT LON -> R G B of the overlay at the centre
  render "$work/heights.yaml" "$1" "$2" "$work/with.png"
  render "$work/plain.yaml" "$1" "$2" "$work/without.png"
  read -r r1 g1 b1 < <(pixel "$work/with.png" 32 32)
  read -r r0 g0 b0 < <(pixel "$work/without.png" 32 32)
  python3 -c "import sys; a=list(map(int,sys.argv[1:4])); b=list(map(int,sys.argv[4:7])); print(*[round(2*x-y) for x,y in zip(a,b)])" \
    "$r1" "$g1" "$b1" "$r0" "$g0" "$b0"
}

read -r r g b < <(overlay_colour 0 -30) # mid-Atlantic, ~ -4000 m
[ $((b - r)) -gt 40 ] || fail "the ocean is not an ocean blue of the terrain map: $r $g $b"
read -r r g b < <(overlay_colour 23 10) # the Sahara, ~ 400 m
{ [ "$g" -gt "$r" ] && [ "$g" -gt "$b" ]; } || fail "the Sahara is not a land green: $r $g $b"

# A colour map that does not exist, and a range on an imagery layer: refused with the key.
sed "s|      opacity: 0.5|      opacity: 0.5\n      colour_map: rainbowish|" "$work/heights.yaml" >"$work/bad.yaml"
if "$tellus" render --config "$work/bad.yaml" --camera 0,0,1e7 --out "$work/bad.png" 2>"$work/err"; then
  fail "an unknown colour map was accepted"
fi
grep -q "renderer.layers\[1\].colour_map" "$work/err" || fail "the error names no key: $(cat "$work/err")"
sed "s|    - layer: bluemarble|    - layer: bluemarble\n    - layer: bluemarble\n      range: [0, 1]|" \
  "$work/heights.yaml" >"$work/bad2.yaml"
if "$tellus" render --config "$work/bad2.yaml" --camera 0,0,1e7 --out "$work/bad.png" 2>"$work/err"; then
  fail "a range on an imagery layer was accepted"
fi
grep -q "value layers only" "$work/err" || fail "unclear error: $(cat "$work/err")"
echo "values: ok"
