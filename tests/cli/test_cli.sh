#!/usr/bin/env bash
# End to end through the tellus executable, as a user runs it: seed, stats, verify, damage, rebuild,
# prune (render and view: test_render.sh and test_view.sh, under xvfb-run).
set -euo pipefail
tellus=$1
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-cli.XXXXXX")
trap 'rm -rf "$work"' EXIT
cache="$work/cache"
fail() { echo "FAIL: $*" >&2; exit 1; }

out=$("$tellus" seed --cache "$cache" --layer bluemarble --levels 0-1 --dry-run)
echo "$out" | grep -q "250 tiles planned" || fail "dry run count: $out"

out=$("$tellus" seed --cache "$cache" --layer bluemarble --levels 0-1 --bbox -40,-10,40,10)
echo "$out" | grep -q "16 tiles planned, 0 already cached, 16 written" || fail "seed: $out"
out=$("$tellus" seed --cache "$cache" --layer bluemarble --levels 0-1 --bbox -40,-10,40,10)
echo "$out" | grep -q "16 already cached, 0 written" || fail "resume: $out"
[ -f "$cache"/local/bluemarble-*/0/2/2_4.jpg ] || fail "World Wind path 0/2/2_4.jpg missing"

json=$("$tellus" cache stats --json --cache "$cache")
python3 - "$json" <<'PY'
import json, sys
s = json.loads(sys.argv[1])
assert s["tiles"] == 16, s
d = s["datasets"][0]
assert d["name"] == "bluemarble" and d["pinned"] is True, d
assert [l["tiles"] for l in d["levels"]] == [4, 12], d
PY

"$tellus" cache verify --cache "$cache" >/dev/null || fail "verify on a clean cache"
rm "$cache"/local/bluemarble-*/0/2/2_4.jpg
set +e
"$tellus" cache verify --cache "$cache" >"$work/verify.txt"
rc=$?
set -e
[ $rc -eq 3 ] || fail "verify should exit 3 on a damaged cache, got $rc"
grep -q "index rows without files: 1" "$work/verify.txt" || fail "verify report: $(cat "$work/verify.txt")"
"$tellus" cache rebuild --cache "$cache" | grep -q "15 tiles" || fail "rebuild count"
"$tellus" cache verify --cache "$cache" >/dev/null || fail "verify after rebuild"

# Temp files of a writer that was killed (its pid is in the name and names no process now): one
# where writers put them (<dataset>/.tmp, removed when the cache is opened), one beside the tiles
# where earlier versions wrote them (a problem for verify until rebuild removes it). The pid is
# above any Linux pid_max: a just-exited process's pid could be reused on a busy machine.
dead=2147483646
ds=$(echo "$cache"/local/bluemarble-*)
mkdir -p "$ds/.tmp"
echo partial >"$ds/.tmp/.2_5.jpg.$dead-1.0.tmp"
echo partial >"$ds/1/4/.4_9.jpg.$dead.4.tmp"
set +e
"$tellus" cache verify --cache "$cache" >"$work/verify.txt"
rc=$?
set -e
[ $rc -eq 3 ] || fail "verify should exit 3 with a stray temp file, got $rc: $(cat "$work/verify.txt")"
grep -q "stray temp files: 1" "$work/verify.txt" || fail "verify temp report: $(cat "$work/verify.txt")"
grep -q "1/4/.4_9.jpg.$dead.4.tmp" "$work/verify.txt" || fail "verify lists: $(cat "$work/verify.txt")"
[ ! -e "$ds/.tmp/.2_5.jpg.$dead-1.0.tmp" ] || fail "a dead writer's temp file survived opening the cache"
"$tellus" cache rebuild --cache "$cache" >/dev/null || fail "rebuild with a stray temp file"
[ ! -e "$ds/1/4/.4_9.jpg.$dead.4.tmp" ] || fail "rebuild left a stray temp file"
"$tellus" cache verify --cache "$cache" >/dev/null || fail "verify after rebuild removed the temp file"

