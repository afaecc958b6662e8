#!/usr/bin/env bash
# Cached tiles through tellus serve against nginx serving the same files (what `make bench-proxy`
# runs), then tellus's resident memory with 1,000 idle keep-alive connections open.
#
#   bench/proxy/run.sh
#
# Seeds a temporary cache (levels 0-2 of the embedded `bluemarble` layer), starts `tellus serve` and
# an nginx of its own (a minimal nginx.conf in the temp dir, 127.0.0.1 only) on that cache's dataset
# folder, and writes one list of random tile keys (fixed seed) as five URL lists:
#
#   A  tellus World Wind   /wwtile?T=bluemarble&L=&X=&Y=
#   B  tellus static path  /tiles/bluemarble/L/R/R_C.jpg
#   C  tellus WMS 1.1.1    GetMap SRS=EPSG:4326, BBOX=w,s,e,n of the tile, 512x512, image/jpeg
#   D  tellus WMS 1.3.0    GetMap CRS=EPSG:4326, BBOX=s,w,n,e (lat/lon axis order)
#   W  tellus WMTS KVP     GetTile in the layer's own set WorldWind_<layer> (TILEROW counted from
#                          the top: rows - 1 - R), the same cached files
#   R  tellus WMTS REST    /wmts/1.0.0/<layer>/default/WorldWind_<layer>/L/<row>/C.jpg
#   N  nginx static files  /L/R/R_C.jpg
#
# Each series is one `wrk -t2 -c64 -d10s --latency` run with bench/proxy/urls.lua (a random URL of
# the list per request). The set runs ROUNDS times, alternating the order (A B C D W R N, N R W ...),
# and the summary gives the median per series, its ratio to nginx and the goals of issue #3
# (>= 0.95x nginx, p99 < 5 ms at 64 connections; RSS < 100 MiB with 1,000 connections open).
#
# Settings (environment):
#   TELLUS=build/tools/tellus/tellus  binary (copied into the temp dir first, so a rebuild during the
#                                     run changes nothing)
#   DURATION=10s CONNECTIONS=64 WRK_THREADS=2 ROUNDS=2 WARMUP=2s (0 skips the warm-up)
#   LAYER=bluemarble LEVELS=0-2 URL_COUNT=10000 SEED=42
#   CACHE_DIR=            reuse this cache instead of seeding a temporary one (seeding is resumable)
#   IDLE_CONNECTIONS=1000 idle keep-alive connections for the memory test (0 skips it)
#   NGINX=nginx NGINX_PORT= (default: a free port in 20000-30000)
#   NGINX_OPEN_FILE_CACHE=0  1: open_file_cache in nginx (keeps descriptors of hot files open)
#   NGINX_TCP_NOPUSH=0       1: tcp_nopush on (two setsockopt calls per response)
#   SERVE_ARGS=           more arguments for `tellus serve` (e.g. "--config my.yaml")
#   HTTP_THREADS=         event-loop threads of tellus serve (`--threads`; default: its own, one
#                         per core but one)
#   COMPARE_THREADS=      also start a second tellus serve with `--threads COMPARE_THREADS`
#                         and add series T (/wwtile on it) to every round, just before N
#   LOAD_WAIT_S=0 MAX_LOAD=0.8  before the runs (after seeding), wait up to LOAD_WAIT_S seconds for
#                         a 1-minute load below MAX_LOAD (polled every 30 s)
#   OUT_DIR=build/bench   where proxy-runs.tsv and proxy-summary.txt go
#   KEEP=0                1: keep the temp dir (wrk logs, nginx.conf, URL lists)
#
# Needs wrk, nginx (Debian: apt-get install -y --no-install-recommends wrk nginx-light), curl,
# python3. Every server binds 127.0.0.1 only; nginx is started from its own config, never as the
# system service, and everything started here is stopped on exit.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"

