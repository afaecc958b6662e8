#!/usr/bin/env bash
# Cached tiles through Varnish in front of `tellus serve` against `tellus serve` alone (issue 27,
# docs/design/cdn.md), side by side in one run.
#
#   bench/cdn.sh
#
# Seeds a temporary cache (levels 0-2 of the embedded `bluemarble` layer), starts `tellus serve`
# and, in front of it, Varnish (tests/support/varnish.sh: config/examples/varnish.vcl, 64 MiB of
# malloc storage, 127.0.0.1 only). One list of random /wwtile URLs (fixed seed) is fetched once
# through Varnish to fill it, then each round runs `wrk --latency -s bench/proxy/urls.lua` on the
# same list against tellus (T) and through Varnish (V), alternating the order round by round
# (T V, V T, ...). Per series: req/s, p50 and p99 latency, and the servers' CPU per request
# (utime + stime of every process of the server, from /proc, over the run: Varnish's manager and
# child; tellus's one process), and how many requests reached tellus (its /metrics; 0 for V when
# every request was a Varnish hit). The summary gives medians and V/T ratios.
#
# Settings (environment):
#   TELLUS=build/tools/tellus/tellus (copied first)  DURATION=10s CONNECTIONS=64 WRK_THREADS=2
#   ROUNDS=4 LEVELS=0-2 URL_COUNT=2000 SEED=42 OUT_DIR=build/bench KEEP=0
# Needs wrk, varnishd and vmod_xkey (apt-get install varnish varnish-modules), curl, python3.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/.." && pwd)"
TELLUS="${TELLUS:-$repo/build/tools/tellus/tellus}"
DURATION="${DURATION:-10s}"
CONNECTIONS="${CONNECTIONS:-64}"
WRK_THREADS="${WRK_THREADS:-2}"
ROUNDS="${ROUNDS:-4}"
LEVELS="${LEVELS:-0-2}"
URL_COUNT="${URL_COUNT:-2000}"
SEED="${SEED:-42}"
OUT_DIR="${OUT_DIR:-$repo/build/bench}"
KEEP="${KEEP:-0}"
say() { echo "== $*"; }
die() { echo "cdn.sh: $*" >&2; exit 1; }
for tool in wrk varnishd curl python3; do command -v "$tool" >/dev/null || die "$tool not found"; done

work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-cdn-bench.XXXXXX")
chmod 755 "$work"
server=
cleanup() {
  "$repo/tests/support/varnish.sh" stop "$work/varnish" || true
  [ -n "$server" ] && kill "$server" 2>/dev/null || true
  [ "$KEEP" = 1 ] || rm -rf "$work"
}
trap cleanup EXIT
cp "$TELLUS" "$work/tellus"
tellus="$work/tellus"
say "binary: $TELLUS ($(stat -c '%y' "$TELLUS" | cut -d. -f1)), $(varnishd -V 2>&1 | head -n 1), $(wrk -v 2>&1 | head -n 1 | cut -d' ' -f1-2)"
say "tree: $(git -C "$repo" rev-parse --short HEAD)$(git -C "$repo" diff --quiet || echo ' (modified)')"
"$tellus" seed --cache "$work/cache" --data "$repo/data" --layer bluemarble --levels "$LEVELS" \
  >"$work/seed.log" 2>&1 || die "seed: $(tail -n 3 "$work/seed.log")"
"$tellus" serve --cache "$work/cache" --data "$repo/data" --listen 127.0.0.1:0 >"$work/serve.log" 2>&1 &
server=$!
for _ in $(seq 100); do grep -qs "listening on" "$work/serve.log" && break; sleep 0.1; done
tport=$(grep -o "127.0.0.1:[0-9]*" "$work/serve.log" | head -n 1 | cut -d: -f2)
[ -n "$tport" ] || die "serve did not start: $(cat "$work/serve.log")"
vport=$("$repo/tests/support/varnish.sh" start "$work/varnish" "$tport") || die "varnish did not start"
vpid=$(cat "$work/varnish/varnishd.pid")

python3 - "$LEVELS" "$URL_COUNT" "$SEED" >"$work/urls.txt" <<'PY'
import random, sys
lo, hi = (int(x) for x in sys.argv[1].split("-"))
rng = random.Random(int(sys.argv[3]))
for _ in range(int(sys.argv[2])):
    level = rng.randint(lo, hi)
    rows, cols = 5 * 2 ** level, 10 * 2 ** level  # bluemarble: 36-degree level 0
    print(f"/wwtile?T=bluemarble&L={level}&X={rng.randrange(cols)}&Y={rng.randrange(rows)}")
