# ONLY=burst of run.sh (sourced by it once the upstream answers): single flight across three
# instances of each server sharing one cache (issue 27), side by side in one run.
#
#   ONLY=burst bench/peers/run.sh                        # about 2-3 minutes
#   ONLY=burst ROUNDS=1 bench/peers/run.sh               # a smoke run
#
# Three instances of each server, one cache shared by the three:
#   tellus    three `tellus serve` on one PostgreSQL index (tests/support/postgres.sh: leases are
#             advisory locks, waiters woken by LISTEN/NOTIFY) and one shared cache folder, or with
#             BURST_STORE=s3 one S3 bucket (tests/support/s3-server.sh: Swift + s3api) behind
#             each instance's own local tier
#   MapCache  three private Apaches (mod_mapcache, MAPCACHE_PROCS x MAPCACHE_THREADS each) on one
#             disk cache, with MapCache's memcache locker on one memcached (Debian memcached;
#             retry MC_LOCK_RETRY s, MapCache's default 0.1)
#   MapProxy  three gunicorns (Debian python3-mapproxy and gunicorn, MAPPROXY_WORKERS gthread
#             workers x MAPPROXY_THREADS) on one cache directory, with MapProxy's file locks in it
# Every round, each server in turn (the order reversed every other round) gets two bursts of
# BURST (300) connected clients let go at once, round-robin over its three instances
# (BURST_CLIENT: build/bench/tellus_bench_burst, one thread per client, built beside TELLUS; or
# BURST_CLIENT=python, tests/cli/burst.py, whose threads take turns on Python's one lock to read
# their answers, adding tens of milliseconds to every server's tail: bench/RESULTS.md):
#   tile  every client asks for one missing tile (level BURST_LEVEL, a tile inside a metatile, east
#         of BURST_AT);
#   meta  the clients ask for the 16 tiles of one missing 4x4 metatile, client i for tile i mod 16.
# Each round uses metatiles no round used before (each server keeps its cache). Counted: the
# upstream's requests during the burst (its access log), p50/p99/max latency; every answer must be
# a 200 image/* and every tile one body.
#
# The same work upstream: on a miss all three fetch the tile's whole 4x4 metatile (one 2048 px
# GetMap; tellus serve does on a shared index, TileServiceOptions::metaTilesOnMiss).

BURST="${BURST:-300}"
BURST_LEVEL="${BURST_LEVEL:-6}"
BURST_AT="${BURST_AT:-12,0}" # lon,lat: central Africa, land (ocean tiles are all one colour)
MC_LOCK_RETRY="${MC_LOCK_RETRY:-0.1}"
BURST_STORE="${BURST_STORE:-folder}" # folder: one shared cache folder; s3: one S3 bucket
TELLUS_THREADS="${TELLUS_THREADS:-}"
burst_py="$repo/tests/cli/burst.py"
BURST_CLIENT="${BURST_CLIENT:-$(dirname "$TELLUS")/../../bench/tellus_bench_burst}"
if [[ "$BURST_CLIENT" == python ]]; then
  burst_client=(python3 "$burst_py")
else
  [[ -x "$BURST_CLIENT" ]] || die "no burst client $BURST_CLIENT (cmake --build build --target tellus_bench_burst, or BURST_CLIENT=python)"
  burst_client=("$BURST_CLIENT")
fi
b="$work/burst"
mkdir -p "$b"

# ---------------------------------------------------------------- tellus: PostgreSQL + a folder
pg_dir="$b/pg"
pg_uri="$("$repo/tests/support/postgres.sh" start "$pg_dir")" || die "PostgreSQL did not start"
mkdir -p "$b/tellus"
if [[ "$BURST_STORE" == s3 ]]; then # one bucket (Swift + s3api), each instance its local tier
  s3_dir="$b/s3"
  "$repo/tests/support/s3-server.sh" start "$s3_dir" >/dev/null || die "the S3 server did not start"
  # shellcheck disable=SC1091
  . "$s3_dir/s3.env"
  export AWS_ACCESS_KEY_ID AWS_SECRET_ACCESS_KEY
  cache_line="cache: {index: \"$pg_uri\", store: \"s3://$S3_BUCKET/burst\", s3: {endpoint: \"$S3_ENDPOINT\", region: $S3_REGION}}"
else
  cache_line="cache: {index: \"$pg_uri\"}"