TELLUS="${TELLUS:-$repo/build/tools/tellus/tellus}"
DURATION="${DURATION:-10s}"
CONNECTIONS="${CONNECTIONS:-64}"
WRK_THREADS="${WRK_THREADS:-2}"
ROUNDS="${ROUNDS:-2}"
WARMUP="${WARMUP:-2s}"
LAYER="${LAYER:-bluemarble}"
LEVELS="${LEVELS:-0-2}"
URL_COUNT="${URL_COUNT:-10000}"
SEED="${SEED:-42}"
CACHE_DIR="${CACHE_DIR:-}"
IDLE_CONNECTIONS="${IDLE_CONNECTIONS:-1000}"
NGINX="${NGINX:-nginx}"
NGINX_PORT="${NGINX_PORT:-}"
NGINX_OPEN_FILE_CACHE="${NGINX_OPEN_FILE_CACHE:-0}"
NGINX_TCP_NOPUSH="${NGINX_TCP_NOPUSH:-0}"
HTTP_THREADS="${HTTP_THREADS:-}"
COMPARE_THREADS="${COMPARE_THREADS:-}"
SERVE_ARGS="${SERVE_ARGS:-}"
LOAD_WAIT_S="${LOAD_WAIT_S:-0}"
MAX_LOAD="${MAX_LOAD:-0.8}"
OUT_DIR="${OUT_DIR:-$repo/build/bench}"
KEEP="${KEEP:-0}"

say() { echo "== $*"; }
warn() { echo "run.sh: warning: $*" >&2; }
die() {
  echo "run.sh: $*" >&2
  exit 1
}

# ------------------------------------------------------------------------------ prerequisites
[[ -x "$TELLUS" ]] || die "$TELLUS not found; build it first (cmake --build build -j2 --target tellus)"
for tool in wrk "$NGINX" curl python3 ss; do
  command -v "$tool" >/dev/null ||
    die "$tool not found (Debian: apt-get install -y --no-install-recommends wrk nginx-light curl python3 iproute2)"
done

# 1,000 client sockets in idle_conns.py and 1,000 server sockets in tellus, plus wrk's.
want_fds=$((IDLE_CONNECTIONS + 1024))
[[ $want_fds -lt 4096 ]] && want_fds=4096
if [[ "$(ulimit -n)" != unlimited && "$(ulimit -n)" -lt $want_fds ]]; then
  if ! ulimit -n "$want_fds" 2>/dev/null; then
    hard="$(ulimit -Hn)"
    ulimit -n "$hard" 2>/dev/null || true
    warn "cannot raise the open-file limit to $want_fds (now $(ulimit -n), hard limit $hard):" \
      "the $IDLE_CONNECTIONS-connection test may fail"
  fi
fi

base="${TMPDIR:-/tmp}"
work="$(mktemp -d "$base/tellus-bench-proxy.XXXXXX")"
chmod 755 "$work" # nginx workers may run as another user
pids=()
cleanup() {
  local p
  for p in "${pids[@]}"; do
    kill "$p" 2>/dev/null || true
  done
  for p in "${pids[@]}"; do
    wait "$p" 2>/dev/null || true
  done
  if [[ "$KEEP" == 1 ]]; then
    echo "== kept: $work"
  else
    rm -rf "$work"
  fi
}
trap cleanup EXIT
trap 'exit 130' INT TERM

load1() { cut -d' ' -f1 /proc/loadavg; }


say "tellus proxy vs nginx: $(date -u '+%Y-%m-%d %H:%M:%S UTC'), $(nproc) CPU(s), load: $(cut -d' ' -f1-3 /proc/loadavg)"
cp "$TELLUS" "$work/tellus"
# The imaging module (OpenImageIO inside, dlopen()ed on the first miss) goes next to the copy, where
# the loader looks first (else it would use the build tree's, which a rebuild may change).
imaging_module="$(dirname "$TELLUS")/../../imaging/libtellus_imaging.so"
[[ ! -f $imaging_module ]] || cp "$imaging_module" "$work/"
tellus="$work/tellus"
say "binary: $TELLUS ($(stat -c '%y' "$TELLUS" | cut -d. -f1)), $($NGINX -v 2>&1), $(wrk -v 2>&1 | head -1 | cut -d' ' -f1-2)"