"$tellus" cache prune --older-than 0s --cache "$cache" | grep -q "pruned 0 tiles" || fail "prune keeps pinned"
"$tellus" cache prune --older-than 0s --include-pinned --cache "$cache" | grep -q "pruned 15 tiles" || fail "prune pinned"

# The imaging module (OpenImageIO inside) is loaded only where a tile is encoded or decoded: a
# missing one fails the tiles that need it, with a message that names it.
set +e
TELLUS_IMAGING_MODULE=/nonexistent/libtellus_imaging.so "$tellus" seed --cache "$work/nomodule" \
  --layer bluemarble --levels 0-0 --bbox 1,-1,2,1 >"$work/nomodule.txt" 2>&1; rc=$?
set -e
[ $rc -eq 3 ] || fail "seed without the imaging module should exit 3, got $rc"
grep -q "cannot load the imaging module /nonexistent/libtellus_imaging.so" "$work/nomodule.txt" \
  || fail "no clear error without the imaging module: $(cat "$work/nomodule.txt")"

# Tile 0/2/5 cached again, for serve to answer from the cache.
"$tellus" seed --cache "$cache" --layer bluemarble --levels 0-0 --bbox 1,-1,2,1 | grep -q "1 written" \
  || fail "reseed of 0/2/5"

# A bad --threads is a usage error (exit 2) that names the option.
set +e
"$tellus" serve --cache "$cache" --listen 127.0.0.1:0 --threads many >"$work/threads.txt" 2>&1
rc=$?
set -e
[ "$rc" = 2 ] || fail "--threads many exited $rc"
grep -q -- "--threads must be 0-256" "$work/threads.txt" || fail "no --threads message: $(cat "$work/threads.txt")"

# tellus serve as a user starts it: any free port, read back from what it prints; then SIGTERM.
"$tellus" serve --cache "$cache" --listen 127.0.0.1:0 --threads 2 >"$work/serve.txt" 2>&1 &
server=$!
for _ in $(seq 600); do grep -q "listening on" "$work/serve.txt" && break; kill -0 $server 2>/dev/null || break; sleep 0.1; done
port=$(grep -o "127.0.0.1:[0-9]*" "$work/serve.txt" | head -n 1 | cut -d: -f2)
[ -n "$port" ] || fail "serve did not say where it listens: $(cat "$work/serve.txt")"
imaging_mapped() { grep -Eq "libtellus_imaging|libOpenImageIO" "/proc/$server/maps"; }
! imaging_mapped || fail "serve loaded OpenImageIO before any tile needed it"
code=$(curl -s -D "$work/hit.hdr" -o "$work/tile.jpg" -w "%{http_code}" "http://127.0.0.1:$port/wwtile?T=bluemarble&L=0&X=5&Y=2")
[ "$code" = 200 ] || fail "wwtile answered $code"
head -c 3 "$work/tile.jpg" | od -An -tx1 | grep -q "ff d8 ff" || fail "not a JPEG"
grep -qi "^X-Cache: HIT" "$work/hit.hdr" || fail "0/2/5 was not a cache hit: $(cat "$work/hit.hdr")"
! imaging_mapped || fail "a cache hit loaded OpenImageIO"
code=$(curl -s -o "$work/miss.jpg" -w "%{http_code}" "http://127.0.0.1:$port/wwtile?T=bluemarble&L=0&X=0&Y=0")
[ "$code" = 200 ] || fail "a miss answered $code"
head -c 3 "$work/miss.jpg" | od -An -tx1 | grep -q "ff d8 ff" || fail "the miss is not a JPEG"
imaging_mapped || fail "a miss rendered without loading the imaging module?"
code=$(curl -s -o /dev/null -w "%{http_code}" "http://127.0.0.1:$port/wwtile?T=bluemarble&L=0&X=99&Y=2")
[ "$code" = 404 ] || fail "outside the grid answered $code"
# Into a file first: grep -q leaving early would break curl's pipe (pipefail) on a long document.
curl -s -o "$work/caps.xml" "http://127.0.0.1:$port/wms?SERVICE=WMS&REQUEST=GetCapabilities"
grep -q "<Name>etopo</Name>" "$work/caps.xml" \
  || fail "capabilities without the etopo layer"