fi
{
  echo "$cache_line"
  cat "$here/tellus.yaml"
} >"$b/tellus/tellus.tmpl"
fill "$b/tellus/tellus.tmpl" "$b/tellus/tellus.yaml" "UPSTREAM_URL=$upstream_url" "SEED_CONCURRENCY=$SEED_CONCURRENCY"
tellus_ports=()
threads=()
[[ -z "$TELLUS_THREADS" ]] || threads=(--threads "$TELLUS_THREADS")
access=() # KEEP=1: each instance's access log (latency and cache outcome of every answer)
for k in 0 1 2; do
  root="$b/tellus/cache"
  [[ "$BURST_STORE" != s3 ]] || root="$b/tellus/cache$k" # the local tiers are each its own
  [[ -z "${KEEP:-}" ]] || access=(--access-log "$b/tellus/access$k.log")
  "$tellus" serve --config "$b/tellus/tellus.yaml" --cache "$root" --listen 127.0.0.1:0 \
    "${threads[@]}" "${access[@]}" >"$b/tellus/serve$k.log" 2>&1 &
  pids+=($!)
done
for k in 0 1 2; do
  port=""
  for _ in $(seq 1 200); do
    port="$(grep -o 'listening on http://127.0.0.1:[0-9]*' "$b/tellus/serve$k.log" | sed 's/.*://' || true)"
    [[ -n "$port" ]] && break
    sleep 0.1
  done
  [[ -n "$port" ]] || die "tellus serve $k did not start: $(cat "$b/tellus/serve$k.log")"
  tellus_ports+=("$port")
done

# ---------------------------------------------------------------- MapCache: memcached + 3 Apaches
mc_lock_port="$(free_port)"
memcached_user=()
[[ $EUID -ne 0 ]] || memcached_user=(-u nobody)
memcached -l 127.0.0.1 -p "$mc_lock_port" -U 0 -m 64 -c 4096 "${memcached_user[@]}" >"$b/memcached.log" 2>&1 &
pids+=($!)
mkdir -p "$b/mapcache/cache"
fill "$here/mapcache.xml" "$b/mapcache/mapcache.xml" "WORK=$b" "UPSTREAM_URL=$upstream_url"
# the disk locker of the single-instance runs becomes the memcache locker shared by the three
MC_PORT="$mc_lock_port" MC_RETRY="$MC_LOCK_RETRY" python3 - "$b/mapcache/mapcache.xml" <<'EOF'
import os, re, sys
p = sys.argv[1]
t = open(p).read()
locker = (f'<locker type="memcache">\n    <server><host>127.0.0.1</host><port>{os.environ["MC_PORT"]}</port></server>\n'
          f'    <retry>{os.environ["MC_RETRY"]}</retry>\n    <timeout>120</timeout>\n  </locker>')
t, n = re.subn(r'<locker type="disk">.*?</locker>', locker, t, flags=re.S)
assert n == 1, "mapcache.xml: no disk locker to replace"
open(p, "w").write(t)
EOF
[[ $EUID -ne 0 ]] || chown -R www-data:www-data "$b/mapcache/cache"
mc_ports=()
for k in 0 1 2; do
  d="$b/mc$k"
  mkdir -p "$d/mapcache/apache"
  cp "$b/mapcache/mapcache.xml" "$d/mapcache/mapcache.xml"
  port="$(free_port)"
  fill "$here/httpd-mapcache.conf" "$d/mapcache/apache/httpd.conf" "WORK=$d" "PORT=$port" "USER_LINES=$user_lines" \
    "PROCS=$MAPCACHE_PROCS" "THREADS=$MAPCACHE_THREADS" "MAX_WORKERS=$((MAPCACHE_PROCS * MAPCACHE_THREADS))"
  start_apache "$d/mapcache/apache/httpd.conf" "$port"
  mc_ports+=("$port")
done

# ---------------------------------------------------------------- MapProxy: 3 gunicorns, one dir
mp_python=/usr/bin/python3
mp_gunicorn=/usr/bin/gunicorn
"$mp_python" -c 'import mapproxy' 2>/dev/null || die "no python3-mapproxy (apt-get install python3-mapproxy gunicorn)"
mkdir -p "$b/mapproxy/cache"
fill "$here/mapproxy.yaml" "$b/mapproxy/mapproxy.yaml" "WORK=$b" "UPSTREAM_URL=$upstream_url"
mp_version="$("$mp_python" -c 'from mapproxy.version import version; print(version)')"
mp_ports=()
for k in 0 1 2; do
  d="$b/mp$k"
  mkdir -p "$d"
  printf 'from mapproxy.wsgiapp import make_wsgi_app\napplication = make_wsgi_app(%s)\n' \
    "'$b/mapproxy/mapproxy.yaml'" >"$d/app.py"
  (cd "$d" && exec "$mp_gunicorn" -b 127.0.0.1:0 -w "$MAPPROXY_WORKERS" -k gthread --threads "$MAPPROXY_THREADS" \
    app:application) >"$d/gunicorn.log" 2>&1 &
  pids+=($!)
  mp_pid[$k]=$!