# ------------------------------------------------------------------------------ cache and URLs
cache="${CACHE_DIR:-$work/cache}"
say "seeding $LAYER levels $LEVELS into $cache"
"$tellus" seed --cache "$cache" --data "$repo/data" --layer "$LAYER" --levels "$LEVELS"
shopt -s nullglob
folders=("$cache"/*/"$LAYER"-*/dataset.txt)
shopt -u nullglob
[[ ${#folders[@]} -eq 1 ]] || die "expected one dataset folder for $LAYER under $cache, found ${#folders[@]}"
dataset="$(dirname "${folders[0]}")"

python3 - "$dataset" "$LAYER" "$LEVELS" "$URL_COUNT" "$SEED" "$work" <<'EOF'
import math, os, random, sys
dataset, layer, levels, count, seed, work = sys.argv[1:7]
d = {}
for line in open(os.path.join(dataset, "dataset.txt")):
    if "=" in line and not line.startswith("#"):
        k, _, v = line.rstrip("\n").partition("=")
        d[k] = v
lo, _, hi = levels.partition("-")
lo, hi = int(lo), int(hi or lo)
west, south, east, north = (float(d[k]) for k in ("west", "south", "east", "north"))
delta0, ext = float(d["level_zero_delta"]), d["extension"]
w, h, mime = int(d["tile_width"]), int(d["tile_height"]), d["mime_type"]
rng = random.Random(int(seed))
keys = []
for _ in range(int(count)):
    level = rng.randint(lo, hi)
    delta = delta0 / 2**level
    rows = math.ceil((north - south) / delta - 1e-9)
    cols = math.ceil((east - west) / delta - 1e-9)
    row, col = rng.randrange(rows), rng.randrange(cols)
    path = os.path.join(dataset, str(level), str(row), f"{row}_{col}.{ext}")
    if not os.path.isfile(path):
        sys.exit(f"run.sh: {path} is not in the cache")
    keys.append((level, row, col, delta))
g = lambda v: f"{v:.10g}"
def sector(level, row, col, delta):
    s, wl = south + row * delta, west + col * delta
    return wl, s, min(east, wl + delta), min(north, s + delta)
series = {
    "A": lambda L, r, c, dl: f"/wwtile?T={layer}&L={L}&X={c}&Y={r}",
    "B": lambda L, r, c, dl: f"/tiles/{layer}/{L}/{r}/{r}_{c}.{ext}",
    "C": lambda L, r, c, dl: "/wms?SERVICE=WMS&VERSION=1.1.1&REQUEST=GetMap&LAYERS=%s&STYLES=&SRS=EPSG:4326"
         "&BBOX=%s,%s,%s,%s&WIDTH=%d&HEIGHT=%d&FORMAT=%s" % ((layer,) + tuple(map(g, sector(L, r, c, dl))) + (w, h, mime)),
    "D": lambda L, r, c, dl: "/wms?SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=%s&STYLES=&CRS=EPSG:4326"
         "&BBOX=%s,%s,%s,%s&WIDTH=%d&HEIGHT=%d&FORMAT=%s" % ((layer,) + tuple(map(g, (lambda W, S, E, N: (S, W, N, E))(*sector(L, r, c, dl)))) + (w, h, mime)),
    "W": lambda L, r, c, dl: "/wmts?SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=%s&STYLE=default"
         "&FORMAT=%s&TILEMATRIXSET=WorldWind_%s&TILEMATRIX=%d&TILEROW=%d&TILECOL=%d"
         % (layer, mime, layer, L, round(180 / dl) - 1 - r, c),
    "R": lambda L, r, c, dl: f"/wmts/1.0.0/{layer}/default/WorldWind_{layer}/{L}/{round(180 / dl) - 1 - r}/{c}.{ext}",
    "N": lambda L, r, c, dl: f"/{L}/{r}/{r}_{c}.{ext}",
}
for name, fmt in series.items():
    with open(os.path.join(work, f"urls-{name}.txt"), "w") as f:
        for k in keys:
            f.write(fmt(*k) + "\n")
with open(os.path.join(work, "files.txt"), "w") as f:
    for L, r, c, _ in keys:
        f.write(os.path.join(dataset, str(L), str(r), f"{r}_{c}.{ext}") + "\n")
distinct = len({k[:3] for k in keys})
sizes = [os.path.getsize(os.path.join(dataset, str(L), str(r), f"{r}_{c}.{ext}")) for L, r, c, _ in keys]
print(f"== {len(keys)} random keys on levels {lo}-{hi} (seed {seed}), {distinct} distinct tiles, "
      f"mean body {sum(sizes) / len(sizes):.0f} bytes")
EOF

# ------------------------------------------------------------------------------ servers
serve_env=(env)
[[ -n "$HTTP_THREADS" ]] && SERVE_ARGS="--threads $HTTP_THREADS $SERVE_ARGS"
# shellcheck disable=SC2086  # SERVE_ARGS is a list of words
"${serve_env[@]}" "$tellus" serve --cache "$cache" --data "$repo/data" --listen 127.0.0.1:0 $SERVE_ARGS \
  >"$work/serve.log" 2>&1 &
tellus_pid=$!
pids+=("$tellus_pid")
wait_port() { # LOG: the port tellus prints
  local i
  for i in $(seq 1 100); do
    local p
    p="$(grep -o 'listening on http://127.0.0.1:[0-9]*' "$1" 2>/dev/null | sed 's/.*://' || true)"
    if [[ -n "$p" ]]; then
      echo "$p"
      return 0
    fi
    sleep 0.1
  done
  cat "$1" >&2
  return 1
}
tellus_port="$(wait_port "$work/serve.log")" || die "tellus serve did not start"
series="A B C D W R N"
if [[ -n "$COMPARE_THREADS" ]]; then
  # shellcheck disable=SC2086
  "$tellus" serve --cache "$cache" --data "$repo/data" --listen 127.0.0.1:0 $SERVE_ARGS \
    --threads "$COMPARE_THREADS" \
    >"$work/serve-t.log" 2>&1 &
  tellus_t_pid=$!
  pids+=("$tellus_t_pid")
  tellus_t_port="$(wait_port "$work/serve-t.log")" || die "the second tellus serve did not start"
  cp "$work/urls-A.txt" "$work/urls-T.txt"
  series="A B C D W R T N"
  say "second tellus serve (series T) on 127.0.0.1:$tellus_t_port (pid $tellus_t_pid, $COMPARE_THREADS loop threads)"
fi

port_free() { ! ss -Htan "( sport = :$1 )" | grep -q .; }
if [[ -z "$NGINX_PORT" ]]; then
  for _ in $(seq 1 200); do
    candidate=$((20000 + RANDOM % 10001))
    if port_free "$candidate"; then
      NGINX_PORT=$candidate
      break
    fi
  done
  [[ -n "$NGINX_PORT" ]] || die "no free port found in 20000-30000"
elif ! port_free "$NGINX_PORT"; then
  die "port $NGINX_PORT is in use"
fi
mkdir -p "$work/nginx/logs"
{
  [[ $EUID -eq 0 ]] && echo "user root;" # workers read the temp cache as the caller
  cat <<EOF
worker_processes 2;
daemon off;
pid $work/nginx/nginx.pid;
error_log $work/nginx/logs/error.log warn;
events { worker_connections 4096; }
http {
  types { image/jpeg jpg jpeg; image/png png; application/octet-stream bil; }
  default_type application/octet-stream;
  access_log off;
  sendfile on;
  keepalive_timeout 65;
  keepalive_requests 1000000;
  client_body_temp_path $work/nginx/client_body;
  proxy_temp_path $work/nginx/proxy;
  fastcgi_temp_path $work/nginx/fastcgi;
  uwsgi_temp_path $work/nginx/uwsgi;
  scgi_temp_path $work/nginx/scgi;
EOF
  [[ "$NGINX_TCP_NOPUSH" == 1 ]] && echo "  tcp_nopush on;"
  if [[ "$NGINX_OPEN_FILE_CACHE" == 1 ]]; then
    echo "  open_file_cache max=10000 inactive=60s;"
    echo "  open_file_cache_valid 60s;"
  fi
  cat <<EOF
  server {
    listen 127.0.0.1:$NGINX_PORT;
    root $dataset;
  }
}
EOF
} >"$work/nginx/nginx.conf"
"$NGINX" -p "$work/nginx" -c "$work/nginx/nginx.conf" -e "$work/nginx/logs/error.log" &
nginx_pid=$!
pids+=("$nginx_pid")
for _ in $(seq 1 50); do
  curl -s -o /dev/null "http://127.0.0.1:$NGINX_PORT/" && break
  sleep 0.1
done
kill -0 "$nginx_pid" 2>/dev/null || die "nginx did not start: $(cat "$work/nginx/logs/error.log")"
say "tellus serve on 127.0.0.1:$tellus_port (pid $tellus_pid, $(awk '$1 == "Threads:" { print $2 }' "/proc/$tellus_pid/status") threads${HTTP_THREADS:+, HTTP_THREADS=$HTTP_THREADS}), nginx on 127.0.0.1:$NGINX_PORT (pid $nginx_pid; open_file_cache $([[ $NGINX_OPEN_FILE_CACHE == 1 ]] && echo on || echo off), tcp_nopush $([[ $NGINX_TCP_NOPUSH == 1 ]] && echo on || echo off))"

nginx_pids() { echo "$nginx_pid" $(pgrep -P "$nginx_pid" || true); }
cpu_ticks() { # PIDS...: user + system clock ticks, all threads
  local t=0 p
  for p in "$@"; do
    [[ -r /proc/$p/stat ]] || continue
    t=$((t + $(awk '{ sub(/.*\) /, ""); print $12 + $13 }' "/proc/$p/stat")))
  done
  echo "$t"
}
mem_kib() { # PID FIELD: VmRSS, VmHWM, ... in KiB
  awk -v f="$2:" '$1 == f { print $2 }' "/proc/$1/status"
}

declare -A label=(
  [A]="tellus World Wind /wwtile"
  [B]="tellus static /tiles/"
  [C]="tellus WMS 1.1.1 GetMap"
  [D]="tellus WMS 1.3.0 GetMap"
  [T]="tellus /wwtile, ${COMPARE_THREADS:-?} thr."
  [W]="tellus WMTS KVP GetTile"
  [R]="tellus WMTS RESTful"
  [N]="nginx static files"
)
port_of() {
  case $1 in
    N) echo "$NGINX_PORT" ;;
    T) echo "$tellus_t_port" ;;
    *) echo "$tellus_port" ;;
  esac
}
pids_of() {
  case $1 in
    N) nginx_pids ;;
    T) echo "$tellus_t_pid" ;;
    *) echo "$tellus_pid" ;;
  esac
}