kill -TERM $server
wait $server || fail "serve did not stop cleanly on SIGTERM"

set +e
"$tellus" seed --levels 3-1 >/dev/null 2>&1; rc=$?
set -e
[ $rc -eq 2 ] || fail "bad --levels should be a usage error, got $rc"
for bad in 0 17 2.5; do
  set +e
  "$tellus" seed --meta-tiles "$bad" --dry-run >"$work/meta.txt" 2>&1; rc=$?
  set -e
  [ $rc -eq 2 ] || fail "--meta-tiles $bad should be a usage error, got $rc"
  grep -q -- "--meta-tiles" "$work/meta.txt" || fail "--meta-tiles $bad: $(cat "$work/meta.txt")"
done
# GeoPackage: export levels 0-1 of bluemarble, read by GDAL where the cached tile says; import back.
# Europe only (lon 0..36, lat 36..54): 1 tile at level 0 and 2 at level 1.
"$tellus" seed --cache "$work/gcache" --layer bluemarble --levels 0-1 --bbox 1,37,35,53 >/dev/null \
  || fail "seed for export"
"$tellus" cache export --cache "$work/gcache" --layer bluemarble --levels 0-1 --gpkg "$work/bm.gpkg" \
  >"$work/export.txt" || fail "export: $(cat "$work/export.txt")"
grep -q "exported bluemarble: 3 tiles" "$work/export.txt" || fail "export said: $(cat "$work/export.txt")"
command -v gdallocationinfo >/dev/null || fail "gdallocationinfo (gdal-bin) is needed for the GeoPackage check"
grep -q "Size is 10240, 5120" <<<"$(gdalinfo "$work/bm.gpkg")" || fail "GDAL does not see a 10240x5120 raster"
# Level 1, row 7 (from the south), column 10: 18 degrees, lat 36..54, lon 0..18 (Europe). The same
# JPEG with a world file must give GDAL the same pixel as the GeoPackage (rows flipped right).
tile=$(ls "$work"/gcache/*/bluemarble-*/1/7/7_10.jpg)
cp "$tile" "$work/t.jpg"
printf '%s\n' 0.03515625 0 0 -0.03515625 0.017578125 53.982421875 >"$work/t.jgw"
for point in "10.0 45.0" "1.0 53.5" "17.5 36.4"; do
  # shellcheck disable=SC2086
  a=$(gdallocationinfo -valonly -wgs84 "$work/bm.gpkg" $point | head -n 3 | tr '\n' ' ')
  # shellcheck disable=SC2086
  b=$(gdallocationinfo -valonly -geoloc "$work/t.jpg" $point | tr '\n' ' ')
  [ -n "$a" ] && [ "$a" = "$b" ] || fail "GeoPackage pixel at $point is '$a', the tile's '$b'"
done
"$tellus" cache import --cache "$work/cache2" --layer bluemarble --gpkg "$work/bm.gpkg" \
  >"$work/import.txt" || fail "import: $(cat "$work/import.txt")"
grep -q "imported bluemarble: 3 tiles" "$work/import.txt" || fail "import said: $(cat "$work/import.txt")"
cmp "$tile" "$(ls "$work"/cache2/*/bluemarble-*/1/7/7_10.jpg)" || fail "imported tile differs"

# TIME: a daily layer (a period) seeds its default time, a listed time, and refuses the rest.
data=$(cd "$(dirname "$0")/../../data" && pwd)
cat >"$work/daily.yaml" <<YAML
upstreams:
  - {name: local, type: local, path: $data/bmng_2048x1024.jpg}
