#!/usr/bin/env bash
# Interoperability: GDAL (Debian's gdal-bin) reads tellus serve as a user would point it at it.
#   - the WMS driver's capabilities parser lists the layers of GetCapabilities;
#   - the WMS driver's WorldWind mini-driver reads /wwtile tiles, and its pixels are the cached
#     tile's (rows counted from the south, levels as tellus numbers them);
#   - the WMS driver reads the elevation layer in a picture format (grey);
#   - the WMS driver reads an EPSG:3857 window: GDAL's reprojection of the lon/lat map.
#   - the WMTS driver lists the layers and tile matrix sets of /wmts, reads the layer's own World
#     Wind set (the cached tile's pixels) and WorldCRS84Quad (composed: the tile's pixels within
#     the bilinear filter's few levels).
# Usage: test_gdal.sh path/to/tellus
set -euo pipefail
tellus=$1
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-gdal.XXXXXX")
server=
cleanup() {
  [ -n "$server" ] && kill "$server" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
command -v gdalinfo >/dev/null || fail "gdalinfo (Debian gdal-bin) is needed"
cache="$work/cache"
# Only the tile the mini-driver test reads (level 2, row 17, column 10: lat 63..72, lon -90..-81).
"$tellus" seed --cache "$cache" --layer bluemarble --levels 2 --bbox -89,64,-82,71 >/dev/null || fail "seed"
"$tellus" serve --cache "$cache" --listen 127.0.0.1:0 --access-log "$work/access.log" >"$work/serve.txt" 2>&1 &
server=$!
for _ in $(seq 50); do grep -q "listening on" "$work/serve.txt" && break; sleep 0.1; done
port=$(grep -o "127.0.0.1:[0-9]*" "$work/serve.txt" | head -n 1 | cut -d: -f2)
[ -n "$port" ] || fail "serve did not start: $(cat "$work/serve.txt")"
base="http://127.0.0.1:$port"

# Capabilities, both versions: GDAL lists one subdataset per layer.
for v in 1.1.1 1.3.0; do
  gdalinfo "WMS:$base/wms?SERVICE=WMS&VERSION=$v&REQUEST=GetCapabilities" >"$work/caps-$v.txt" 2>&1 \
    || fail "GDAL could not read the $v capabilities: $(cat "$work/caps-$v.txt")"
  grep -q "LAYERS=bluemarble" "$work/caps-$v.txt" || fail "$v: no bluemarble subdataset"
  grep -q "LAYERS=etopo" "$work/caps-$v.txt" || fail "$v: no etopo subdataset"
done

# The WorldWind mini-driver at level 2 (40 x 20 tiles of 512 px). GDAL appends "L=" right after
# the layer, so the layer carries the "&" (a quirk of GDAL's mini-driver, not of the protocol).
cat >"$work/ww.xml" <<XML
<GDAL_WMS>
  <Service name="WorldWind">
    <ServerUrl>$base/wwtile?</ServerUrl>
    <Layer>bluemarble&amp;</Layer>
  </Service>
  <DataWindow>
    <UpperLeftX>-180.0</UpperLeftX><UpperLeftY>90.0</UpperLeftY>
    <LowerRightX>180.0</LowerRightX><LowerRightY>-90.0</LowerRightY>
    <TileLevel>2</TileLevel><TileCountX>10</TileCountX><TileCountY>5</TileCountY>
    <YOrigin>bottom</YOrigin>
  </DataWindow>
  <Projection>EPSG:4326</Projection>
  <BlockSizeX>512</BlockSizeX><BlockSizeY>512</BlockSizeY>
  <BandsCount>3</BandsCount>
</GDAL_WMS>
XML
grep -q "Size is 20480, 10240" <<<"$(gdalinfo "$work/ww.xml")" || fail "GDAL sees another raster size"
# Block (column 10, row 2 from the top) is tellus's level-2 tile row 17, column 10.
gdal_translate -q -srcwin 5120 1024 512 512 -of GTiff "$work/ww.xml" "$work/block.tif" \
  || fail "gdal_translate through the WorldWind mini-driver"
tile=$(ls "$cache"/*/bluemarble-*/2/17/17_10.jpg)
grep -q 'target="/wwtile?T=bluemarble&L=2&X=10&Y=17" status=200 .* cache=HIT' "$work/access.log" \
  || fail "GDAL did not ask for L=2 X=10 Y=17, or it was not the cached tile: $(cat "$work/access.log")"
for p in "100 200" "400 30" "7 500" "511 511"; do
  # shellcheck disable=SC2086
  a=$(gdallocationinfo -valonly "$work/block.tif" $p | tr '\n' ' ')
  # shellcheck disable=SC2086
  b=$(gdallocationinfo -valonly "$tile" $p | tr '\n' ' ')
  [ -n "$a" ] && [ "$a" = "$b" ] || fail "pixel $p through GDAL is '$a', in the cached tile '$b'"
done
# WMTS (issue 25): GDAL's WMTS driver, one subdataset per layer and tile matrix set.
wmts="WMTS:$base/wmts/1.0.0/WMTSCapabilities.xml"
gdalinfo "$wmts" >"$work/wmts-caps.txt" 2>&1 || fail "GDAL could not read the WMTS capabilities: $(cat "$work/wmts-caps.txt")"
for want in "layer=bluemarble,tilematrixset=WorldWind_bluemarble" \
            "layer=bluemarble,tilematrixset=WorldCRS84Quad" \
            "layer=bluemarble,tilematrixset=GoogleMapsCompatible"; do
  grep -q "$want" "$work/wmts-caps.txt" || fail "WMTS: no subdataset $want: $(cat "$work/wmts-caps.txt")"
done
# The own set at tile matrix 2 is the World Wind level 2: the same block as above, the same pixels.
own="$wmts,layer=bluemarble,tilematrixset=WorldWind_bluemarble,tilematrix=2"
grep -q "Size is 20480, 10240" <<<"$(gdalinfo "$own")" || fail "WMTS: GDAL sees another raster size: $(gdalinfo "$own")"
gdal_translate -q -srcwin 5120 1024 512 512 -of GTiff "$own" "$work/wmts-block.tif" \
  || fail "gdal_translate through the WMTS driver"
grep -q 'target=/wmts/1.0.0/bluemarble/default/WorldWind_bluemarble/2/2/10.jpg status=200 .* cache=HIT' \
  "$work/access.log" \
  || fail "GDAL's WMTS GetTile was not the cached tile: $(grep wmts "$work/access.log")"
for p in "100 200" "400 30" "7 500" "511 511"; do
  # shellcheck disable=SC2086
  a=$(gdallocationinfo -valonly "$work/wmts-block.tif" $p | head -n 3 | tr '\n' ' ') # RGB of RGBA
  # shellcheck disable=SC2086
  b=$(gdallocationinfo -valonly "$tile" $p | tr '\n' ' ')
  [ -n "$a" ] && [ "$a" = "$b" ] || fail "WMTS pixel $p through GDAL is '$a', in the cached tile '$b'"
done
# WorldCRS84Quad: tiles composed from the cached level-2 tile (their edges are not World Wind's).
gdal_translate -q -of GTiff -outsize 300 300 -projwin -88 70 -83 65 \
  "$wmts,layer=bluemarble,tilematrixset=WorldCRS84Quad" "$work/wmts-quad.tif" \
  || fail "gdal_translate of WorldCRS84Quad through the WMTS driver"
cp "$tile" "$work/t17.jpg"
printf '%s\n' 0.017578125 0 0 -0.017578125 -89.9912109375 71.9912109375 >"$work/t17.jgw"
for p in "-85.5 67.5" "-87.9 69.9" "-83.2 65.3"; do
  # shellcheck disable=SC2086
  a=$(gdallocationinfo -valonly -wgs84 "$work/wmts-quad.tif" $p | head -n 3 | tr '\n' ' ')
  # shellcheck disable=SC2086
  b=$(gdallocationinfo -valonly -geoloc "$work/t17.jpg" $p | tr '\n' ' ')
  python3 - "$a" "$b" <<'PY' || fail "WorldCRS84Quad pixel $p through GDAL is '$a', in the cached tile '$b'"
import sys
a = [int(v) for v in sys.argv[1].split()]
b = [int(v) for v in sys.argv[2].split()]
sys.exit(0 if len(a) == 3 and len(b) == 3 and max(abs(x - y) for x, y in zip(a, b)) <= 8 else 1)
PY
done

# The WMS driver on an arbitrary window: GDAL asks for boxes of its own choosing, which tellus
# composes from the cached level-2 tile; the pixels agree with the tile's (bilinear, a few levels
# of difference at most).
gdal_translate -q -of GTiff -outsize 300 300 -projwin -88 70 -83 65 \
  "WMS:$base/wms?SERVICE=WMS&VERSION=1.1.1&REQUEST=GetMap&LAYERS=bluemarble&SRS=EPSG:4326&BBOX=-180,-90,180,90&FORMAT=image/jpeg" \
  "$work/window.tif" || fail "gdal_translate of an arbitrary window through the WMS driver"
grep -qi "request=getmap.* status=200" "$work/access.log" || fail "no GetMap in the access log: $(tail -3 "$work/access.log")"
for p in "-85.5 67.5" "-87.9 69.9" "-83.2 65.3"; do
  # shellcheck disable=SC2086
  a=$(gdallocationinfo -valonly -wgs84 "$work/window.tif" $p | tr '\n' ' ')
  # shellcheck disable=SC2086
  b=$(gdallocationinfo -valonly -geoloc "$work/t17.jpg" $p | tr '\n' ' ')
  python3 - "$a" "$b" <<'PY' || fail "pixel $p through GDAL's WMS driver is '$a', in the cached tile '$b'"
import sys
a = [int(v) for v in sys.argv[1].split()]
b = [int(v) for v in sys.argv[2].split()]
sys.exit(0 if len(a) == 3 and len(b) == 3 and max(abs(x - y) for x, y in zip(a, b)) <= 8 else 1)
PY
done

# Web Mercator (EPSG:3857) through GDAL's WMS driver, which asks for boxes in metres of its own
# choosing: the map must be tellus's lat/long GetMap of the place reprojected by GDAL (gdalwarp,
# bilinear), rows at the inverse Mercator (lon -88..-83, lat 65..70, inside the cached tile). Rows
# evenly in latitude would be 6 pixels off in the middle: the same comparison shifted by 6 rows
# must be clearly worse.
read -r mx0 my0 mx1 my1 < <(python3 -c '
import math
R = 6378137.0
x = lambda lon: math.radians(lon) * R
y = lambda lat: R * math.asinh(math.tan(math.radians(lat)))
print(x(-88), y(65), x(-83), y(70))')
# The reference: 7 x 7 degrees at the cached level's own resolution (398 px: level 2), lon/lat.
curl -sf -o "$work/ref4326.png" "$base/wms?SERVICE=WMS&VERSION=1.1.1&REQUEST=GetMap&LAYERS=bluemarble&STYLES=&SRS=EPSG:4326&BBOX=-89,64,-82,71&WIDTH=398&HEIGHT=398&FORMAT=image/png" \
  || fail "GetMap of the lon/lat reference"
gdal_translate -q -a_srs EPSG:4326 -a_ullr -89 71 -82 64 "$work/ref4326.png" "$work/ref4326.tif" || fail "georeferencing the reference"
gdalwarp -q -s_srs EPSG:4326 -t_srs EPSG:3857 -te "$mx0" "$my0" "$mx1" "$my1" -ts 256 256 -r bilinear \
  "$work/ref4326.tif" "$work/ref3857.tif" || fail "gdalwarp of the reference into EPSG:3857"
cat >"$work/merc.xml" <<XML
<GDAL_WMS>
  <Service name="WMS"><Version>1.1.1</Version><ServerUrl>$base/wms?</ServerUrl><SRS>EPSG:3857</SRS>
    <ImageFormat>image/png</ImageFormat><Layers>bluemarble</Layers></Service>
  <DataWindow><UpperLeftX>-20037508.34</UpperLeftX><UpperLeftY>20037508.34</UpperLeftY>
    <LowerRightX>20037508.34</LowerRightX><LowerRightY>-20037508.34</LowerRightY>
    <SizeX>2097152</SizeX><SizeY>2097152</SizeY></DataWindow>
  <BandsCount>3</BandsCount>
</GDAL_WMS>
XML
gdal_translate -q -of GTiff -projwin "$mx0" "$my1" "$mx1" "$my0" -outsize 256 256 "$work/merc.xml" "$work/merc.tif" \
  || fail "gdal_translate of an EPSG:3857 window through the WMS driver"
grep -qi 'srs=epsg:3857[^"]*" status=200' "$work/access.log" || fail "no EPSG:3857 GetMap in the access log"
for f in merc ref3857; do gdal_translate -q -of PNG -b 1 -b 2 -b 3 "$work/$f.tif" "$work/$f.png" || fail "$f as PNG"; done
/usr/bin/python3 - "$work/merc.png" "$work/ref3857.png" <<'PY' || fail "the EPSG:3857 map is not the reprojected lon/lat map"
import sys
import numpy as np
from PIL import Image
a = np.asarray(Image.open(sys.argv[1]).convert("RGB"), dtype=np.int32)
b = np.asarray(Image.open(sys.argv[2]).convert("RGB"), dtype=np.int32)
inner = (slice(8, -8), slice(8, -8))
same = np.abs(a[inner] - b[inner]).mean()
shifted = np.abs(np.roll(a, 6, axis=0)[inner] - b[inner]).mean()
print("EPSG:3857 against the reprojected lon/lat map: mean |difference| %.2f (%.2f shifted by 6 rows)" % (same, shifted))
sys.exit(0 if same < 6.0 and shifted > 1.5 * same else 1)
PY

# Heights in a picture format (the GetMap format list is service-wide): GDAL's WMS driver reads
# the elevation layer as a JPEG, a grey picture of the relief (docs/CONFIG.md, "WMS": -11000 m
# black, +9000 m white).
etopo="WMS:$base/wms?SERVICE=WMS&VERSION=1.1.1&REQUEST=GetMap&LAYERS=etopo&SRS=EPSG:4326&BBOX=-180,-90,180,90"
gdal_translate -q -of GTiff -outsize 360 180 "$etopo&FORMAT=image/jpeg" "$work/etopo-grey.tif" \
  || fail "GDAL could not read the heights layer as image/jpeg"
grey() {
  # shellcheck disable=SC2086
  gdallocationinfo -valonly -wgs84 "$work/etopo-grey.tif" $1 | tr '\n' ' '
}
python3 - "$(grey "86.9 28.0")" "$(grey "-150 0")" <<'PY' \
  || fail "the heights as a picture are not grey, Himalaya over Pacific: '$(grey "86.9 28.0")' '$(grey "-150 0")'"
import sys
high = [int(v) for v in sys.argv[1].split()]
deep = [int(v) for v in sys.argv[2].split()]
grey = lambda p: len(p) >= 3 and max(p[:3]) - min(p[:3]) <= 4
sys.exit(0 if grey(high) and grey(deep) and high[0] > deep[0] + 60 else 1)
PY

# image/tiff is what the layers make it: Int16 heights for the elevation layer alone, an 8-bit
# picture for imagery (RGBA with TRANSPARENT). GDAL's own TIFF reader judges the files.
map="$base/wms?SERVICE=WMS&VERSION=1.1.1&REQUEST=GetMap&STYLES=&SRS=EPSG:4326&BBOX=60,10,100,40&WIDTH=80&HEIGHT=60&FORMAT=image/tiff"
curl -sf -o "$work/heights.tif" "$map&LAYERS=etopo" || fail "GetMap etopo as image/tiff"
grep -q "Band 1 Block=.* Type=Int16" <<<"$(gdalinfo "$work/heights.tif")" || fail "heights as TIFF: $(gdalinfo "$work/heights.tif")"
[ "$(gdalinfo "$work/heights.tif" | grep -c '^Band ')" = 1 ] || fail "heights as TIFF: more than one band"
curl -sf -o "$work/picture.tif" "$map&LAYERS=bluemarble&TRANSPARENT=TRUE" || fail "GetMap bluemarble as image/tiff"
info=$(gdalinfo "$work/picture.tif")
[ "$(echo "$info" | grep -c '^Band .* Type=Byte')" = 4 ] || fail "imagery as TIFF: not 4 Byte bands: $info"
echo "$info" | grep -q "ColorInterp=Alpha" || fail "imagery as TIFF with TRANSPARENT: no alpha band: $info"

# A value layer's style (issue 24): the elevation layer coloured by the terrain map (cmocean
# topo: blues below sea level, land colours above), read by GDAL's WMS driver. The "WMS:" URL
# syntax drops STYLES, so a service description names it (<Styles>).
cat >"$work/terrain.xml" <<XML
<GDAL_WMS>
  <Service name="WMS"><Version>1.1.1</Version><ServerUrl>$base/wms?</ServerUrl><SRS>EPSG:4326</SRS>
    <ImageFormat>image/png</ImageFormat><Layers>etopo</Layers><Styles>terrain</Styles></Service>
  <DataWindow><UpperLeftX>-180</UpperLeftX><UpperLeftY>90</UpperLeftY><LowerRightX>180</LowerRightX>
    <LowerRightY>-90</LowerRightY><SizeX>1024</SizeX><SizeY>512</SizeY></DataWindow>
  <BandsCount>3</BandsCount>
</GDAL_WMS>
XML
gdal_translate -q -of GTiff -outsize 360 180 "$work/terrain.xml" "$work/etopo-terrain.tif" \
  || fail "GDAL could not read the styled GetMap (STYLES=terrain)"
colour() {
  # shellcheck disable=SC2086
  gdallocationinfo -valonly -wgs84 "$work/etopo-terrain.tif" $1 | tr '\n' ' '
}
python3 - "$(colour "86.9 28.0")" "$(colour "-150 0")" <<'PY' \
  || fail "STYLES=terrain: Himalaya '$(colour "86.9 28.0")', Pacific '$(colour "-150 0")'"
import sys
land = [int(v) for v in sys.argv[1].split()]
sea = [int(v) for v in sys.argv[2].split()]
sys.exit(0 if len(land) >= 3 and len(sea) >= 3 and sea[2] > sea[0] and land[0] > land[2] else 1)
PY

echo "gdal interop: all checks passed"