# Every series must answer the tile's bytes, not an error or an exception document.
for s in $series; do
  head -n 20 "$work/urls-$s.txt" | paste - <(head -n 20 "$work/files.txt") | while IFS=$'\t' read -r url file; do
    curl -sf -o "$work/check.bin" "http://127.0.0.1:$(port_of "$s")$url" || die "series $s: $url failed"
    cmp -s "$work/check.bin" "$file" || die "series $s: $url did not answer the bytes of $file"
  done
done
say "checked: the first 20 URLs of every series answer the cached file's bytes"

# ------------------------------------------------------------------------------ load runs
# Jiffies of the whole machine: user+nice+system+irq+softirq (the kernel charges the ticks that
# /proc/stat books as irq/softirq to the interrupted task as well) and steal.
machine_ticks() { awk '$1 == "cpu" { print $2 + $3 + $4 + $7 + $8, $9 }' /proc/stat; }
time_bin="$(command -v time 2>/dev/null | grep / || true)"
[[ -z "$time_bin" && -x /usr/bin/time ]] && time_bin=/usr/bin/time

one_run() { # SERIES ROUND DURATION -> a line of runs.tsv
  local s=$1 round=$2 dur=$3 t0 t1 m0 m1 load wrk_cpu=0
  local log="$work/wrk-$s-$round.log" res="$work/res-$s-$round.txt" tf="$work/time-$s-$round.txt"
  local timer=()
  [[ -n "$time_bin" ]] && timer=("$time_bin" -f '%U %S' -o "$tf")
  # shellcheck disable=SC2046
  t0=$(cpu_ticks $(pids_of "$s"))
  m0="$(machine_ticks)"
  load="$(load1)"
  URLS="$work/urls-$s.txt" SEED="$SEED" RESULT="$res" \
    "${timer[@]}" wrk -t"$WRK_THREADS" -c"$CONNECTIONS" -d"$dur" --latency -s "$here/urls.lua" \
    "http://127.0.0.1:$(port_of "$s")" >"$log" 2>&1 || die "wrk failed: $(cat "$log")"
  # shellcheck disable=SC2046
  t1=$(cpu_ticks $(pids_of "$s"))
  m1="$(machine_ticks)"
  [[ -s "$res" ]] || die "wrk wrote no result: $(cat "$log")"
  [[ -s "$tf" ]] && wrk_cpu="$(awk '{ print $1 + $2 }' "$tf")"
  # series round load server_ticks wrk_cpu_s machine_task_ticks machine_steal_ticks RESULT fields
  echo -e "$s\t$round\t$load\t$((t1 - t0))\t$wrk_cpu\t$((${m1% *} - ${m0% *}))\t$((${m1#* } - ${m0#* }))\t$(sed 's/^RESULT //' "$res")"
}

