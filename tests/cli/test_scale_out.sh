#!/usr/bin/env bash
# Several `tellus serve` on one shared index (issue 27): three instances on different ports share a
# PostgreSQL index (tests/support/postgres.sh) and one cache folder for the tiles' bytes (standing
# in for the object store), in front of an upstream that counts its GetMaps
# (tests/support/counting_wms.py). Checked:
#   - 300 concurrent requests for one missing tile, spread over the three: exactly one upstream
#     request, every client gets 200 and the same bytes; p50/p99 printed; the same for the 16
#     tiles of one missing metatile (a miss fetches its metatile under the metatile's lease);
#   - the instance holding a tile's lease killed (-9) while its fetch is under way (a slow
#     upstream): another instance fetches the tile and answers its waiting clients within 2 s;
#   - the database stopped: stored tiles are still served (read-only), a miss is a 503, /metrics
#     says tellus_shared_index_up 0; started again: misses are fetched and stored again, without
#     restarting tellus;
#   - two `tellus seed` of one command on the shared index split the job: no GetMap twice, and a
#     third run afterwards finds every tile cached;
#   - a password in cache.index is refused at start, and a failing connection's message on stderr
#     has no password (from the password file) in it.
# Usage: test_scale_out.sh path/to/tellus
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/../.." && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-scale.XXXXXX")
pids=()
upstream=
cleanup() {
  for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null || true; done
  [ -n "$upstream" ] && kill "$upstream" 2>/dev/null || true
  "$src/tests/support/postgres.sh" stop "$work/pg" || true
  [ -n "${KEEP:-}" ] || rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

uri=$("$src/tests/support/postgres.sh" start "$work/pg")
python3 "$src/tests/support/counting_wms.py" "$work/upstream.port" &
upstream=$!
for _ in $(seq 100); do [ -s "$work/upstream.port" ] && break; sleep 0.1; done
up=$(cat "$work/upstream.port")
[ -n "$up" ] || fail "the counting upstream did not start"

cat >"$work/tellus.yaml" <<YAML
cache: {index: "$uri"}
upstreams:
  - {name: counted, type: wms, url: "http://127.0.0.1:$up/wms", version: 1.1.1, retries: 0}
layers:
  - {name: shared, upstream: counted, format: image/png, grid: {level_zero_delta: 36, tile_size: 64, levels: 4}}
YAML

ports=()
start() { # $1: index (0..2); sets pids[$1], ports[$1]
  local log="$work/serve$1.log"
  "$tellus" serve --config "$work/tellus.yaml" --cache "$work/cache" --listen 127.0.0.1:0 \
    --threads 4 >"$log" 2>&1 &
  pids[$1]=$!
  for _ in $(seq 100); do grep -qs "listening on" "$log" && break; sleep 0.1; done
  ports[$1]=$(grep -o "127.0.0.1:[0-9]*" "$log" | head -n 1 | cut -d: -f2)
  [ -n "${ports[$1]}" ] || fail "serve $1 did not start: $(cat "$log")"
}
start 0
start 1
start 2
getmaps() { curl -fsS "http://127.0.0.1:$up/stats" | python3 -c 'import json,sys; print(json.load(sys.stdin)["getmaps"])'; }

# --- 300 concurrent requests for one missing tile over three instances ---------------------------
tile='/wwtile?T=shared&L=2&X=5&Y=3'
result=$(python3 "$here/burst.py" 300 "$tile" "${ports[@]}") ||
  fail "the burst (not all 200, or several bodies): $result"
echo "burst of 300 over 3 instances: $result"
[ "$(getmaps)" = 1 ] || fail "300 requests for one tile over 3 instances made $(getmaps) upstream requests"

# --- 300 concurrent requests for the 16 tiles of one missing metatile over three instances --------
# (meta_tiles 4: a miss fetches its 4x4 metatile under the metatile's lease.) Level 2 is 40 x 20
# tiles; the tiles above are in the metatile of rows 0-3, columns 4-7; this one is rows 8-11,
# columns 20-23.
for r in 8 9 10 11; do for c in 20 21 22 23; do echo "/wwtile?T=shared&L=2&X=$c&Y=$r"; done; done \
  >"$work/metatile.txt"
result=$(python3 "$here/burst.py" 300 "@$work/metatile.txt" "${ports[@]}") ||
  fail "the metatile burst (not all 200, or several bodies for one tile): $result"
echo "burst of 300 over the 16 tiles of a metatile and 3 instances: $result"
[ "$(getmaps)" = 2 ] ||
  fail "300 requests for one metatile's tiles made $(($(getmaps) - 1)) upstream requests: $(curl -fsS "http://127.0.0.1:$up/stats")"

# --- the holder killed mid-fetch: another instance fetches within 2 s -----------------------------
curl -fsS "http://127.0.0.1:$up/delay?ms=30000" >/dev/null
tile2='/wwtile?T=shared&L=2&X=9&Y=3' # another metatile
curl -s -o /dev/null "http://127.0.0.1:${ports[0]}$tile2" & # instance 0 takes the lease
holder_client=$!
for _ in $(seq 100); do [ "$(getmaps)" = 3 ] && break; sleep 0.05; done
[ "$(getmaps)" = 3 ] || fail "instance 0 did not fetch the second tile"
# Clients of the other two wait for instance 0's fetch.
curl -s -o "$work/w1.png" -w '%{http_code}' "http://127.0.0.1:${ports[1]}$tile2" >"$work/w1.code" &
w1=$!
curl -s -o "$work/w2.png" -w '%{http_code}' "http://127.0.0.1:${ports[2]}$tile2" >"$work/w2.code" &
w2=$!
sleep 0.5
[ "$(getmaps)" = 3 ] || fail "a waiting instance fetched while the holder was alive"
curl -fsS "http://127.0.0.1:$up/delay?ms=0" >/dev/null
killed_at=$(date +%s.%N)
kill -9 "${pids[0]}"
wait "$w1" "$w2"
done_at=$(date +%s.%N)
wait "$holder_client" 2>/dev/null || true
took=$(python3 -c "print(round($done_at - $killed_at, 3))")
echo "holder killed: the waiting clients were answered ${took} s later"
[ "$(cat "$work/w1.code")" = 200 ] && [ "$(cat "$work/w2.code")" = 200 ] ||
  fail "waiting clients got $(cat "$work/w1.code") and $(cat "$work/w2.code")"
cmp -s "$work/w1.png" "$work/w2.png" || fail "the two instances served different bytes"
python3 -c "import sys; sys.exit(0 if $took < 2.0 else 1)" || fail "took ${took} s (> 2 s)"
[ "$(getmaps)" = 4 ] || fail "expected 4 upstream requests (two tiles, a metatile, one refetch), got $(getmaps)"

# --- the database down, then back ------------------------------------------------------------------
metric() { curl -fsS "http://127.0.0.1:$1/metrics" | awk -v m="$2" '$1 == m {print $2}'; }
[ "$(metric "${ports[1]}" tellus_shared_index_up)" = 1 ] || fail "the index is up: $(metric "${ports[1]}" tellus_shared_index_up)"
curl -fsS -o "$work/a1.png" "http://127.0.0.1:${ports[1]}$tile"
"$src/tests/support/postgres.sh" pause "$work/pg"
for p in 1 2; do
  # The first request after the server left may meet a pooled connection that only then breaks.
  for _ in $(seq 3); do
    code=$(curl -s -o "$work/down$p.png" -w '%{http_code}' "http://127.0.0.1:${ports[$p]}$tile")
    [ "$code" = 200 ] && break
  done
  [ "$code" = 200 ] || fail "instance $p did not serve a stored tile with the database down: $code"
  cmp -s "$work/down$p.png" "$work/a1.png" || fail "instance $p served other bytes without the index"
done
tile3='/wwtile?T=shared&L=2&X=13&Y=3' # another metatile
code=$(curl -s -o /dev/null -w '%{http_code}' "http://127.0.0.1:${ports[1]}$tile3")
[ "$code" = 503 ] || fail "a miss with the database down: $code, not 503"
[ "$(metric "${ports[1]}" tellus_shared_index_up)" = 0 ] || fail "/metrics does not say the index is down"
[ "$(getmaps)" = 4 ] || fail "an instance fetched with the database down"
"$src/tests/support/postgres.sh" resume "$work/pg"
for _ in $(seq 50); do
  code=$(curl -s -o "$work/c.png" -w '%{http_code}' "http://127.0.0.1:${ports[1]}$tile3")
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
  code=$(curl -s -o "$work/c2.png" -w '%{http_code}' "http://127.0.0.1:${ports[2]}$tile3")
  [ "$code" = 200 ] && break
  sleep 0.1
done
cmp -s "$work/c.png" "$work/c2.png" || fail "instance 2 did not serve instance 1's tile"
echo "database stopped and started: stored tiles served meanwhile, service resumed without restarts ($(getmaps) upstream requests in all)"

# --- two seeders on one job --------------------------------------------------------------------
curl -fsS "http://127.0.0.1:$up/stats" >"$work/before.json"
seed() { "$tellus" seed --config "$work/tellus.yaml" --cache "$work/cache" --layer shared --levels 0-2 "$@"; }
seed >"$work/seed1.txt" 2>&1 &
s1=$!
seed >"$work/seed2.txt" 2>&1 &
s2=$!
wait "$s1" || fail "seeder 1: $(cat "$work/seed1.txt")"
wait "$s2" || fail "seeder 2: $(cat "$work/seed2.txt")"
curl -fsS "http://127.0.0.1:$up/stats" >"$work/after.json"
python3 - "$work/before.json" "$work/after.json" <<'PY' || fail "a GetMap was made twice by the two seeders"
import json, sys
before, after = (json.load(open(p))["by_bbox"] for p in sys.argv[1:3])
twice = {b: n - before.get(b, 0) for b, n in after.items() if n - before.get(b, 0) > 1}
again = {b: n - before[b] for b, n in after.items() if b in before and n > before[b]}
assert not twice, twice
assert not again, again  # cached before the job: skipped
print("two seeders:", sum(after[b] - before.get(b, 0) for b in after), "GetMaps, none twice")
PY
grep -h "shared job" "$work/seed1.txt" "$work/seed2.txt"
seed >"$work/seed3.txt" 2>&1 || fail "the third seeder: $(cat "$work/seed3.txt")"
grep -q " 0 written" "$work/seed3.txt" || fail "the job left tiles unseeded: $(cat "$work/seed3.txt")"

# --- credentials ----------------------------------------------------------------------------------
sed 's|cache: {index: "postgresql://tellus@|cache: {index: "postgresql://tellus:hunter2@|' \
  "$work/tellus.yaml" >"$work/pw.yaml"
if "$tellus" serve --config "$work/pw.yaml" --cache "$work/cache" --listen 127.0.0.1:0 \
  >"$work/pw.log" 2>&1; then fail "a password in cache.index was taken"; fi
grep -q "PGPASSWORD" "$work/pw.log" || fail "no hint where the password goes: $(cat "$work/pw.log")"
! grep -q hunter2 "$work/pw.log" || fail "the password was shown: $(cat "$work/pw.log")"
echo "pw-in-file-4b7" >"$work/pgpass"
cat >"$work/down.yaml" <<YAML
cache: {index: "postgresql://tellus@127.0.0.1:1/tellus", index_password_file: "$work/pgpass"}
upstreams:
  - {name: counted, type: wms, url: "http://127.0.0.1:$up/wms", version: 1.1.1}
layers:
  - {name: shared, upstream: counted, format: image/png, grid: {levels: 2}}
YAML
if "$tellus" serve --config "$work/down.yaml" --cache "$work/cache2" --listen 127.0.0.1:0 \
  >"$work/down.log" 2>&1; then fail "serve started without its database"; fi
grep -q "cannot connect to PostgreSQL" "$work/down.log" || fail "$(cat "$work/down.log")"
! grep -q "pw-in-file" "$work/down.log" || fail "the password was shown: $(cat "$work/down.log")"
echo "PASS"
