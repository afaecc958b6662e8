#!/usr/bin/env bash
# Resident memory of `tellus serve` on the embedded default: before any request, after a cached
# tile, with IDLE_CONNECTIONS (1000) keep-alive connections open that each fetched that cached tile,
# and after one miss rendered from a local raster (the first tile that loads the imaging module, and
# with it OpenImageIO).
#
#   bench/proxy/imaging_rss.sh [TELLUS ...]      (default: build/tools/tellus/tellus)
#
# For each binary: a fresh temp cache in which that binary seeds bluemarble tile 0/2/5, then
# `tellus serve --cache <it> --listen 127.0.0.1:0`; SETTLE_S (2) seconds after it listens, and
# again SETTLE_S seconds after each request, VmRSS, RssAnon and RssFile come from
# /proc/<pid>/status and the count of distinct shared objects mapped from /proc/<pid>/maps.
# Requests: /wwtile?T=bluemarble&L=0&X=5&Y=2 (a hit); the idle connections (bench/proxy/
# idle_conns.py, measured once all hold their answer, then closed; IDLE_CONNECTIONS=0 skips them);
# then L=0&X=0&Y=0 (a miss).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
SETTLE_S="${SETTLE_S:-2}"
IDLE_CONNECTIONS="${IDLE_CONNECTIONS:-1000}"
want_fds=$((IDLE_CONNECTIONS + 1024))
if [[ "$(ulimit -n)" != unlimited && "$(ulimit -n)" -lt $want_fds ]]; then
  ulimit -n "$want_fds" 2>/dev/null || ulimit -n "$(ulimit -Hn)"
fi
[[ $# -gt 0 ]] || set -- "$repo/build/tools/tellus/tellus"

work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-imaging-rss.XXXXXX")
server=
cleanup() {
  [[ -z $server ]] || kill "$server" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

mem() { # PID: "VmRSS RssAnon RssFile" in MiB (one decimal) and the number of .so files mapped
  awk '$1 == "VmRSS:" { r = $2 } $1 == "RssAnon:" { a = $2 } $1 == "RssFile:" { f = $2 }
       END { printf "%.1f %.1f %.1f", r / 1024, a / 1024, f / 1024 }' "/proc/$1/status"
  printf ' %s' "$(awk '$6 ~ /\.so/ { print $6 }' "/proc/$1/maps" | sort -u | wc -l)"
}

printf '%-44s %-16s %8s %8s %8s %6s %s\n' binary stage VmRSS RssAnon RssFile libs imaging
n=0
for tellus in "$@"; do
  n=$((n + 1))
  cache="$work/cache-$n"
  "$tellus" seed --cache "$cache" --layer bluemarble --levels 0-0 --bbox 1,-1,2,1 >/dev/null
  "$tellus" serve --cache "$cache" --listen 127.0.0.1:0 >"$work/serve-$n.txt" 2>&1 &
  server=$!
  for _ in $(seq 100); do grep -q "listening on" "$work/serve-$n.txt" && break; sleep 0.1; done
  port=$(grep -o "127.0.0.1:[0-9]*" "$work/serve-$n.txt" | head -n 1 | cut -d: -f2)
  [[ -n $port ]] || { cat "$work/serve-$n.txt"; exit 1; }
  row() {
    read -r rss anon file libs <<<"$(mem "$server")"
    loaded=no
    grep -q libOpenImageIO "/proc/$server/maps" && loaded=OIIO
    printf '%-44s %-16s %8s %8s %8s %6s %s\n' "$tellus" "$1" "$rss" "$anon" "$file" "$libs" "$loaded"
  }
  sleep "$SETTLE_S"
  row "no request"
  curl -sf -o /dev/null "http://127.0.0.1:$port/wwtile?T=bluemarble&L=0&X=5&Y=2"
  sleep "$SETTLE_S"
  row "after a hit"
  if [[ $IDLE_CONNECTIONS -gt 0 ]]; then
    echo "/wwtile?T=bluemarble&L=0&X=5&Y=2" >"$work/urls.txt"
    rm -f "$work/hold"
    mkfifo "$work/hold"
    python3 "$here/idle_conns.py" 127.0.0.1 "$port" "$work/urls.txt" "$IDLE_CONNECTIONS" 60 \
      <"$work/hold" >"$work/idle-$n.out" 2>&1 &
    idle=$!
    exec 7>"$work/hold"
    for _ in $(seq 600); do
      grep -q '^OPEN' "$work/idle-$n.out" && break
      sleep 0.1
    done
    sleep "$SETTLE_S"
    row "$IDLE_CONNECTIONS connections"
    grep -q "^OPEN $IDLE_CONNECTIONS ok=$IDLE_CONNECTIONS " "$work/idle-$n.out" \
      || { echo "idle connections: $(cat "$work/idle-$n.out")" >&2; exit 1; }
    exec 7>&-
    wait "$idle"
  fi
  curl -sf -o /dev/null "http://127.0.0.1:$port/wwtile?T=bluemarble&L=0&X=0&Y=0"
  sleep "$SETTLE_S"
  row "after a miss"
  kill "$server"
  wait "$server" 2>/dev/null || true
  server=
done