if [[ "$LOAD_WAIT_S" -gt 0 ]]; then
  waited=0
  while awk -v l="$(load1)" -v m="$MAX_LOAD" 'BEGIN { exit !(l >= m) }'; do
    if [[ $waited -ge $LOAD_WAIT_S ]]; then
      warn "load $(load1) still >= $MAX_LOAD after ${waited}s: measuring anyway"
      break
    fi
    say "waiting for a 1-minute load below $MAX_LOAD (now $(load1))"
    sleep 30
    waited=$((waited + 30))
  done
fi

say "load before the runs: $(cut -d' ' -f1-3 /proc/loadavg)"
if [[ "$WARMUP" != 0 ]]; then
  say "warm-up: $WARMUP per series"
  for s in $series; do
    one_run "$s" 0 "$WARMUP" >/dev/null
  done
fi

runs="$work/runs.tsv"
: >"$runs"
for round in $(seq 1 "$ROUNDS"); do
  if ((round % 2)); then order="$series"; else order="$(echo "$series" | tr ' ' '\n' | tac | tr '\n' ' ' | sed 's/ $//')"; fi
  say "round $round/$ROUNDS: $order (wrk -t$WRK_THREADS -c$CONNECTIONS -d$DURATION --latency)"
  for s in $order; do
    line="$(one_run "$s" "$round" "$DURATION")"
    echo "$line" >>"$runs"
    echo "   $s ${label[$s]}: $(echo "$line" | cut -f8- | tr '\t' ' ')"
  done
