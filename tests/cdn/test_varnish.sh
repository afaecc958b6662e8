#!/usr/bin/env bash
# Varnish (Debian's 7.1 with vmod_xkey) in front of a real `tellus serve` (docs/design/cdn.md),
# all on loopback: tests/support/varnish.sh starts varnishd with config/examples/varnish.vcl,
# tests/cdn/tile_upstream.py is the World Wind upstream (a 500 on demand). Checked:
#   - a second request for a tile is a Varnish hit (X-Varnish names two transactions, tellus is
#     asked once), and tellus's Cache-Control (s-maxage) set its lifetime there;
#   - If-None-Match with the tile's ETag gets 304 from Varnish;
#   - an error is not kept: a failing upstream (503 from tellus), then a working one: the same
#     URL is a 200 at once;
#   - PURGE with an xkey-purge header of a layer's key removes that layer's tiles, not others';
#   - revalidation end to end: a tile past its ttl (Varnish's s-maxage too) is asked of tellus
#     again with its ETag; tellus revalidates upstream (304), the tile's version and ETag stay,
#     and tellus answers Varnish 304 (its access log): no body crosses either hop;
#   - `tellus cache prune --layer` with server.cdn.purge pointing at Varnish: the pruned layer's
#     tile leaves Varnish (the next request reaches tellus), the other layer's stays; and so does
#     `tellus seed --refresh` of that layer; a purge that fails exits 1 and shows no token.
# Usage: test_varnish.sh path/to/tellus. Exits 77 (skipped) without varnishd or vmod_xkey.
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd)
support="$here/../support"
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-varnish.XXXXXX")
chmod 755 "$work" # varnishd's workers (another user when root) read the VCL below it
server=
upstream=
cleanup() {
  "$support/varnish.sh" stop "$work/varnish" || true
  [ -n "$server" ] && kill "$server" 2>/dev/null || true
  [ -n "$upstream" ] && kill "$upstream" 2>/dev/null || true
  [ -n "${KEEP:-}" ] || rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

python3 "$here/tile_upstream.py" "$work/up.port" "$work/upstream.log" "$work/fail" &
upstream=$!
for _ in $(seq 100); do [ -s "$work/up.port" ] && break; sleep 0.1; done
up=$(cat "$work/up.port")
[ -n "$up" ] || fail "the upstream did not start"

# tellus's port first (serve binds 0 and says where); Varnish's purge URL is written into the
# configuration of `cache prune`, which runs after Varnish has started.
config() { # $1: purge URL or ""
  cat <<YAML
server:
  cdn:
    purge: [${1}]
upstreams:
  - {name: ww, type: worldwind, url: "http://127.0.0.1:$up/tiles", retries: 0, failure_threshold: 100}
layers:
  - name: sat
    upstream: ww
    format: image/png
    grid: {level_zero_delta: 36, tile_size: 256, levels: 3}
  - name: other
    upstream: ww
    format: image/png
    grid: {level_zero_delta: 36, tile_size: 256, levels: 3}
  - name: rev
    upstream: ww
    format: image/png
    grid: {level_zero_delta: 36, tile_size: 256, levels: 3}
    cache: {ttl: 1s}
YAML
}
config "" >"$work/serve.yaml"
"$tellus" serve --config "$work/serve.yaml" --cache "$work/cache" --listen 127.0.0.1:0 \
  --access-log "$work/access.log" >"$work/serve.log" 2>&1 &
server=$!
for _ in $(seq 100); do grep -qs "listening on" "$work/serve.log" && break; sleep 0.1; done
tport=$(grep -o "127.0.0.1:[0-9]*" "$work/serve.log" | head -n 1 | cut -d: -f2)
[ -n "$tport" ] || fail "serve did not start: $(cat "$work/serve.log")"

set +e
vport=$("$support/varnish.sh" start "$work/varnish" "$tport")
rc=$?
set -e
[ $rc = 77 ] && { echo "skipped: no varnishd or vmod_xkey"; exit 77; }
[ $rc = 0 ] || fail "varnish did not start"
v="http://127.0.0.1:$vport"

head_of() { # $1: URL, more curl arguments follow; the response's headers, CRs removed
  local url=$1
  shift
  curl -s -D - -o "$work/body" "$@" "$url" | tr -d '\r'
}
status_of() { sed -n '1s/^HTTP\/[0-9.]* \([0-9]*\).*/\1/p'; }
field() { grep -i "^$1:" | head -n 1 | cut -d' ' -f2-; }
asked() { grep -c "^$1\$" "$work/upstream.log" || true; }

# 1. A hit: the second request is Varnish's (two transaction ids), tellus asked once.
a=$(head_of "$v/wwtile?T=sat&L=1&X=2&Y=3")
[ "$(status_of <<<"$a")" = 200 ] || fail "first tile: $a"
b=$(head_of "$v/wwtile?T=sat&L=1&X=2&Y=3")
[ "$(status_of <<<"$b")" = 200 ] || fail "second tile: $b"
[ "$(field x-varnish <<<"$b" | wc -w)" = 2 ] || fail "not a Varnish hit: $b"
[ -n "$(field age <<<"$b")" ] || fail "no Age on a hit: $b"
[ "$(field x-cache <<<"$b")" = MISS ] || fail "the hit is not the object tellus sent first: $b"
[ -z "$(field xkey <<<"$b")" ] || fail "the surrogate keys reached the client: $b"
[ "$(asked 'T=sat&L=1&X=2&Y=3')" = 1 ] || fail "the upstream was asked $(asked 'T=sat&L=1&X=2&Y=3') times"
# tellus's own answer carries what Varnish used.
t=$(head_of "http://127.0.0.1:$tport/wwtile?T=sat&L=1&X=2&Y=3")
field cache-control <<<"$t" | grep -q "s-maxage=86400, stale-while-revalidate=86400, stale-if-error=604800" ||
  fail "tellus's Cache-Control: $(field cache-control <<<"$t")"
[ "$(field xkey <<<"$t")" = "tellus layer:sat layer:sat/1" ] || fail "tellus's keys: $t"

# 2. 304 through Varnish.
etag=$(field etag <<<"$b")
c=$(head_of "$v/wwtile?T=sat&L=1&X=2&Y=3" -H "If-None-Match: $etag")
[ "$(status_of <<<"$c")" = 304 ] || fail "If-None-Match through Varnish: $c"

# 2b. Revalidation through both hops. rev's tiles expire after 1 s, and so do Varnish's copies
# (s-maxage=1, grace 1 s, kept for stale-if-error): past that Varnish asks tellus with the ETag it
# has, tellus asks the upstream with the upstream's (304: the tile is the same), keeps the tile's
# version (so its ETag) and answers Varnish 304. Real processes on real clocks: a short sleep.
rev="wwtile?T=rev&L=1&X=2&Y=3"
r1=$(head_of "$v/$rev")
[ "$(status_of <<<"$r1")" = 200 ] || fail "rev's tile: $r1"
etag1=$(field etag <<<"$r1")
field cache-control <<<"$r1" | grep -q "s-maxage=1," || fail "rev's Cache-Control: $r1"
sleep 2.5
r2=$(head_of "$v/$rev")
[ "$(status_of <<<"$r2")" = 200 ] || fail "rev's tile past its ttl: $r2"
for _ in $(seq 50); do # Varnish may have answered from grace and revalidate in the background
  grep -q "target=\"/$rev\" status=304" "$work/access.log" && break
  sleep 0.1
done
grep -q "target=\"/$rev\" status=304" "$work/access.log" ||
  fail "Varnish's revalidation did not get 304 from tellus: $(grep "T=rev" "$work/access.log")"
[ "$(grep -c "^T=rev&L=1&X=2&Y=3 304\$" "$work/upstream.log")" -ge 1 ] ||
  fail "tellus did not revalidate upstream: $(grep "T=rev" "$work/upstream.log")"
[ "$(asked 'T=rev&L=1&X=2&Y=3')" = 1 ] || fail "the upstream sent rev's tile again"
r3=$(head_of "$v/$rev")
[ "$(field etag <<<"$r3")" = "$etag1" ] || fail "the ETag changed at revalidation: $r1 / $r3"
cmp -s "$work/body" <(curl -s "http://127.0.0.1:$tport/$rev") || fail "Varnish's body differs"

# 3. Errors are not kept: a failing upstream, then a working one.
touch "$work/fail"
d=$(head_of "$v/wwtile?T=sat&L=2&X=5&Y=5")
[ "$(status_of <<<"$d")" = 503 ] || fail "a failing upstream gave $(status_of <<<"$d")"
[ "$(field cache-control <<<"$d")" = no-store ] || fail "an error without no-store: $d"
rm "$work/fail"
e=$(head_of "$v/wwtile?T=sat&L=2&X=5&Y=5")
[ "$(status_of <<<"$e")" = 200 ] || fail "the error was kept: $e"
f=$(head_of "$v/wwtile?T=sat&L=2&X=5&Y=5")
[ "$(field x-varnish <<<"$f" | wc -w)" = 2 ] || fail "the good tile is not kept after the error: $f"

# 4. PURGE by key: sat's tiles go, other's stay.
head_of "$v/wwtile?T=other&L=0&X=0&Y=0" >/dev/null
g=$(head_of "$v/wwtile?T=other&L=0&X=0&Y=0")
[ "$(field x-varnish <<<"$g" | wc -w)" = 2 ] || fail "other's tile not kept: $g"
p=$(head_of "$v/" -X PURGE -H "xkey-purge: layer:sat")
[ "$(status_of <<<"$p")" = 200 ] || fail "PURGE: $p"
h=$(head_of "$v/wwtile?T=sat&L=1&X=2&Y=3")
[ "$(field x-varnish <<<"$h" | wc -w)" = 1 ] || fail "a purged tile is still a hit: $h"
[ "$(field x-cache <<<"$h")" = HIT ] || fail "after the purge tellus answers from its cache: $h"
i=$(head_of "$v/wwtile?T=other&L=0&X=0&Y=0")
[ "$(field x-varnish <<<"$i" | wc -w)" = 2 ] || fail "the purge of sat took other's tile: $i"
# Another host may not purge (the VCL's acl): not tested here, everything is loopback.

# 5. `tellus cache prune --layer sat` purges sat in Varnish.
head_of "$v/wwtile?T=sat&L=1&X=2&Y=3" >/dev/null # a hit again
config "\"http://127.0.0.1:$vport/\"" >"$work/prune.yaml"
"$tellus" cache prune --config "$work/prune.yaml" --cache "$work/cache" --layer sat \
  --older-than 0s >"$work/prune.log" 2>&1 || fail "prune: $(cat "$work/prune.log")"
grep -q "purged 1 keys at server.cdn.purge\[0\] (http://127.0.0.1:$vport)" "$work/prune.log" ||
  fail "prune did not say it purged: $(cat "$work/prune.log")"
j=$(head_of "$v/wwtile?T=sat&L=1&X=2&Y=3")
[ "$(field x-varnish <<<"$j" | wc -w)" = 1 ] || fail "the pruned tile is still in Varnish: $j"
# (Whether tellus itself answers it from its cache or fetches it again depends on how soon it
# notices the other process's prune: TileCacheOptions::otherWritersCheck; not this test's
# business.)
k=$(head_of "$v/wwtile?T=other&L=0&X=0&Y=0")
[ "$(field x-varnish <<<"$k" | wc -w)" = 2 ] || fail "prune of sat took other's tile: $k"

# 6. `tellus seed --refresh` of sat (one tile of level 0) purges sat in Varnish too.
head_of "$v/wwtile?T=sat&L=1&X=2&Y=3" >/dev/null # kept again
l=$(head_of "$v/wwtile?T=sat&L=1&X=2&Y=3")
[ "$(field x-varnish <<<"$l" | wc -w)" = 2 ] || fail "not kept again before the refresh: $l"
"$tellus" seed --config "$work/prune.yaml" --cache "$work/cache" --layer sat --levels 0 \
  --bbox -180,-90,-144,-54 --refresh >"$work/refresh.log" 2>&1 ||
  fail "seed --refresh: $(cat "$work/refresh.log")"
grep -q "purged 1 keys at server.cdn.purge\[0\]" "$work/refresh.log" ||
  fail "seed --refresh did not purge: $(cat "$work/refresh.log")"
m=$(head_of "$v/wwtile?T=sat&L=1&X=2&Y=3")
[ "$(field x-varnish <<<"$m" | wc -w)" = 1 ] || fail "a refreshed layer's tile is still in Varnish: $m"
n=$(head_of "$v/wwtile?T=other&L=0&X=0&Y=0")
[ "$(field x-varnish <<<"$n" | wc -w)" = 2 ] || fail "the refresh of sat took other's tile: $n"

# 7. A purge that fails: the command says so and exits 1, naming the endpoint by its place and
# origin, never the rest of its URL (a token in its query; credentials in it are refused).
config "\"http://127.0.0.1:1/purge?token=s3cr3t\"" >"$work/bad-purge.yaml"
if "$tellus" cache prune --config "$work/bad-purge.yaml" --cache "$work/cache" --layer other \
  --older-than 0s >"$work/bad-purge.log" 2>&1; then
  fail "a failed purge exited 0: $(cat "$work/bad-purge.log")"
fi
grep -q "purging server.cdn.purge\[0\] (http://127.0.0.1:1) failed" "$work/bad-purge.log" ||
  fail "the failed purge is not reported: $(cat "$work/bad-purge.log")"
! grep -q "s3cr3t" "$work/bad-purge.log" || fail "the purge URL's token was shown"
echo "ok: Varnish in front of tellus serve: hits, 304, revalidation, no error kept, purge by key, by prune and by refresh"
