#!/usr/bin/env bash
# Issue 27's configuration end to end: three `tellus serve` on different ports sharing ONE
# PostgreSQL index (tests/support/postgres.sh) and ONE S3 bucket (tests/support/s3-server.sh,
# Swift + s3api), each with its own root (its local tier), Varnish (tests/support/varnish.sh) in
# front of instance 0, a counting upstream (tests/support/counting_wms.py). Its own PostgreSQL and
# S3 server, not the ctest fixtures': the S3 front is killed and started again here, which would
# break the tests that share the fixture's. Checked:
#   1. 300 concurrent requests for one missing tile over the three instances and Varnish: exactly
#      one upstream request, every client 200 and the same bytes; p50/p99 printed;
#   2. the lease holder killed (-9) mid-fetch (a slow upstream): another instance answers the
#      waiting clients within 2 s;
#   3. the S3 front killed under load (stored and missing tiles over the three) and started again:
#      no torn or wrong tile served (one body per tile), afterwards every tile is served (no error
#      kept) and stored in the bucket (an instance that never saw it serves it, upstream not
#      asked), without restarting tellus;
#   4. `tellus seed --refresh` of a tile (same size, new bytes) against the shared index and
#      bucket: the three instances, whose local tiers hold the old copy, serve the new bytes, and
#      Varnish's copy is purged;
#   5. PostgreSQL stopped: stored tiles still served (local tier, bucket), a miss is a 503 and
#      /metrics says tellus_shared_index_up 0; started again: the miss is fetched and served by
#      every instance, without restarting tellus.
# Usage: test_scale_out_s3.sh path/to/tellus. 77: varnish or Swift not installed.
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/../.." && pwd)
support=$src/tests/support
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-scale-s3.XXXXXX")
pids=()
upstream=
cleanup() {
  for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null || true; done
  [ -n "$upstream" ] && kill "$upstream" 2>/dev/null || true
  "$support/varnish.sh" stop "$work/varnish" || true
  "$support/s3-server.sh" stop "$work/s3" >/dev/null 2>&1 || true
  "$support/postgres.sh" stop "$work/pg" || true
  [ -n "${KEEP:-}" ] || rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
command -v swift-proxy-server >/dev/null || { echo "skipped: no Swift"; exit 77; }
command -v varnishd >/dev/null || { echo "skipped: no varnishd"; exit 77; }

uri=$("$support/postgres.sh" start "$work/pg")
"$support/s3-server.sh" start "$work/s3" >/dev/null || fail "no S3 server"
# shellcheck disable=SC1091
. "$work/s3/s3.env"
export AWS_ACCESS_KEY_ID AWS_SECRET_ACCESS_KEY
python3 "$support/counting_wms.py" "$work/upstream.port" &
upstream=$!
for _ in $(seq 100); do [ -s "$work/upstream.port" ] && break; sleep 0.1; done
up=$(cat "$work/upstream.port")
[ -n "$up" ] || fail "the counting upstream did not start"

config() { # $1: purge URL or ""
  cat <<YAML
cache:
  index: "$uri"
  store: s3://$S3_BUCKET/scale
  s3: {endpoint: $S3_ENDPOINT, region: $S3_REGION}
server:
  cdn: {purge: [$1]}
upstreams:
  - {name: counted, type: wms, url: "http://127.0.0.1:$up/wms", version: 1.1.1, retries: 0}
  # one GetMap per tile: the counting upstream draws one colour per GetMap, so a tile fetched alone
  # and in a metatile differ; the S3 outage (3.) checks one body per tile, and the refresh (4.)
  # compares a tile with its refetch (metatiles on a shared index: test_scale_out.sh)
  - {name: single, type: wms, url: "http://127.0.0.1:$up/wms", version: 1.1.1, retries: 0, meta_tiles: 1}
layers:
  - {name: shared, upstream: single, format: image/png, grid: {level_zero_delta: 36, tile_size: 64, levels: 4}}
  - {name: fresh, upstream: single, format: image/png, cache: {ttl: 3s}, grid: {level_zero_delta: 36, tile_size: 64, levels: 4}}
YAML
}
config "" >"$work/tellus.yaml"

ports=()
start() { # $1: index (0..2); its own root; sets pids[$1], ports[$1]
  local log="$work/serve$1.log"
  "$tellus" serve --config "$work/tellus.yaml" --cache "$work/root$1" --listen 127.0.0.1:0 \
    --threads 4 >"$log" 2>&1 &
  pids[$1]=$!
  for _ in $(seq 150); do grep -qs "listening on" "$log" && break; sleep 0.1; done
  ports[$1]=$(grep -o "127.0.0.1:[0-9]*" "$log" | head -n 1 | cut -d: -f2 || true)
  [ -n "${ports[$1]}" ] || fail "serve $1 did not start: $(cat "$log")"
}
start 0
start 1
start 2
vport=$("$support/varnish.sh" start "$work/varnish" "${ports[0]}") || fail "varnish did not start"
config "http://127.0.0.1:$vport/" >"$work/seed.yaml"
getmaps() { curl -fsS "http://127.0.0.1:$up/stats" | python3 -c 'import json,sys; print(json.load(sys.stdin)["getmaps"])'; }
get() { # $1: port, $2: target, $3: output; prints the status
  curl -s -o "$3" -w '%{http_code}' "http://127.0.0.1:$1$2"
}

# --- 1. 300 concurrent requests for one missing tile over the three and Varnish -------------------
tile='/wwtile?T=shared&L=2&X=5&Y=3'
result=$(python3 "$here/burst.py" 300 "$tile" "${ports[@]}" "$vport") ||
  fail "the burst (not all 200, or several bodies): $result"
echo "burst of 300 over 3 instances + Varnish (PostgreSQL index, S3 store): $result"
[ "$(getmaps)" = 1 ] || fail "300 requests for one tile made $(getmaps) upstream requests"

# --- 2. the holder killed mid-fetch: another instance answers within 2 s ---------------------------
curl -fsS "http://127.0.0.1:$up/delay?ms=30000" >/dev/null
tile2='/wwtile?T=shared&L=2&X=9&Y=3' # not in the first tile's metatile
curl -s -o /dev/null "http://127.0.0.1:${ports[2]}$tile2" & # instance 2 takes the lease
holder_client=$!
for _ in $(seq 100); do [ "$(getmaps)" = 2 ] && break; sleep 0.05; done
[ "$(getmaps)" = 2 ] || fail "instance 2 did not fetch the second tile"
get "${ports[0]}" "$tile2" "$work/w0.png" >"$work/w0.code" &
w0=$!
get "${ports[1]}" "$tile2" "$work/w1.png" >"$work/w1.code" &
w1=$!
sleep 0.5
[ "$(getmaps)" = 2 ] || fail "a waiting instance fetched while the holder was alive"
curl -fsS "http://127.0.0.1:$up/delay?ms=0" >/dev/null
killed_at=$(date +%s.%N)
kill -9 "${pids[2]}"
wait "$w0" "$w1"
done_at=$(date +%s.%N)
wait "$holder_client" 2>/dev/null || true
took=$(python3 -c "print(round($done_at - $killed_at, 3))")
echo "holder killed: the waiting clients were answered ${took} s later"
[ "$(cat "$work/w0.code")" = 200 ] && [ "$(cat "$work/w1.code")" = 200 ] ||
  fail "waiting clients got $(cat "$work/w0.code") and $(cat "$work/w1.code")"
cmp -s "$work/w0.png" "$work/w1.png" || fail "the two instances served different bytes"
python3 -c "import sys; sys.exit(0 if $took < 2.0 else 1)" || fail "took ${took} s (> 2 s)"
[ "$(getmaps)" = 3 ] || fail "expected 3 upstream requests (two tiles, one refetch), got $(getmaps)"
start 2 # the killed instance back, on its old root

# --- 3. the S3 front killed under load and started again ----------------------------------------
targets=("$tile" "$tile2")
for x in 0 1 2 3 4 5; do targets+=("/wwtile?T=shared&L=3&X=$x&Y=7"); done
python3 "$here/load.py" "$work/stop" 8 "${ports[0]},${ports[1]},${ports[2]}" "${targets[@]}" \
  >"$work/load.json" &
load=$!
sleep 1
"$support/s3-server.sh" pause "$work/s3"
outage_from=$(getmaps)
# Tiles nobody asked for yet, asked while the store is down (misses that cannot be stored).
missing=()
for x in 0 1 2 3 4 5; do missing+=("/wwtile?T=shared&L=3&X=$x&Y=6"); done
python3 "$here/load.py" "$work/stop" 4 "${ports[0]},${ports[1]},${ports[2]}" "${missing[@]}" \
  >"$work/load2.json" &
load2=$!
sleep 2
outage_getmaps=$(($(getmaps) - outage_from))
"$support/s3-server.sh" resume "$work/s3" || fail "the S3 server did not come back"
sleep 1
touch "$work/stop"
wait "$load" || fail "the load: $(cat "$work/load.json")"
wait "$load2" || fail "the load: $(cat "$work/load2.json")"
echo "S3 killed and back under load, stored tiles: $(cat "$work/load.json")"
echo "S3 killed and back under load, missing tiles: $(cat "$work/load2.json")"
# What could not be stored is kept in memory: each instance asks the upstream for a missing tile
# about once (a request that looked just before a fetch landed may fetch it again), not once per
# request (TileServiceOptions::keepUnstoredBytes).
echo "GetMaps while S3 was down: $outage_getmaps for ${#missing[@]} missing tiles over 3 instances"
[ "$outage_getmaps" -le $((6 * ${#missing[@]})) ] ||
  fail "the outage's misses were fetched again and again: $outage_getmaps GetMaps"
for f in load load2; do
  python3 - "$work/$f.json" <<'PY' || fail "under the S3 restart: $(cat "$work/$f.json")"
import json, sys
r = json.load(open(sys.argv[1]))
assert r["torn"] == 0, "torn tiles served"
assert r["statuses"].get("200", 0) > 0, "nothing served"
many = {t: b for t, b in r["bodies"].items() if len(b) > 1}
assert not many, f"several bodies for one tile: {many}"
PY
done
targets+=("${missing[@]}")
before=$(getmaps)
for t in "${targets[@]}"; do
  for p in 0 1 2; do
    code=$(get "${ports[$p]}" "$t" "$work/after$p.png")
    [ "$code" = 200 ] || fail "after S3 came back instance $p answers $code for $t (an error kept?)"
  done
  cmp -s "$work/after0.png" "$work/after1.png" && cmp -s "$work/after0.png" "$work/after2.png" ||
    fail "the instances serve different bytes for $t"
done
# Stored in the bucket: a fourth instance with an empty local tier serves them all, upstream unasked.
start 3
for t in "${targets[@]}"; do
  [ "$(get "${ports[3]}" "$t" "$work/fresh.png")" = 200 ] || fail "a fresh instance: $t"
done
[ "$(getmaps)" = "$before" ] || fail "after S3 came back tiles were fetched again ($before -> $(getmaps)): not stored"
kill -9 "${pids[3]}"
unset 'pids[3]'

# --- 4. a refresh on one side is seen by every instance and purged from Varnish ----------------
# `seed --refresh` fetches again what has expired: a layer whose tiles expire after 3 s. The
# instances are asked at once after the refresh, before the new row expires (an instance that
# revalidated an expired tile itself would get the new bytes without the shared index's help).
ftile='/wwtile?T=fresh&L=2&X=5&Y=3'
for p in 0 1 2; do get "${ports[$p]}" "$ftile" "$work/old$p.png" >/dev/null; done # each local tier
get "$vport" "$ftile" "$work/oldv.png" >/dev/null
curl -s -D - -o /dev/null "http://127.0.0.1:$vport$ftile" | tr -d '\r' | grep -qi '^x-varnish: [0-9]* [0-9]*$' ||
  fail "the tile is not in Varnish before the refresh"
sleep 3.2 # expired
curl -fsS "http://127.0.0.1:$up/salt?v=refreshed" >/dev/null
"$tellus" seed --config "$work/seed.yaml" --cache "$work/seedroot" --layer fresh --levels 2 \
  --bbox -134,-62,-127,-55 --refresh >"$work/refresh.log" 2>&1 || fail "seed --refresh: $(cat "$work/refresh.log")"
grep -q " 1 written" "$work/refresh.log" || fail "seed --refresh did not refetch: $(cat "$work/refresh.log")"
grep -q "purged 1 keys at server.cdn.purge\[0\]" "$work/refresh.log" ||
  fail "seed --refresh did not purge Varnish: $(cat "$work/refresh.log")"
refreshed_at=$(date +%s.%N)
for p in 0 1 2 v; do
  if [ "$p" = v ]; then port=$vport; else port=${ports[$p]}; fi
  for _ in $(seq 10); do
    get "$port" "$ftile" "$work/new$p.png" >/dev/null
    cmp -s "$work/new$p.png" "$work/old0.png" || break
    sleep 0.05
  done
  ! cmp -s "$work/new$p.png" "$work/old0.png" || fail "instance $p still serves the old tile after the refresh"
  [ "$(stat -c %s "$work/new$p.png")" = "$(stat -c %s "$work/old0.png")" ] || fail "not the same size: the test is moot"
done
seen=$(python3 -c "import time; print(round(time.time() - $refreshed_at, 3))")
python3 -c "import sys; sys.exit(0 if $seen < 2.5 else 1)" || fail "the check took $seen s: the new row may have expired"
cmp -s "$work/new0.png" "$work/new1.png" && cmp -s "$work/new0.png" "$work/new2.png" && cmp -s "$work/new0.png" "$work/newv.png" ||
  fail "the refreshed tile differs between instances"
echo "refreshed by a seeder: the three instances and Varnish served the new bytes within ${seen} s"

# --- 5. PostgreSQL stopped and started: stored tiles served meanwhile, misses 503 -----------------
metric() { curl -fsS "http://127.0.0.1:$1/metrics" | awk -v m="$2" '$1 == m {print $2}'; }
get "${ports[0]}" "$tile" "$work/db0.png" >/dev/null
"$support/postgres.sh" pause "$work/pg"
for p in 1 2; do
  # The first request after the server left may meet a pooled connection that only then breaks.
  for _ in $(seq 3); do
    code=$(get "${ports[$p]}" "$tile" "$work/dbdown$p.png")
    [ "$code" = 200 ] && break
  done
  [ "$code" = 200 ] || fail "instance $p did not serve a stored tile with the database down: $code"
  cmp -s "$work/dbdown$p.png" "$work/db0.png" || fail "instance $p served other bytes without the index"
done
dbtile='/wwtile?T=shared&L=1&X=9&Y=4' # asked by nobody so far
before=$(getmaps)
code=$(get "${ports[1]}" "$dbtile" "$work/dbmiss.png")
[ "$code" = 503 ] || fail "a miss with the database down: $code, not 503"
[ "$(metric "${ports[1]}" tellus_shared_index_up)" = 0 ] || fail "/metrics does not say the index is down"
[ "$(getmaps)" = "$before" ] || fail "an instance fetched with the database down"
"$support/postgres.sh" resume "$work/pg"
for _ in $(seq 50); do
  code=$(get "${ports[1]}" "$dbtile" "$work/dbback1.png")
  [ "$code" = 200 ] && break
  sleep 0.1
done
[ "$code" = 200 ] || fail "the database back, a miss is still $code"
# The lease listener listens again on its own (every 200 ms while it cannot): /metrics follows it.
for _ in $(seq 50); do
  [ "$(metric "${ports[1]}" tellus_shared_index_up)" = 1 ] && break
  sleep 0.1
done
[ "$(metric "${ports[1]}" tellus_shared_index_up)" = 1 ] || fail "/metrics still says the index is down after 5 s"
for _ in $(seq 50); do
  code=$(get "${ports[2]}" "$dbtile" "$work/dbback2.png")
  [ "$code" = 200 ] && break
  sleep 0.1
done
cmp -s "$work/dbback1.png" "$work/dbback2.png" || fail "instance 2 did not serve instance 1's tile"
echo "PostgreSQL stopped and started: stored tiles served from the tiers and the bucket meanwhile, service resumed without restarts"
echo "PASS"
