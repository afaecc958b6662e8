#!/usr/bin/env bash
# Instructions per request of cached tiles, counted by valgrind (callgrind), series side by side:
# A /wwtile, W WMTS KVP GetTile and R WMTS RESTful (the same tiles as bench/proxy/run.sh's series).
# A count of the server's user-space instructions moves far less than req/s or CPU time on a
# shared machine; what the kernel does (sendfile, the sockets) is not in it.
#
#   bench/proxy/instructions.sh
#
# Seeds a temporary cache (levels 0-2 of `bluemarble`), starts `tellus serve --threads 1` under
# callgrind, and per series (A W R, ROUNDS times, after a 2 s warm-up of each) zeroes the counts,
# runs `wrk -t1 -c4 -d$DURATION` with bench/proxy/urls.lua and dumps them: Ir/req is the dump's
# instructions over wrk's requests. The count moves by a few per cent from round to round (how
# many requests one wake-up of the event loop finds), so compare series of the same rounds.
#
# Settings (environment): TELLUS=build/tools/tellus/tellus DURATION=6s ROUNDS=2 URL_COUNT=2000
# SEED=42. Needs valgrind, wrk, python3. Binds 127.0.0.1 only; stops what it started on exit.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
TELLUS="${TELLUS:-$repo/build/tools/tellus/tellus}"
DURATION="${DURATION:-6s}"
ROUNDS="${ROUNDS:-2}"
URL_COUNT="${URL_COUNT:-2000}"
SEED="${SEED:-42}"

work="$(mktemp -d /tmp/tellus-bench-instr.XXXXXX)"
pid=""
cleanup() {
  [[ -z $pid ]] || kill "$pid" 2>/dev/null || true
  [[ -z $pid ]] || wait "$pid" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
cp "$TELLUS" "$work/tellus"
module="$(dirname "$TELLUS")/../../imaging/libtellus_imaging.so"
[[ ! -f $module ]] || cp "$module" "$work/"

"$work/tellus" seed --cache "$work/cache" --data "$repo/data" --layer bluemarble --levels 0-2 \
  >"$work/seed.log" 2>&1
python3 - "$work" "$URL_COUNT" "$SEED" <<'PY'
import random, sys
work, count, seed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
rng = random.Random(seed)
keys = []
for _ in range(count):  # bluemarble: 36-degree level-zero tiles, 10 x 5 at level 0
    level = rng.randint(0, 2)
    keys.append((level, rng.randrange(5 << level), rng.randrange(10 << level)))
series = {
    "A": lambda L, r, c: f"/wwtile?T=bluemarble&L={L}&X={c}&Y={r}",
    "W": lambda L, r, c: "/wmts?SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=bluemarble"
         "&STYLE=default&FORMAT=image/jpeg&TILEMATRIXSET=WorldWind_bluemarble"
         f"&TILEMATRIX={L}&TILEROW={(5 << L) - 1 - r}&TILECOL={c}",
    "R": lambda L, r, c: f"/wmts/1.0.0/bluemarble/default/WorldWind_bluemarble/{L}/{(5 << L) - 1 - r}/{c}.jpg",
}
for name, fmt in series.items():
    with open(f"{work}/urls-{name}.txt", "w") as f:
        f.writelines(fmt(*k) + "\n" for k in keys)
PY

(cd "$work" && exec valgrind --tool=callgrind --callgrind-out-file="$work/cg.out" \
  ./tellus serve --cache "$work/cache" --data "$repo/data" --listen 127.0.0.1:0 --threads 1 \
  >"$work/serve.log" 2>&1) &
pid=$!
port=""
for _ in $(seq 1 120); do
  port="$(grep 'listening on' "$work/serve.log" | grep -o '127.0.0.1:[0-9]*' | head -1 | cut -d: -f2 || true)"
  [[ -z $port ]] || break
  sleep 1
done
[[ -n $port ]] || { echo "instructions.sh: tellus serve did not start" >&2; exit 1; }
vpid=$pid # valgrind runs in the process it was exec-ed as
for url in $(head -3 "$work/urls-W.txt") $(head -3 "$work/urls-A.txt"); do
  [[ "$(curl -s -o /dev/null -w '%{http_code}' "http://127.0.0.1:$port$url")" == 200 ]] ||
    { echo "instructions.sh: $url is not answered with 200" >&2; exit 1; }
done
for s in A W R; do # warm-up, not counted: first touches of the files, the row cache, the allocator
  URLS="$work/urls-$s.txt" wrk -t1 -c4 -d2s -s "$here/urls.lua" "http://127.0.0.1:$port" \
    >/dev/null 2>&1
done
echo "== $(date -u '+%F %H:%M') tellus $(stat -c '%y' "$TELLUS" | cut -d. -f1), wrk -t1 -c4 -d$DURATION"
for round in $(seq 1 "$ROUNDS"); do
  for s in A W R; do
    callgrind_control -z "$vpid" >/dev/null 2>&1
    URLS="$work/urls-$s.txt" RESULT="$work/res.txt" wrk -t1 -c4 -d"$DURATION" -s "$here/urls.lua" \
      "http://127.0.0.1:$port" >/dev/null 2>&1
    callgrind_control -d "$s$round" "$vpid" >/dev/null 2>&1
    sleep 1
    dump="$(ls -t "$work"/cg.out.* | head -1)"
    ir="$(grep -m1 '^summary:' "$dump" | awk '{print $2}')"
    n="$(grep -o 'requests=[0-9]*' "$work/res.txt" | cut -d= -f2)"
    echo "$s round $round: requests=$n Ir=$ir Ir/req=$((ir / n))"
  done
done