layers:
  - name: daily
    upstream: local
    format: image/jpeg
    grid: {level_zero_delta: 36, tile_size: 512, levels: 1}
    time: {period: 2024-01-01/2024-01-31/P1D}
YAML
tcache="$work/tcache"
out=$("$tellus" seed --config "$work/daily.yaml" --cache "$tcache" --layer daily --levels 0 \
  --bbox -30,-30,30,30) || fail "seed at the default time: $out"
echo "$out" | grep -q "6 written" || fail "seed at the default time: $out"
out=$("$tellus" seed --config "$work/daily.yaml" --cache "$tcache" --layer daily --levels 0 \
  --bbox -30,-30,30,30 --time 2024-01-15) || fail "seed at 2024-01-15: $out"
echo "$out" | grep -q "6 written" || fail "a second time is a second set of tiles: $out"
for bad in 2024-02-01 2024-1-5 yesterday; do
  if err=$("$tellus" seed --config "$work/daily.yaml" --cache "$tcache" --layer daily --levels 0 \
    --time "$bad" 2>&1); then fail "--time $bad was accepted: $err"; fi
  echo "$err" | grep -q "TIME is not one of the layer's times" || fail "--time $bad: $err"
done
if err=$("$tellus" seed --cache "$tcache" --layer bluemarble --levels 0 --time 2024-01-15 2>&1); then
  fail "--time for a layer without TIME was accepted"
fi
echo "$err" | grep -q "no TIME dimension" || fail "no TIME dimension: $err"
# Several times (issue 24): a range on the daily grid seeds each time in turn; a range or list with
# a time the layer does not declare is refused by name before anything is fetched; too many.
out=$("$tellus" seed --config "$work/daily.yaml" --cache "$tcache" --layer daily --levels 0 \
  --bbox -30,-30,30,30 --time 2024-01-20/2024-01-24/P2D) || fail "seed a range: $out"
echo "$out" | grep -q "daily: time 3 of 3: 2024-01-24" || fail "seed a range, per time: $out"
[ "$(echo "$out" | grep -c "6 written")" = 3 ] || fail "a range of three times: $out"
out=$("$tellus" seed --config "$work/daily.yaml" --cache "$tcache" --layer daily --levels 0 \
  --bbox -30,-30,30,30 --time 2024-01-20T00:00:00Z,2024-01-25) || fail "seed a list: $out"
