#!/usr/bin/env bash
# NASA GIBS as a WMTS upstream through `tellus serve` (issue 25): a fake GIBS of our own
# (tests/cli/wmts_upstream.py) serves GIBS's real capabilities document (tests/data/wmts) and
# tiles in GIBS's layout. Checked:
#   - a /wwtile of level 0 is the upstream's tile of matrix 3 (GIBS level n + 3 is World Wind level
#     n), byte for byte, its row counted from the top (World Wind row 0 is GIBS row 4), through
#     the REST template and through KVP GetTile;
#   - a tile at another TIME (/tiles/...?time=) asks the upstream for that time;
#   - a 500 from the upstream is a 5xx here and caches nothing (asked again next time);
#   - a second start with --offline reads the saved capabilities and serves the cached tiles;
#   - a configured tile matrix set the layer does not link stops the start with a message that
#     names the one it links.
# Usage: test_wmts.sh path/to/tellus
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/../.." && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-wmts.XXXXXX")
server=
upstream=
cleanup() {
  [ -n "$server" ] && kill "$server" 2>/dev/null || true
  [ -n "$upstream" ] && kill "$upstream" 2>/dev/null || true
  [ -n "${KEEP:-}" ] || rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

mkdir -p "$work/tiles"
python3 "$here/wmts_upstream.py" "$src/tests/data/wmts/gibs-geographic-2014.xml" "$work/port" \
  "$work/upstream.log" "$work/tiles" &
upstream=$!
for _ in $(seq 100); do [ -s "$work/port" ] && break; sleep 0.1; done
up=$(cat "$work/port")
[ -n "$up" ] || fail "the fake WMTS did not start"

config() { # $1: tile matrix set of the layer "sst"
  cat <<YAML
upstreams:
  - name: gibs
    type: wmts
    url: http://127.0.0.1:$up/wmts-geo/1.0.0/WMTSCapabilities.xml
    retries: 0
  - name: gibs-kvp
    type: wmts
    url: http://127.0.0.1:$up/wmts-geo/1.0.0/WMTSCapabilities.xml
    encoding: kvp
    retries: 0
layers:
  - name: sst
    upstream: gibs
    upstream_layer: Sea_Surface_Temp_Blended
    tile_matrix_set: $1
    format: image/png
    grid: {level_zero_delta: 36, tile_size: 512, levels: 4}
    time: {values: [2000-01-01, 2013-06-01, 2014-02-04]}
  - name: sst-kvp
    upstream: gibs-kvp
    upstream_layer: Sea_Surface_Temp_Blended
    format: image/png
    grid: {level_zero_delta: 36, tile_size: 512, levels: 4}
    time: {values: [2013-06-01, 2014-02-04]}
YAML
}

start() { # $1: config, $2: log; extra arguments follow
  local cfg=$1 log=$2
  shift 2
  "$tellus" serve --config "$cfg" --cache "$work/cache" --listen 127.0.0.1:0 "$@" >"$log" 2>&1 &
  server=$!
  for _ in $(seq 100); do grep -qs "listening on" "$log" && break; sleep 0.1; done
  port=$(grep -o "127.0.0.1:[0-9]*" "$log" | head -n 1 | cut -d: -f2)
  [ -n "$port" ] || fail "serve did not start: $(cat "$log")"
}
stop() {
  kill -TERM "$server"
  wait "$server" || fail "serve did not stop cleanly"
  server=
}
get() { # $1: target, $2: output file; prints the status
  curl -s -o "$2" -w "%{http_code}" "http://127.0.0.1:$port$1"
}

config EPSG4326_1km >"$work/tellus.yaml"
start "$work/tellus.yaml" "$work/serve.txt"

# Level 0, column 3, row 0 (the southernmost): GIBS matrix 3, row 4, column 3, default time.
[ "$(get '/wwtile?T=sst&L=0&X=3&Y=0' "$work/a.png")" = 200 ] || fail "wwtile: $(cat "$work/a.png")"
cmp -s "$work/a.png" "$work/tiles/2014-02-04_3_4_3.png" || fail "the tile is not the upstream's bytes"
grep -q "^/wmts-geo/Sea_Surface_Temp_Blended/default/2014-02-04/EPSG4326_1km/3/4/3.png$" \
  "$work/upstream.log" || fail "REST request not as GIBS lays it out: $(tail -n 3 "$work/upstream.log")"
# Level 3 (GIBS matrix 6, 80 x 40): row 2 from the south is row 37 from the top.
[ "$(get '/wwtile?T=sst&L=3&X=50&Y=2' "$work/b.png")" = 200 ] || fail "wwtile level 3"
cmp -s "$work/b.png" "$work/tiles/2014-02-04_6_37_50.png" || fail "level 3 is not the upstream's tile"
# KVP GetTile, another time.
[ "$(get '/tiles/sst-kvp/1/9/9_0.png?time=2013-06-01' "$work/c.png")" = 200 ] || fail "kvp"
cmp -s "$work/c.png" "$work/tiles/2013-06-01_4_0_0.png" || fail "the KVP tile is not the upstream's"
grep -q "^/wmts-geo/wmts.cgi?SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=Sea_Surface_Temp_Blended&STYLE=default&FORMAT=image%2Fpng&TILEMATRIXSET=EPSG4326_1km&TILEMATRIX=4&TILEROW=0&TILECOL=0&TIME=2013-06-01$" \
  "$work/upstream.log" || fail "KVP request: $(tail -n 1 "$work/upstream.log")"
# A 500 upstream: 503 here, nothing cached, asked again.
for _ in 1 2; do
  status=$(get '/tiles/sst/0/1/1_1.png?time=2000-01-01' "$work/d.txt")
  case $status in 5??) ;; *) fail "a 500 upstream answered $status here" ;; esac
done
[ "$(grep -c '/2000-01-01/EPSG4326_1km/3/3/1.png$' "$work/upstream.log")" = 2 ] ||
  fail "a failed tile was not asked for again"
stop
[ -s "$work/cache/wmts-capabilities/gibs.xml" ] || fail "the capabilities were not saved"

# Offline: the saved capabilities, the cached tiles.
start "$work/tellus.yaml" "$work/offline.txt" --offline
[ "$(get '/wwtile?T=sst&L=0&X=3&Y=0' "$work/e.png")" = 200 ] || fail "offline: $(cat "$work/e.png")"
cmp -s "$work/e.png" "$work/a.png" || fail "offline tile differs"
stop

# A set the layer does not link: refused at start, naming the one it links.
config EPSG4326_250m >"$work/bad.yaml"
if "$tellus" serve --config "$work/bad.yaml" --cache "$work/cache" --listen 127.0.0.1:0 \
  >"$work/bad.txt" 2>&1; then
  fail "serve started with a tile matrix set the layer does not link"
fi
grep -q "it links 'EPSG4326_1km'" "$work/bad.txt" || fail "unclear refusal: $(cat "$work/bad.txt")"
echo "ok: WMTS upstream through tellus serve"
