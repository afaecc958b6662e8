#!/usr/bin/env bash
# `tellus serve` with its tiles in S3 (issue 27, `cache.store: s3://...`): a real S3 server on
# loopback (tests/support/s3-server.sh: Swift + s3api; TELLUS_S3_ENV names a running one's s3.env,
# else one is started here) and the fake GIBS of test_wmts.sh as the upstream. Checked:
#   - a tile fetched upstream is served and stored in the bucket and in the local tier (the file
#     tree under the cache root; the index stays local, SQLite), whose bytes /metrics shows (the
#     tier is bounded: cache.s3.local_tier_limit);
#   - with the local tier, index and folder gone, `tellus cache rebuild` finds the tile in the
#     bucket and `serve --offline` serves it from there, byte for byte, the upstream not asked;
#   - wrong credentials stop the start with a message that names the bucket and the endpoint but
#     not the key; the credentials appear in no log.
# Usage: test_s3_serve.sh path/to/tellus
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/../.." && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-s3.XXXXXX")
server=
upstream=
own_s3=
cleanup() {
  [ -n "$server" ] && kill "$server" 2>/dev/null || true
  [ -n "$upstream" ] && kill "$upstream" 2>/dev/null || true
  [ -n "$own_s3" ] && "$src/tests/support/s3-server.sh" stop "$own_s3" || true
  [ -n "${KEEP:-}" ] || rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

env_file=${TELLUS_S3_ENV:-}
if [ -z "$env_file" ]; then
  own_s3=$work/s3
  "$src/tests/support/s3-server.sh" start "$own_s3" >/dev/null || fail "no S3 server"
  env_file=$own_s3/s3.env
fi
# shellcheck disable=SC1090
. "$env_file"
export AWS_ACCESS_KEY_ID AWS_SECRET_ACCESS_KEY
prefix="serve-$$-$(date +%s%N)"

mkdir -p "$work/tiles"
python3 "$here/wmts_upstream.py" "$src/tests/data/wmts/gibs-geographic-2014.xml" "$work/port" \
  "$work/upstream.log" "$work/tiles" &
upstream=$!
for _ in $(seq 100); do [ -s "$work/port" ] && break; sleep 0.1; done
up=$(cat "$work/port")
[ -n "$up" ] || fail "the fake WMTS did not start"

cat >"$work/tellus.yaml" <<YAML
cache:
  store: s3://$S3_BUCKET/$prefix
  s3: {endpoint: $S3_ENDPOINT, region: $S3_REGION, local_tier_limit: 64 MiB}
upstreams:
  - name: gibs
    type: wmts
    url: http://127.0.0.1:$up/wmts-geo/1.0.0/WMTSCapabilities.xml
    retries: 0
layers:
  - name: sst
    upstream: gibs
    upstream_layer: Sea_Surface_Temp_Blended
    tile_matrix_set: EPSG4326_1km
    format: image/png
    grid: {level_zero_delta: 36, tile_size: 512, levels: 4}
    time: {values: [2013-06-01, 2014-02-04]}
YAML

start() { # $1: log; extra arguments follow
  local log=$1
  shift
  "$tellus" serve --config "$work/tellus.yaml" --cache "$work/cache" --listen 127.0.0.1:0 "$@" \
    >"$log" 2>&1 &
  server=$!
  for _ in $(seq 150); do grep -qs "listening on" "$log" && break; sleep 0.1; done
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

start "$work/serve.txt"
[ "$(get '/wwtile?T=sst&L=0&X=3&Y=0' "$work/a.png")" = 200 ] || fail "wwtile: $(cat "$work/a.png")"
cmp -s "$work/a.png" "$work/tiles/2014-02-04_3_4_3.png" || fail "the tile is not the upstream's bytes"
asked=$(grep -c '/2014-02-04/EPSG4326_1km/3/4/3.png$' "$work/upstream.log")
[ "$asked" = 1 ] || fail "the upstream was asked $asked times"
[ "$(get /metrics "$work/metrics.txt")" = 200 ] || fail "/metrics"
grep -q '^tellus_cache_local_tier_bytes [1-9]' "$work/metrics.txt" ||
  fail "no local tier bytes in /metrics: $(grep local_tier "$work/metrics.txt")"
grep -q '^tellus_cache_local_tier_evictions_total 0$' "$work/metrics.txt" || fail "evictions"
stop
[ -n "$(find "$work/cache" -name '*.png')" ] || fail "no copy in the local tier"

# The local tier (tree, index, folder) emptied: the bucket is all that holds the tile.
find "$work/cache" -mindepth 1 -maxdepth 1 ! -name wmts-capabilities -exec rm -rf {} +
"$tellus" cache rebuild --config "$work/tellus.yaml" --cache "$work/cache" >"$work/rebuild.txt" 2>&1 ||
  fail "rebuild: $(cat "$work/rebuild.txt")"
start "$work/offline.txt" --offline
[ "$(get '/wwtile?T=sst&L=0&X=3&Y=0' "$work/b.png")" = 200 ] || fail "from S3: $(cat "$work/b.png")"
cmp -s "$work/b.png" "$work/a.png" || fail "the tile read back from S3 differs"
stop
[ -n "$(find "$work/cache" -name '*.png')" ] || fail "the tile read from S3 was not copied locally"
asked=$(grep -c '/2014-02-04/EPSG4326_1km/3/4/3.png$' "$work/upstream.log")
[ "$asked" = 1 ] || fail "the upstream was asked again ($asked times)"

# Wrong credentials: refused at the start, the key named nowhere.
if AWS_SECRET_ACCESS_KEY=wrong-Zq9-secret "$tellus" serve --config "$work/tellus.yaml" \
  --cache "$work/cache" --listen 127.0.0.1:0 >"$work/bad.txt" 2>&1; then
  fail "serve started with a wrong secret"
fi
grep -q "$S3_ENDPOINT" "$work/bad.txt" || fail "the refusal does not name the endpoint: $(cat "$work/bad.txt")"
grep -q "403" "$work/bad.txt" || fail "the refusal does not say 403: $(cat "$work/bad.txt")"
for f in "$work"/*.txt; do
  if grep -qF -e "wrong-Zq9-secret" -e "$AWS_SECRET_ACCESS_KEY" "$f"; then
    fail "a secret in $f"
  fi
done
echo "ok: tellus serve with its tiles in S3"
