#!/usr/bin/env bash
# Real scientific data through the proxy (issue 24): config/examples/sst.yaml serves the bundled
# COADS January sea-surface temperature (data/sst_coads_jan_int16.tif: 0.01 degree C, land
# -32768) as a layer of values, rendered into tiles by the local upstream. `tellus serve` is asked
# as a WMS client would:
#   - GetFeatureInfo (JSON) at source cell centres answers the temperature in degrees C, checked
#     against the source read by GDAL (gdallocationinfo) within a quarter of the local spread of
#     the 3 x 3 source cells + 0.05 C (the tiles resample the source bilinearly, land never mixed
#     in); the equatorial Pacific is 26-30 C; land (the Sahara) has no data;
#   - the styled GetMap (magma, its default style), read by GDAL, is the magma colour of that
#     value at the same pixel (index +-1 where the value sits on a bin edge), opaque; land is
#     transparent;
#   - GetLegendGraphic is a PNG;
#   - `tellus height --values sst` at the same points prints what GetFeatureInfo answered (the same
#     tile, the same value function), and "no data" on land.
# Usage: test_sst.sh path/to/tellus
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/../.." && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-sst.XXXXXX")
server=
cleanup() {
  [ -n "$server" ] && kill "$server" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
command -v gdallocationinfo >/dev/null || fail "gdallocationinfo (Debian gdal-bin) is needed"
sed "s|^data_dir: .*|data_dir: $src/data|" "$src/config/examples/sst.yaml" >"$work/sst.yaml"
"$tellus" serve --config "$work/sst.yaml" --cache "$work/cache" --listen 127.0.0.1:0 \
  >"$work/serve.txt" 2>&1 &
server=$!
for _ in $(seq 100); do grep -q "listening on" "$work/serve.txt" && break; sleep 0.1; done
port=$(grep -o "127.0.0.1:[0-9]*" "$work/serve.txt" | head -n 1 | cut -d: -f2)
[ -n "$port" ] || fail "serve did not start: $(cat "$work/serve.txt")"
base="http://127.0.0.1:$port/wms?SERVICE=WMS&VERSION=1.3.0"
# A 180 x 90 map of the globe: pixel (x, y) is the source's 2-degree cell (x, y), whose centre is
# (-179 + 2x E, 89 - 2y N).
map="LAYERS=sst&STYLES=&CRS=CRS:84&BBOX=-180,-90,180,90&WIDTH=180&HEIGHT=90"

curl -sf -o "$work/map.png" "$base&REQUEST=GetMap&$map&FORMAT=image/png&TRANSPARENT=TRUE" \
  || fail "styled GetMap"
curl -sf -o "$work/legend.png" "$base&REQUEST=GetLegendGraphic&LAYER=sst&FORMAT=image/png" \
  || fail "GetLegendGraphic"
[ "$(head -c 4 "$work/legend.png" | tail -c 3)" = "PNG" ] || fail "the legend is not a PNG"

# Points: x y what. Sea points away from coasts; the Sahara last (no data).
points=(
  "10 44 central Pacific (1 N, 159 W)"
  "15 45 eastern equatorial Pacific (1 S, 149 W)"
  "165 44 western Pacific warm pool (1 N, 151 E)"
  "75 44 equatorial Atlantic (1 N, 29 W)"
  "120 50 Indian Ocean (11 S, 61 E)"
  "80 20 North Atlantic (49 N, 19 W)"
  "95 33 the Sahara (23 N, 11 E)"
)
: >"$work/got"
: >"$work/cells"
: >"$work/colours"
: >"$work/height"
for p in "${points[@]}"; do
  read -r x y what <<<"$p"
  "$tellus" height --config "$work/sst.yaml" --cache "$work/cache" --values sst \
    --lat $((89 - 2 * y)) --lon $((-179 + 2 * x)) >>"$work/height" 2>"$work/height.err" \
    || fail "tellus height --values at $what: $(cat "$work/height.err")"
  curl -sf -o "$work/info.json" \
    "$base&REQUEST=GetFeatureInfo&$map&QUERY_LAYERS=sst&INFO_FORMAT=application/json&I=$x&J=$y" \
    || fail "GetFeatureInfo at $what"
  python3 -c "import json,sys; v=json.load(open(sys.argv[1]))['features'][0]['properties']; print(v['value'] if v['value'] is not None else 'null', v['unit'])" \
    "$work/info.json" >>"$work/got" || fail "GetFeatureInfo at $what: $(cat "$work/info.json")"
  gdallocationinfo -valonly "$work/map.png" "$x" "$y" | tr '\n' ' ' >>"$work/colours"
  echo >>"$work/colours"
  for dj in -1 0 1; do
    for di in -1 0 1; do
      echo "$(((x + di + 180) % 180)) $((y + dj))" >>"$work/cells"
    done
  done
done
gdallocationinfo -valonly "$src/data/sst_coads_jan_int16.tif" <"$work/cells" >"$work/source"
python3 - "$work/got" "$work/source" "$work/colours" "$src/values/src/ColourMapTables.cpp" \
  "${#points[@]}" "$work/height" <<'PY'
import re, sys
got = [line.split() for line in open(sys.argv[1])]
height = [line.strip() for line in open(sys.argv[6])]
source = [int(float(v)) for v in open(sys.argv[2]).read().split()]
colours = [[int(v) for v in line.split()] for line in open(sys.argv[3])]
table = open(sys.argv[4]).read()
body = table[table.index("k_magma = {{"):]
body = body[:body.index("}};")]
magma = [tuple(map(int, t)) for t in re.findall(r"\{(\d+), (\d+), (\d+)\}", body)]
assert len(magma) == 256, len(magma)
n = int(sys.argv[5])
assert len(got) == n and len(colours) == n and len(source) == 9 * n, (len(got), len(source))
assert len(height) == n, height
bad = []
for k in range(n):
    cells = source[9 * k:9 * k + 9]
    value, unit = got[k]
    same = height[k] == "no data" if value == "null" else abs(float(height[k]) - float(value)) < 1e-3
    if not same:
        bad.append(f"point {k}: tellus height --values printed {height[k]}, GetFeatureInfo {value}")
    if k == n - 1:  # the Sahara
        if value != "null" or cells[4] != -32768 or colours[k][3] != 0:
            bad.append(f"Sahara: value {value}, source {cells[4]}, pixel {colours[k]}")
        continue
    v = float(value)
    sea = [c / 100 for c in cells if c != -32768]
    tolerance = 0.25 * (max(sea) - min(sea)) + 0.05
    if unit != "°C" or abs(v - cells[4] / 100) > tolerance:
        bad.append(f"point {k}: {v} {unit}, the source cell {cells[4] / 100} (+-{tolerance:.3f})")
    index = min(max(int((v + 2) / 34 * 256), 0), 255)
    near = [tuple(magma[i]) for i in range(max(index - 1, 0), min(index + 2, 256))]
    if tuple(colours[k][:3]) not in near or colours[k][3] != 255:
        bad.append(f"point {k}: pixel {colours[k]}, magma[{index}] = {magma[index]}")
    if k < 3 and not 26.0 <= v <= 30.0:
        bad.append(f"point {k}: {v} C is not an equatorial Pacific temperature")
if bad:
    sys.exit("\n".join(bad))
print("\n".join(" ".join(g) for g in got))
PY
echo "sst: ok"