done
for k in 0 1 2; do
  d="$b/mp$k" port=""
  for _ in $(seq 1 200); do
    port="$(grep -o 'Listening at: http://127.0.0.1:[0-9]*' "$d/gunicorn.log" | sed 's/.*://' || true)"
    [[ -n "$port" ]] && break
    sleep 0.1
  done
  [[ -n "$port" ]] || die "gunicorn $k did not start: $(cat "$d/gunicorn.log")"
  for _ in $(seq 1 100); do
    [[ "$(pgrep -P "${mp_pid[$k]}" | wc -l)" -ge "$MAPPROXY_WORKERS" ]] &&
      curl -sf -o /dev/null "http://127.0.0.1:$port/tms/1.0.0/" && break
    sleep 0.2
  done
  mp_ports+=("$port")
done
say "burst: tellus ${tellus_ports[*]} (PostgreSQL index), MapCache ${mc_ports[*]} (memcached :$mc_lock_port)," \
  "MapProxy $mp_version ${mp_ports[*]} (gunicorn $("$mp_gunicorn" --version 2>&1 | grep -o '[0-9.]*' | head -1)); upstream :$up_port"

# ---------------------------------------------------------------- the bursts
burst_url() { # SERVER LEVEL ROW COL
  case $1 in
    tellus) echo "/wwtile?T=world&L=$2&X=$4&Y=$3" ;;
    MapCache) echo "/mapcache/tms/1.0.0/world@ww4326/$2/$4/$3.jpg" ;;
    MapProxy) echo "/tiles/world/ww4326/$2/$4/$3.jpeg" ;;
  esac
}
burst_ports() {
  case $1 in
    tellus) echo "${tellus_ports[*]}" ;;
    MapCache) echo "${mc_ports[*]}" ;;
    MapProxy) echo "${mp_ports[*]}" ;;
  esac
}
# the first 4x4-aligned metatile north-east of BURST_AT at BURST_LEVEL; round r's metatiles are
# the (2r)-th (tile) and (2r+1)-th (meta) east along its row
IFS=, read -r bw bs <<<"$BURST_AT"
read -r row0 col0 < <(python3 -c "
d = 36 / 2 ** $BURST_LEVEL
r, c = round(($bs + 90) / d), round(($bw + 180) / d)
print(r + (-r) % 4, c + (-c) % 4)")
# warm-up: every instance answers, its processes started (a level-1 tile, not counted); then each
# instance of the servers in WARM_SERVERS alone misses WARM_MISSES metatiles at once, twice, north
# of the measured ones: what a running server has done before a burst (a metatile cut on each of
# its threads) is done before the first measured one. A fresh tellus process's first metatile
# split costs 2-3x a later one (page faults on its coefficient arrays). MapCache is left out by
# default: warmed so, its bursts came out about one lock poll (0.1 s) slower, so it is measured
# as it was fastest (bench/RESULTS.md).
WARM_MISSES="${WARM_MISSES:-8}"
WARM_SERVERS="${WARM_SERVERS:-tellus MapProxy}"
for s in tellus MapCache MapProxy; do
  # shellcheck disable=SC2046
  "${burst_client[@]}" 30 "$(burst_url "$s" 1 3 3)" $(burst_ports "$s") >"$b/warm-$s.json" ||
    die "$s: the warm-up burst failed: $(cat "$b/warm-$s.json")"
  k=0
  [[ " $WARM_SERVERS " == *" $s "* && $WARM_MISSES -gt 0 ]] || continue
  for port in $(burst_ports "$s"); do
    for pass in 0 1; do
      list="$b/warm-$s-$k-$pass.txt"
      for j in $(seq 0 $((WARM_MISSES - 1))); do
        burst_url "$s" "$BURST_LEVEL" $((row0 + 8 + 4 * (2 * k + pass))) $((col0 + 4 * j + 1))
      done >"$list"
      "${burst_client[@]}" "$WARM_MISSES" "@$list" "$port" >"$b/warm-$s-$k-$pass.json" ||
        die "$s: a warm-up miss failed: $(cat "$b/warm-$s-$k-$pass.json")"
    done
    k=$((k + 1))
  done
done
bursts="$b/bursts.tsv"
: >"$bursts"
for round in $(seq 1 "$ROUNDS"); do
  order="tellus MapCache MapProxy"
  ((round % 2)) || order="MapProxy MapCache tellus"
  say "burst round $round/$ROUNDS: $order ($BURST clients over 3 instances each)"
  for kind in tile meta; do
    c=$((col0 + 4 * 2 * round))
    [[ $kind == tile ]] || c=$((c + 4))
    for s in $order; do
      list="$b/targets-$s-$kind-$round.txt"
      if [[ $kind == tile ]]; then
        burst_url "$s" "$BURST_LEVEL" $((row0 + 1)) $((c + 2)) >"$list"
      else
        for dr in 0 1 2 3; do for dc in 0 1 2 3; do
          burst_url "$s" "$BURST_LEVEL" $((row0 + dr)) $((c + dc))
        done; done >"$list"
      fi
      u0=$(upstream_requests)
      ok=1
      # shellcheck disable=SC2046
      res="$("${burst_client[@]}" "$BURST" "@$list" $(burst_ports "$s"))" || ok=0
      u1=$(upstream_requests)
      echo -e "$s\t$kind\t$round\t$((u1 - u0))\t$ok\t$res" >>"$bursts"
      echo "   $s $kind: $((u1 - u0)) upstream requests, $res"
    done
  done
done

# ---------------------------------------------------------------- summary
mkdir -p "$OUT_DIR"
summary="$OUT_DIR/peers-burst-summary.txt"
cp "$bursts" "$OUT_DIR/peers-bursts.tsv"
python3 - "$bursts" "$BURST" "$BURST_LEVEL" "$MC_LOCK_RETRY" "$(basename "${burst_client[-1]}")" <<'EOF' | tee "$summary"
import json, statistics, sys
path, n, level, retry, client = sys.argv[1:6]
rows = {}
for line in open(path):
    s, kind, rnd, up, ok, res = line.rstrip("\n").split("\t", 5)
    r = json.loads(res)
    r.update(up=int(up), ok=ok == "1")
    rows.setdefault((kind, s), []).append(r)
print()
print(f"== Single flight across 3 instances: {n} clients let go at once, level {level}; "
      f"medians of {max(len(v) for v in rows.values())} rounds (MapCache's lock retry {retry} s; client {client})")
print(f"{'burst':<6}{'server':<10}{'upstream req':>13}{'p50 ms':>9}{'p99 ms':>9}{'max ms':>9}  answers")
p99 = {}
for kind in ("tile", "meta"):
    for s in ("tellus", "MapCache", "MapProxy"):
        v = rows.get((kind, s))
        if not v:
            continue
        ups = sorted(r["up"] for r in v)
        p99[kind, s] = statistics.median(r["p99_ms"] for r in v)
        bad = [r["statuses"] for r in v if not r["ok"]]
        ans = "all 200 image/*, one body per tile" if not bad else f"NOT ALL 200 / ONE BODY: {bad}"
        up = f"{ups[0]}" if ups[0] == ups[-1] else f"{ups[0]}-{ups[-1]}"
        print(f"{kind:<6}{s:<10}{up:>13}{statistics.median(r['p50_ms'] for r in v):>9.1f}{p99[kind, s]:>9.1f}"
              f"{statistics.median(r['max_ms'] for r in v):>9.1f}  {ans}")
for kind in ("tile", "meta"):
    if (kind, "tellus") in p99 and (kind, "MapCache") in p99:
        r = p99[kind, "tellus"] / p99[kind, "MapCache"]
        ups = {r["up"] for r in rows[kind, "tellus"]}
        print(f"{kind}: tellus p99 / MapCache p99 = {r:.2f} (goal <= 0.5: {'met' if r <= 0.5 else 'MISSED'}); "
              f"tellus upstream requests per burst {sorted(ups)} (goal: 1 per metatile: "
              f"{'met' if ups == {1} else 'MISSED'})")
print("tile: one tile; meta: the 16 tiles of one 4x4 metatile, client i asking for tile i mod 16."
      " Each server fetches a miss's whole metatile (one 2048 px GetMap).")
EOF
say "bursts: $OUT_DIR/peers-bursts.tsv, summary: $summary"