done

hz=$(getconf CLK_TCK)
after_wrk_rss=$(mem_kib "$tellus_pid" VmRSS)
after_wrk_hwm=$(mem_kib "$tellus_pid" VmHWM)
after_wrk_anon=$(mem_kib "$tellus_pid" RssAnon)
after_wrk_file=$(mem_kib "$tellus_pid" RssFile)
after_wrk_threads=$(awk '$1 == "Threads:" { print $2 }' "/proc/$tellus_pid/status")
nginx_rss=0
for p in $(nginx_pids); do nginx_rss=$((nginx_rss + $(mem_kib "$p" VmRSS))); done

# ------------------------------------------------------------------------------ summary
mkdir -p "$OUT_DIR"
cp "$runs" "$OUT_DIR/proxy-runs.tsv"
summary="$OUT_DIR/proxy-summary.txt"
for s in $series; do echo "$s ${label[$s]}"; done >"$work/labels.txt"
python3 - "$runs" "$hz" "$DURATION" "$CONNECTIONS" "$(nproc)" "$work/labels.txt" <<'EOF' | tee "$summary"
import statistics, sys
runs, hz, duration, conns, ncpu = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4], int(sys.argv[5])
label = dict(line.rstrip("\n").split(" ", 1) for line in open(sys.argv[6]))
rows = {}
for line in open(runs):
    f = line.rstrip("\n").split("\t")
    kv = dict(x.split("=") for x in f[7].split())
    wall = int(kv["duration_us"]) / 1e6
    kv.update(load=float(f[2]), cpu_s=int(f[3]) / hz, wrk_s=float(f[4]))
    # CPU of every other task on the machine during the run, in % of all CPUs, and steal
    kv.update(other=(int(f[5]) / hz - kv["cpu_s"] - kv["wrk_s"]) / (wall * ncpu) * 100,
              steal=int(f[6]) / hz / (wall * ncpu) * 100)
    kv["round"] = f[1]
    rows.setdefault(f[0], []).append(kv)