echo "$out" | grep -q "time 1 of 2: 2024-01-20$" || fail "the layer's spelling of a time: $out"
echo "$out" | grep -q "6 already cached, 0 written" || fail "a time seeded before is cached: $out"
before=$("$tellus" cache stats --json --cache "$tcache" | python3 -c 'import json,sys; print(json.load(sys.stdin)["tiles"])')
for bad in "2024-01-30/2024-02-02/P1D:2024-02-01" "2024-01-01/2024-01-02/PT12H:2024-01-01T12:00:00Z" \
  "2024-01-05,2024-03-01:2024-03-01"; do
  range=${bad%%:[0-9]*}
  named=${bad#"$range":}
  if err=$("$tellus" seed --config "$work/daily.yaml" --cache "$tcache" --layer daily --levels 0 \
    --time "$range" 2>&1); then fail "--time $range was accepted: $err"; fi
  echo "$err" | grep -qF "does not declare $named" || fail "--time $range: $err"
done
if err=$("$tellus" seed --config "$work/daily.yaml" --cache "$tcache" --layer daily --levels 0 \
  --time 2024-01-01T00:00:00Z/2024-01-31T00:00:00Z/PT1M 2>&1); then fail "a huge range was accepted"; fi
echo "$err" | grep -q "more than 1000 instants" || fail "a huge range: $err"
after=$("$tellus" cache stats --json --cache "$tcache" | python3 -c 'import json,sys; print(json.load(sys.stdin)["tiles"])')
[ "$before" = "$after" ] || fail "a refused --time seeded tiles: $before -> $after"

# server.jpeg_quality reaches the maps tellus composes: the first luma quantisation step of a
# GetMap that is not one tile is 16 at quality 50 (libjpeg's table unscaled; 3 at the default 90).
cat >"$work/q50.yaml" <<YAML
server: {jpeg_quality: 50}
upstreams:
  - {name: local, type: local, path: $data/bmng_2048x1024.jpg}
layers:
  - name: bm
    upstream: local
    format: image/jpeg
    grid: {level_zero_delta: 36, tile_size: 512, levels: 2}
YAML
"$tellus" serve --config "$work/q50.yaml" --cache "$work/qcache" --listen 127.0.0.1:0 \
  >"$work/qserve.txt" 2>&1 &
server=$!
for _ in $(seq 600); do grep -q "listening on" "$work/qserve.txt" && break; kill -0 $server 2>/dev/null || break; sleep 0.1; done
port=$(grep -o "127.0.0.1:[0-9]*" "$work/qserve.txt" | head -n 1 | cut -d: -f2)
[ -n "$port" ] || fail "serve (q50) did not say where it listens: $(cat "$work/qserve.txt")"
code=$(curl -s -o "$work/q50.jpg" -w "%{http_code}" "http://127.0.0.1:$port/wms?SERVICE=WMS&VERSION=1.1.1&REQUEST=GetMap&LAYERS=bm&STYLES=&SRS=EPSG:4326&BBOX=-30,-20,40,30&WIDTH=300&HEIGHT=200&FORMAT=image/jpeg")
kill -TERM $server
wait $server || fail "serve (q50) did not stop cleanly on SIGTERM"
[ "$code" = 200 ] || fail "composed GetMap answered $code"
python3 - "$work/q50.jpg" <<'PY' || fail "the composed map is not quality 50"
import sys
b = open(sys.argv[1], "rb").read()
assert b[:2] == b"\xff\xd8", "not a JPEG"
i = b.index(b"\xff\xdb")
assert b[i + 5] == 16, f"first luma step {b[i + 5]}"
PY

# A full disk (issue 21): seed onto a 2 MiB tmpfs, and onto one without inodes left, then serve
# from the full one. The tmpfs is mounted in a private mount namespace: a user namespace where
# that is allowed (unprivileged), else a plain one (root).
if unshare -rm true 2>/dev/null; then
  ns="unshare -rm"
elif unshare -m true 2>/dev/null; then
  ns="unshare -m"
else
  ns=""
fi
if [ -z "$ns" ]; then
  echo "SKIPPED!!! cli full-disk checks: neither 'unshare -rm' nor 'unshare -m' can make a mount namespace here" >&2
else
  mkdir -p "$work/full" "$work/noinodes"
  cat >"$work/full.sh" <<'SH'
set -eu
tellus=$1 work=$2
mnt=$work/full
mount -t tmpfs -o size=2m,nr_inodes=4096 tmpfs "$mnt"
set +e
"$tellus" seed --cache "$mnt/c" --layer bluemarble --levels 0-2 >"$work/full-seed.txt" 2>&1
echo $? >"$work/full-seed.rc"
set -e
"$tellus" cache stats --json --cache "$mnt/c" >"$work/full-stats.json"
set +e
"$tellus" cache verify --cache "$mnt/c" >"$work/full-verify.txt" 2>&1
echo $? >"$work/full-verify.rc"
set -e
dd if=/dev/zero of="$mnt/filler" bs=4k >/dev/null 2>&1 || true
"$tellus" serve --cache "$mnt/c" --listen 127.0.0.1:0 >"$work/full-serve.txt" 2>&1 &
server=$!
for _ in $(seq 600); do grep -q "listening on" "$work/full-serve.txt" && break; kill -0 $server 2>/dev/null || break; sleep 0.1; done
port=$(grep -o "127.0.0.1:[0-9]*" "$work/full-serve.txt" | head -n 1 | cut -d: -f2)
if [ -n "$port" ]; then
  curl -s -D "$work/full-hit.hdr" -o /dev/null -w "%{http_code}" \
    "http://127.0.0.1:$port/wwtile?T=bluemarble&L=0&X=0&Y=0" >"$work/full-hit.code"
  curl -s -D "$work/full-miss.hdr" -o "$work/full-miss.jpg" -w "%{http_code}" \
    "http://127.0.0.1:$port/wwtile?T=bluemarble&L=2&X=7&Y=3" >"$work/full-miss.code"
  curl -s "http://127.0.0.1:$port/metrics" >"$work/full-metrics.txt"
  kill -TERM $server
fi
wait $server || echo "serve exited $?" >>"$work/full-serve.txt"
mnt=$work/noinodes
mount -t tmpfs -o size=16m,nr_inodes=40 tmpfs "$mnt"
set +e
"$tellus" seed --cache "$mnt/c" --layer bluemarble --levels 0-2 >"$work/noinodes-seed.txt" 2>&1
echo $? >"$work/noinodes-seed.rc"
set -e
"$tellus" cache verify --cache "$mnt/c" >"$work/noinodes-verify.txt" 2>&1 || true
SH
  $ns sh "$work/full.sh" "$tellus" "$work" || fail "the full-disk script failed under $ns"
  seedout=$(cat "$work/full-seed.txt")
  [ "$(cat "$work/full-seed.rc")" = 4 ] || fail "seed onto a full disk should exit 4, got $(cat "$work/full-seed.rc"): $seedout"
  echo "$seedout" | grep -q "stopped, the cache refuses tiles: the cache at $work/full/c is full (" \
    || fail "seed onto a full disk does not name the cache and its free space: $seedout"
  written=$(echo "$seedout" | grep -o "[0-9]* written" | cut -d" " -f1)
  stored=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["tiles"])' "$work/full-stats.json")
  [ -n "$written" ] && [ "$written" = "$stored" ] || fail "seed said $written written, the cache holds $stored: $seedout"
  [ "$(cat "$work/full-verify.rc")" = 0 ] || fail "verify after a full-disk seed: $(cat "$work/full-verify.txt")"
  grep -q "listening on" "$work/full-serve.txt" || fail "serve did not start on a full disk: $(cat "$work/full-serve.txt")"
  [ "$(cat "$work/full-hit.code")" = 200 ] || fail "a cached tile on a full disk answered $(cat "$work/full-hit.code")"
  grep -qi "^X-Cache: HIT" "$work/full-hit.hdr" || fail "not a hit: $(cat "$work/full-hit.hdr")"
  [ "$(cat "$work/full-miss.code")" = 200 ] || fail "a miss on a full disk answered $(cat "$work/full-miss.code")"
  head -c 3 "$work/full-miss.jpg" | od -An -tx1 | grep -q "ff d8 ff" || fail "the miss on a full disk is not a JPEG"
  grep -q "^tellus_cache_writable 0$" "$work/full-metrics.txt" || fail "metrics do not say the cache is full: $(grep tellus_cache "$work/full-metrics.txt")"
  grep -q "^tellus_cache_store_refused_total 1$" "$work/full-metrics.txt" || fail "refused stores: $(grep tellus_cache "$work/full-metrics.txt")"
  [ "$(grep -c "the cache is full" "$work/full-serve.txt")" = 1 ] || fail "serve's log: $(cat "$work/full-serve.txt")"
  seedout=$(cat "$work/noinodes-seed.txt")
  [ "$(cat "$work/noinodes-seed.rc")" = 4 ] || fail "seed without inodes left should exit 4, got $(cat "$work/noinodes-seed.rc"): $seedout"
  echo "$seedout" | grep -q " 0 inodes free)" || fail "seed without inodes does not say so: $seedout"
  grep -q "cache is consistent" "$work/noinodes-verify.txt" || fail "verify without inodes: $(cat "$work/noinodes-verify.txt")"
fi

echo "cli: all checks passed"