PY
say "filling Varnish with $(sort -u "$work/urls.txt" | wc -l) distinct tiles"
sort -u "$work/urls.txt" | while read -r u; do
  code=$(curl -s -o /dev/null -w "%{http_code}" "http://127.0.0.1:$vport$u")
  [ "$code" = 200 ] || die "$u: $code"
done

cpu_ticks() { # $@: pids; the sum of utime + stime of them and their children's threads
  local total=0 p
  for p in "$@"; do
    [ -r "/proc/$p/stat" ] || continue
    total=$((total + $(awk '{print $14 + $15}' "/proc/$p/stat")))
  done
  echo "$total"
}
varnish_pids() { echo "$vpid" $(pgrep -P "$vpid" || true); }
hz=$(getconf CLK_TCK)
mkdir -p "$OUT_DIR"
tsv="$OUT_DIR/cdn-runs.tsv"
printf "round\tseries\treq_s\tp50_us\tp99_us\tcpu_us_per_req\tnon2xx\ttellus_requests\n" >"$tsv"
tellus_requests() { # every request tellus answered so far (its /metrics)
  curl -s "http://127.0.0.1:$tport/metrics" |
    awk '/^tellus_http_requests_total/ {n += $NF} END {printf "%d", n}'
}
run() { # $1: round, $2: series T|V
  local port pids
  if [ "$2" = T ]; then port=$tport; pids=$server; else port=$vport; pids=$(varnish_pids); fi
  local before after served
  served=$(tellus_requests)
  before=$(cpu_ticks $pids)
  URLS="$work/urls.txt" SEED="$SEED" RESULT="$work/r.txt" wrk -t"$WRK_THREADS" -c"$CONNECTIONS" \
    -d"$DURATION" --latency -s "$repo/bench/proxy/urls.lua" "http://127.0.0.1:$port" >"$work/wrk-$1-$2.log"
  after=$(cpu_ticks $pids)
  served=$(($(tellus_requests) - served - 1)) # less the /metrics scrape itself
  python3 - "$1" "$2" "$before" "$after" "$hz" "$work/r.txt" "$served" >>"$tsv" <<'PY'
import sys
rnd, series, before, after, hz, path, served = sys.argv[1:8]
f = dict(kv.split("=") for kv in open(path).read().split()[1:])
n = int(f["requests"])
cpu = (int(after) - int(before)) / int(hz) * 1e6 / max(n, 1)
print(f"{rnd}\t{series}\t{float(f['req_s']):.0f}\t{f['p50_us']}\t{f['p99_us']}\t{cpu:.1f}\t{f['status']}\t{served}")
PY
  tail -n 1 "$tsv"
}
for r in $(seq "$ROUNDS"); do
  if [ $((r % 2)) = 1 ]; then run "$r" T; run "$r" V; else run "$r" V; run "$r" T; fi
done
python3 - "$tsv" <<'PY' | tee "$OUT_DIR/cdn-summary.txt"
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1]), delimiter="\t"))
def med(series, key):
    return statistics.median(float(r[key]) for r in rows if r["series"] == series)
for s, name in (("T", "tellus alone"), ("V", "through Varnish")):
    print(f"{name:16s} {med(s,'req_s'):9.0f} req/s  p50 {med(s,'p50_us')/1000:.2f} ms  "
          f"p99 {med(s,'p99_us')/1000:.2f} ms  server CPU {med(s,'cpu_us_per_req'):.1f} us/req")
print(f"Varnish / tellus: {med('V','req_s')/med('T','req_s'):.2f}x req/s, "
      f"p99 {med('V','p99_us')/med('T','p99_us'):.2f}x, "
      f"CPU per request {med('V','cpu_us_per_req')/med('T','cpu_us_per_req'):.2f}x")
bad = sum(int(r["non2xx"]) for r in rows)
print(f"non-2xx answers in all runs: {bad}")
through = sum(int(r["tellus_requests"]) for r in rows if r["series"] == "V")
print(f"requests that reached tellus during the Varnish runs: {through} (0: every one a hit)")
PY