med = lambda s, k: statistics.median(float(r[k]) for r in rows[s])
n_rps = med("N", "req_s")
print()
print(f"Median of {len(rows['N'])} rounds per series; wrk -c{conns} -d{duration}; latency from wrk's distribution.")
print(f"{'series':<27}{'req/s':>9}{'(min-max)':>17}{'p50 ms':>8}{'p99 ms':>8}{'p99.9':>8}"
      f"{'vs nginx':>9}{'CPU us/req':>11}{'srv CPU%':>9}{'wrk CPU%':>9}{'other%':>7}{'steal%':>7}{'errors':>7}  goals")
for s in label:
    rs = rows[s]
    rps = med(s, "req_s")
    lo, hi = min(float(r["req_s"]) for r in rs), max(float(r["req_s"]) for r in rs)
    p50, p99, p999 = med(s, "p50_us") / 1000, med(s, "p99_us") / 1000, med(s, "p999_us") / 1000
    cpu = statistics.median(r["cpu_s"] / int(r["requests"]) * 1e6 for r in rs)
    srv = statistics.median(r["cpu_s"] / (int(r["duration_us"]) / 1e6) * 100 for r in rs)
    wrk = statistics.median(r["wrk_s"] / (int(r["duration_us"]) / 1e6) * 100 for r in rs)
    other = statistics.median(r["other"] for r in rs)
    steal = statistics.median(r["steal"] for r in rs)
    errors = sum(int(r[k]) for r in rs for k in ("connect", "read", "write", "status", "timeout"))
    ratio = rps / n_rps
    if s == "N":
        goal = f"p99 {'<' if p99 < 5 else '>='} 5 ms"
    else:
        g1 = "met" if ratio >= 0.95 else "MISSED"
        g2 = "met" if p99 < 5 else "MISSED"
        goal = f">=0.95x {g1}, p99<5ms {g2}"
    print(f"{label[s]:<27}{rps:>9.0f}{f'({lo:.0f}-{hi:.0f})':>17}{p50:>8.2f}{p99:>8.2f}{p999:>8.2f}"
          f"{ratio:>8.2f}x{cpu:>11.1f}{srv:>9.0f}{wrk:>9.0f}{other:>7.0f}{steal:>7.0f}{errors:>7}  {goal}")
for s in ("W", "R"):
    if s in label:
        print(f"{label[s]} against /wwtile in the same rounds: {med(s, 'req_s') / med('A', 'req_s'):.3f}x "
              f"(issue 25's goal: within 5 %)")
loads = [r["load"] for s in rows for r in rows[s]]
print(f"1-minute load at the start of the runs: {min(loads):.2f}-{max(loads):.2f}")
print("CPU us/req: the server's user+system CPU time (all threads/workers) per answered request;")
print(f"srv/wrk CPU%: the server's and wrk's CPU time in % of one CPU; other%/steal%: CPU taken by every")
print(f"other task on the machine / stolen by the hypervisor, in % of all {ncpu} CPUs (medians over rounds).")
disturbed = [f"{s}{r['round']}" for s in label for r in rows[s] if r["other"] > 10]
if disturbed:
    print(f"WARNING: other tasks took more than 10% of the CPUs during {len(disturbed)} of "
          f"{sum(len(v) for v in rows.values())} runs ({' '.join(disturbed)}): compare those with care")
print("Per run (series round req/s p99 ms other%):",
      "  ".join(f"{s}{r['round']} {float(r['req_s']):.0f} {int(r['p99_us']) / 1000:.1f} {r['other']:.0f}"
                for s in label for r in rows[s]))
