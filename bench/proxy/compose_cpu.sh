#!/usr/bin/env bash
# CPU time per composed GetMap (1024x768 JPEG, random boxes 10-90 degrees wide, the peers'
# wms_arbitrary.lua), read from the server's own utime+stime in /proc: a figure that the other load
# on a shared machine disturbs much less than requests per second.
#
#   bench/proxy/compose_cpu.sh [path/to/tellus] [seconds]
#
# CONFIG=file.yaml serves with that configuration (for example another server.limits.
# decoded_tile_cache); BOX_LEVELS=0-2 seeds those levels; REGION=W,S,E,N draws the boxes inside
# that region (default the whole world; bench/peers/run.sh's is -36,-18,72,54, where the spans
# are 10-80 degrees instead of 10-90).
#
# Seeds the bundled Blue Marble (levels 0-2) into a scratch cache, serves it, runs wrk with one
# connection for the given time (default 20 s) and prints requests, CPU seconds, CPU ms per map
# and the server's RSS. Needs wrk (Debian package).
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
tellus="${1:-$repo/build/tools/tellus/tellus}"
seconds="${2:-20}"
work="$(mktemp -d "${TMPDIR:-/tmp}/tellus-compose.XXXXXX")"
server=
cleanup() { [ -n "$server" ] && kill "$server" 2>/dev/null; rm -rf "$work"; }
trap cleanup EXIT
config=()
[ -n "${CONFIG:-}" ] && config=(--config "$CONFIG")
"$tellus" seed "${config[@]}" --cache "$work/cache" --layer bluemarble --levels "${BOX_LEVELS:-0-2}" >/dev/null
"$tellus" serve "${config[@]}" --cache "$work/cache" --listen 127.0.0.1:0 >"$work/serve.txt" 2>&1 &
server=$!
for _ in $(seq 50); do grep -q "listening on" "$work/serve.txt" && break; sleep 0.1; done
port=$(grep -o "127.0.0.1:[0-9]*" "$work/serve.txt" | head -n 1 | cut -d: -f2)
IFS=, read -r rw rs re rn <<<"${REGION:--180,-90,180,90}"
cat >"$work/arbitrary.lua" <<LUA
local W, S, E, N = $rw, $rs, $re, $rn
LUA
cat >>"$work/arbitrary.lua" <<'LUA'
math.randomseed(42)
local maxSpan = math.min(90, E - W, (N - S) / 0.75)
request = function()
  local span = 10 + math.random() * (maxSpan - 10)
  local w = W + math.random() * (E - W - span)
  local hs = span * 0.75
  local s = S + math.random() * (N - S - hs)
  return wrk.format("GET", string.format("/wms?SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=bluemarble&STYLES=&CRS=EPSG:4326&BBOX=%.6f,%.6f,%.6f,%.6f&WIDTH=1024&HEIGHT=768&FORMAT=image/jpeg", s, w, s + hs, w + span))
end
LUA
# One map first: what the answer is, and the warm-up of the composer's buffers.
curl -s -o "$work/first.jpg" -w '%{content_type}\n' "http://127.0.0.1:$port/wms?SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=bluemarble&STYLES=&CRS=EPSG:4326&BBOX=20,160,70,210&WIDTH=1024&HEIGHT=768&FORMAT=image/jpeg" | grep -q image/jpeg \
  || { echo "compose_cpu.sh: the server did not answer a JPEG map" >&2; exit 1; }
ticks() { awk '{print $14 + $15}' "/proc/$server/stat"; }
hz=$(getconf CLK_TCK)
before=$(ticks)
out=$(wrk -t1 -c1 -d"${seconds}s" -s "$work/arbitrary.lua" "http://127.0.0.1:$port")
after=$(ticks)
n=$(echo "$out" | awk '/requests in/ {print $1}')
non2xx=$(echo "$out" | awk '/Non-2xx/ {print $NF}')
rss=$(awk '/VmRSS/ {print $2}' "/proc/$server/status")
awk -v n="$n" -v t=$((after - before)) -v hz="$hz" -v rss="$rss" -v bad="${non2xx:-0}" 'BEGIN {
  printf "%d maps (%d non-2xx), %.2f s CPU, %.2f ms CPU per map, RSS %.0f MiB\n", n, bad, t / hz, 1000 * t / hz / n, rss / 1024 }'