EOF
{
  echo "tellus after the load runs: VmRSS $((after_wrk_rss / 1024)) MiB (RssAnon $((after_wrk_anon / 1024))," \
    "RssFile $((after_wrk_file / 1024))), VmHWM $((after_wrk_hwm / 1024)) MiB," \
    "$after_wrk_threads threads; nginx (master + workers) VmRSS $((nginx_rss / 1024)) MiB"
} | tee -a "$summary"

# ------------------------------------------------------------------------------ memory with idle connections
if [[ "$IDLE_CONNECTIONS" -gt 0 ]]; then
  kill "$tellus_pid"
  wait "$tellus_pid" 2>/dev/null || true
  # shellcheck disable=SC2086
  "${serve_env[@]}" "$tellus" serve --cache "$cache" --data "$repo/data" --listen 127.0.0.1:0 $SERVE_ARGS \
    >"$work/serve2.log" 2>&1 &
  tellus_pid=$!
  pids+=("$tellus_pid")
  tellus_port="$(wait_port "$work/serve2.log")" || die "tellus serve did not start"
  sleep 1
  idle_test() { # NAME PORT SERIES PIDS...: RSS before, with IDLE_CONNECTIONS connections open, after
    local name=$1 port=$2 series=$3
    shift 3
    local before=0 during=0 after=0 hwm=0 p established opened
    for p in "$@"; do before=$((before + $(mem_kib "$p" VmRSS))); done
    rm -f "$work/hold"
    mkfifo "$work/hold"
    python3 "$here/idle_conns.py" 127.0.0.1 "$port" "$work/urls-$series.txt" "$IDLE_CONNECTIONS" 50 \
      <"$work/hold" >"$work/idle-$name.out" 2>&1 &
    local idle_pid=$!
    exec 7>"$work/hold"
    for _ in $(seq 1 600); do
      grep -q '^OPEN' "$work/idle-$name.out" && break
      kill -0 "$idle_pid" 2>/dev/null || break
      sleep 0.1
    done
    sleep 1
    opened="$(grep '^OPEN' "$work/idle-$name.out" || echo "OPEN 0 (failed: $(cat "$work/idle-$name.out"))")"
    established=$(ss -Htn state established "( sport = :$port )" | wc -l)
    local anon=0 file=0
    for p in "$@"; do
      during=$((during + $(mem_kib "$p" VmRSS)))
      anon=$((anon + $(mem_kib "$p" RssAnon)))
      file=$((file + $(mem_kib "$p" RssFile)))
    done
    exec 7>&-
    wait "$idle_pid" || warn "$name: not every idle connection got its tile ($(cat "$work/idle-$name.out"))"
    sleep 2
    for p in "$@"; do
      after=$((after + $(mem_kib "$p" VmRSS)))
      hwm=$((hwm + $(mem_kib "$p" VmHWM)))
    done
    echo "$name with $IDLE_CONNECTIONS idle keep-alive connections ($opened; $established established at the server):" \
      "VmRSS before $((before / 1024)) MiB, during $((during / 1024)) MiB (RssAnon $((anon / 1024)), RssFile $((file / 1024)))," \
      "after $((after / 1024)) MiB;" \
      "VmHWM $((hwm / 1024)) MiB; $(((during - before) * 1024 / IDLE_CONNECTIONS)) bytes per connection"
  }
  {
    echo
    idle_test tellus "$tellus_port" A "$tellus_pid" | sed "s/^tellus /tellus (a fresh serve) /"
  } | tee -a "$summary"
  # shellcheck disable=SC2046
  idle_test nginx "$NGINX_PORT" N $(nginx_pids) | tee -a "$summary"
  rss_mib=$(grep -o 'during [0-9]* MiB' "$summary" | head -1 | grep -o '[0-9]*')
  if [[ -n "$rss_mib" && "$rss_mib" -lt 100 ]]; then
    echo "goal RSS < 100 MiB with $IDLE_CONNECTIONS connections open: met ($rss_mib MiB)" | tee -a "$summary"
  else
    echo "goal RSS < 100 MiB with $IDLE_CONNECTIONS connections open: MISSED (${rss_mib:-?} MiB)" | tee -a "$summary"
  fi
fi
say "runs: $OUT_DIR/proxy-runs.tsv, summary: $OUT_DIR/proxy-summary.txt"
