#!/usr/bin/env bash
# tellus against MapProxy and MapCache in front of the same upstream, side by side in one run (what
# `make bench-peers` runs; issue #4's performance goals).
#
#   bench/peers/run.sh                                   # the measured run, about 8-9 minutes
#   SEED_ROUNDS=1 ROUNDS=1 DURATION=2s WARMUP=0 LEVELS=0-3 CEILING_DURATION=3s LOAD_DURATION=3s \
#     bench/peers/run.sh                                 # a smoke run, about 1-1.5 minutes
#   ONLY=seed bench/peers/run.sh                         # step 1 alone (seeding), about 3 minutes
#   ONLY=mercator bench/peers/run.sh                     # Web Mercator tiles composed from the
#                                                        # lat/long caches: mercator.sh
#   ONLY=burst bench/peers/run.sh                        # single flight across 3 instances of
#                                                        # each server on one shared cache:
#                                                        # burst.sh, about 2-3 minutes
#
# What it sets up, every server on 127.0.0.1 only, on ports it picks (0 where the program allows):
#
#   upstream  MapServer 8 (mapserv as FastCGI under mod_fcgid, in a private Apache) serving
#             RASTER (default: the bundled Blue Marble, data/bmng_2048x1024.jpg) as WMS layer
#             "world"; its access log counts the requests every cache sends it
#   tellus    `tellus serve` with bench/peers/tellus.yaml (a WMS upstream)
#   MapCache  mod_mapcache (Debian libapache2-mod-mapcache) in a private Apache instance,
#             bench/peers/mapcache.xml, disk cache in MapCache's "worldwind" layout
#   MapProxy  PyPI MapProxy under gunicorn (gthread workers), bench/peers/mapproxy.yaml, in a venv
#             under PEERS_DIR (made on the first run)
#
# All three on the same grid (EPSG:4326, 36-degree level zero, 512 px JPEG tiles: the World Wind
# grid), then, in this order:
#
#  1. Seeding REGION levels LEVELS from the upstream into empty caches: MapServer alone first (the
#     ceiling: wrk making one 512 px GetMap per tile of the region, and one 2048 px GetMap per 4x4
#     metatile, at SEED_CONCURRENCY), then `tellus seed` twice (one GetMap per tile:
#     --meta-tiles 1; and its default, 4x4 metatiles), `mapproxy-seed` and `mapcache_seed` with
#     SEED_CONCURRENCY, each into an empty cache; SEED_ROUNDS rounds, the order reversed every
#     other round, medians. The rate is the region's tiles over the command's wall time (start-up
#     included); the upstream's access log gives the requests each one made and their failures.
#  2. The servers start on those caches; the first 20 URLs of every series must answer 200 with an
#     image/* Content-Type and a body. tellus's arbitrary-box answer is checked once first: a
#     tellus that does not compose arbitrary boxes yet answers an exception, and the row then says
#     "tellus: not supported" instead of a number.
#  3. Resident memory, idle: VmRSS (and PSS, which counts pages shared between processes once)
#     summed over every process of each server (Apache's parent and children, gunicorn's master and
#     workers).
#  4. Load runs: first the cached-tile series (wrk -c CONNECTIONS), then the arbitrary-box series
#     (wrk -c ARB_CONNECTIONS); for each kind a warm-up, then ROUNDS rounds in which the servers
#     alternate (tellus, MapCache, MapProxy, ...), the order reversed every other round; medians.
#     Memory is read again after each kind.
#     URLs come from one list of random tiles of the seeded set (fixed SEED) written in each
#     server's URL style, and one list of random boxes inside REGION (bench/proxy/urls.lua picks
#     one per request):
#       tw  tellus   /wwtile?T=world&L=&X=&Y=          ct  MapCache TMS  /mapcache/tms/1.0.0/world@ww4326/z/x/y.jpg
#       ts  tellus   /tiles/world/L/R/R_C.jpg          pt  MapProxy      /tiles/world/ww4326/z/x/y.jpeg
#       tm  tellus   WMS 1.1.1 GetMap, the tile's BBOX cm / pm  MapCache / MapProxy, the same GetMap
#       ta / ca / pa  WMS 1.3.0 GetMap CRS=EPSG:4326 (lat,lon BBOX), 1024x768 JPEG, a random box
#                     10-80 degrees wide inside REGION (composed from the cached tiles)
#     No upstream request may happen during the load runs (every answer from a cache): checked.
#  5. Resident memory under load: wrk -c LOAD_CONNECTIONS for LOAD_DURATION on each server's cached
#     tiles (tw, ct, pt), the summed RSS and PSS sampled every 0.25 s; the peak is reported.
#
# Goals (issue #4): cached tiles >= 1.05x MapCache and >= 6x MapProxy; arbitrary boxes >= 1.7x
# MapCache and >= 6x MapProxy; seeding at the upstream's limit and >= MapProxy; RSS < 100 MiB under
# load. Absolute figures move between runs and machines; compare ratios from one run.
#
# Settings (environment):
#   TELLUS=build/tools/tellus/tellus  (copied into the work folder first, with the imaging module)
#   PEERS_DIR=build/peers-bench   the venv (kept between runs) and each run's work folder
#   DURATION=10s CONNECTIONS=64 ARB_CONNECTIONS=16 WRK_THREADS=2 ROUNDS=3 WARMUP=2s (0: none)
#   REGION=-36,-18,72,54 (W,S,E,N; aligned to the 36-degree level-zero tiles)
#   LEVELS=0-4                    0-3 at least: the arbitrary boxes are composed from levels 0-3
#   URL_COUNT=10000 ARB_COUNT=2000 SEED=42
#   SEED_CONCURRENCY=4            parallel requests of every seeder and of the ceiling runs
#   UPSTREAM_PROCS=4              mapserv FastCGI processes
#   CEILING_DURATION=10s          each MapServer-alone run (after a 2 s warm-up)
#   SEED_ROUNDS=3                 seeding rounds (order reversed every other round; medians)
#   LOAD_CONNECTIONS=1000 LOAD_DURATION=10s   the memory-under-load runs (LOAD_CONNECTIONS=0 skips)
#   MAPPROXY_VERSION=7.0.0 GUNICORN_VERSION=27.0.1 MAPPROXY_WORKERS=4 MAPPROXY_THREADS=4
#   MAPCACHE_PROCS=4 MAPCACHE_THREADS=25   Apache (mpm_event) processes and threads per process
#   RASTER=data/bmng_2048x1024.jpg  the upstream's imagery (georeferenced: world file or GeoTIFF)
#   INSTALL=1                     install missing Debian packages (apt-get) and the venv (pip);
#                                 0: stop and print the commands instead
#   LOAD_WAIT_S=0 MAX_LOAD=0.8    before the seeding (the first measurement), wait up to
#                                 LOAD_WAIT_S s for a 1-minute load below MAX_LOAD
#   OUT_DIR=build/bench           peers-runs.tsv, peers-summary.txt
#   ONLY=                         seed: step 1 alone (the seeders and the ceilings), then the summary;
#                                 burst: burst.sh alone (BURST=300 BURST_LEVEL=6 MC_LOCK_RETRY=0.1
#                                 WARM_MISSES=8 WARM_SERVERS="tellus MapProxy");
#                                 mercator: tellus and MapProxy seeded once, then mercator.sh (its
#                                 settings: MERC_ZOOMS=3-7 MERC_CONNECTIONS=16)
#   KEEP=0                        1: keep the work folder (configs, logs, caches, URL lists,
#                                 PostgreSQL's log as postgres.log)
#   UPSTREAM_CPUS=                CPU list (taskset -c, e.g. 0): the upstream (Apache and its mapserv
#                                 processes) runs on these CPUs, and the seeders and the ceiling's
#                                 wrk on the others: the upstream's own limit without the seeder's
#                                 work taking CPU from it (on 2 CPUs both share them otherwise)
#
# Needs cgi-mapserver mapserver-bin gdal-bin wrk (in tools/debian-packages.txt), curl python3
# iproute2 (base system) and, installed on the first run because CI does not need them,
# apache2-bin libapache2-mod-mapcache libapache2-mod-fcgid mapcache-tools python3-venv (apt-get)
# and MapProxy and gunicorn (pip, in the venv). Nothing touches the system's Apache: each Apache
# runs from its own config in the work folder and is stopped on exit, with everything else
# started here.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"

TELLUS="${TELLUS:-$repo/build/tools/tellus/tellus}"
PEERS_DIR="${PEERS_DIR:-$repo/build/peers-bench}"
DURATION="${DURATION:-10s}"
CONNECTIONS="${CONNECTIONS:-64}"
ARB_CONNECTIONS="${ARB_CONNECTIONS:-16}"
WRK_THREADS="${WRK_THREADS:-2}"
ROUNDS="${ROUNDS:-3}"
WARMUP="${WARMUP:-2s}"
REGION="${REGION:--36,-18,72,54}"
LEVELS="${LEVELS:-0-4}"
URL_COUNT="${URL_COUNT:-10000}"
ARB_COUNT="${ARB_COUNT:-2000}"
SEED="${SEED:-42}"
SEED_CONCURRENCY="${SEED_CONCURRENCY:-4}"
UPSTREAM_PROCS="${UPSTREAM_PROCS:-4}"
CEILING_DURATION="${CEILING_DURATION:-10s}"
SEED_ROUNDS="${SEED_ROUNDS:-3}"
LOAD_CONNECTIONS="${LOAD_CONNECTIONS:-1000}"
LOAD_DURATION="${LOAD_DURATION:-10s}"
MAPPROXY_VERSION="${MAPPROXY_VERSION:-7.0.0}"
GUNICORN_VERSION="${GUNICORN_VERSION:-27.0.1}"
MAPPROXY_WORKERS="${MAPPROXY_WORKERS:-4}"
MAPPROXY_THREADS="${MAPPROXY_THREADS:-4}"
MAPCACHE_PROCS="${MAPCACHE_PROCS:-4}"
MAPCACHE_THREADS="${MAPCACHE_THREADS:-25}"
RASTER="${RASTER:-$repo/data/bmng_2048x1024.jpg}"
INSTALL="${INSTALL:-1}"
LOAD_WAIT_S="${LOAD_WAIT_S:-0}"
MAX_LOAD="${MAX_LOAD:-0.8}"
OUT_DIR="${OUT_DIR:-$repo/build/bench}"
KEEP="${KEEP:-0}"
ONLY="${ONLY:-}"
UPSTREAM_CPUS="${UPSTREAM_CPUS:-}"
up_pin=() seed_pin=()
if [[ -n "$UPSTREAM_CPUS" ]]; then
  [[ "$UPSTREAM_CPUS" =~ ^[0-9]+(,[0-9]+)*$ ]] || { echo "run.sh: UPSTREAM_CPUS=$UPSTREAM_CPUS: a list like 0 or 0,1" >&2; exit 1; }
  other_cpus="$(python3 -c 'import os, sys; up = {int(c) for c in sys.argv[1].split(",")}; print(",".join(str(c) for c in sorted(os.sched_getaffinity(0) - up)))' "$UPSTREAM_CPUS")"
  [[ -n "$other_cpus" ]] || { echo "run.sh: UPSTREAM_CPUS=$UPSTREAM_CPUS leaves no CPU for the seeders" >&2; exit 1; }
  up_pin=(taskset -c "$UPSTREAM_CPUS") seed_pin=(taskset -c "$other_cpus")
fi
[[ -z "$ONLY" || "$ONLY" == seed || "$ONLY" == mercator || "$ONLY" == burst ]] ||
  { echo "run.sh: ONLY=$ONLY: ONLY=seed, ONLY=mercator or ONLY=burst" >&2; exit 1; }
# ONLY=mercator: the lat/long caches seeded once (tellus and MapProxy), then mercator.sh
[[ "$ONLY" != mercator ]] || SEED_ROUNDS=1

say() { echo "== $*"; }
warn() { echo "run.sh: warning: $*" >&2; }
die() {
  echo "run.sh: $*" >&2
  exit 1
}
load1() { cut -d' ' -f1 /proc/loadavg; }

# ------------------------------------------------------------------------------ prerequisites
[[ -x "$TELLUS" ]] || die "$TELLUS not found; build it first (cmake --preset release && cmake --build build -j2)"
[[ -f "$RASTER" ]] || die "RASTER=$RASTER not found"
sudo=()
[[ $EUID -ne 0 ]] && sudo=(sudo)
missing=()
for p in cgi-mapserver mapserver-bin gdal-bin wrk curl python3 iproute2 apache2-bin libapache2-mod-mapcache \
  libapache2-mod-fcgid mapcache-tools $([[ "$ONLY" != burst ]] || echo memcached python3-mapproxy gunicorn postgresql-15); do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done
# python3-venv: ensurepip is what it adds
if ! python3 -c 'import ensurepip' 2>/dev/null; then missing+=(python3-venv); fi
if [[ ${#missing[@]} -gt 0 ]]; then
  install_cmd="${sudo[*]} apt-get install -y --no-install-recommends ${missing[*]}"
  [[ "$INSTALL" == 1 ]] || die "missing Debian packages; install them with: $install_cmd"
  # apache2-bin only, never the apache2 package: that one would start the system's Apache on *:80.
  say "installing the benchmark's own Debian packages (not part of CI): ${missing[*]}"
  DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

venv="$PEERS_DIR/venv"
want_pip=("MapProxy==$MAPPROXY_VERSION" "gunicorn==$GUNICORN_VERSION")
# ONLY=burst runs Debian's MapProxy (python3-mapproxy) under Debian's gunicorn: no venv
if [[ "$ONLY" != burst ]] && ! "$venv/bin/python" - "$MAPPROXY_VERSION" "$GUNICORN_VERSION" 2>/dev/null <<'EOF'; then
import sys
from importlib.metadata import version
sys.exit(0 if (version("MapProxy"), version("gunicorn")) == tuple(sys.argv[1:3]) else 1)
EOF
  [[ "$INSTALL" == 1 ]] ||
    die "no venv with ${want_pip[*]} in $venv; make it with: python3 -m venv $venv && $venv/bin/pip install ${want_pip[*]}"
  say "installing ${want_pip[*]} from PyPI into $venv (once; about a minute)"
  mkdir -p "$PEERS_DIR"
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q --disable-pip-version-check "${want_pip[@]}"
fi

# wrk's 1,000 connections plus the servers' sockets
if [[ "$(ulimit -n)" != unlimited && "$(ulimit -n)" -lt 8192 ]]; then
  ulimit -n 8192 2>/dev/null || ulimit -n "$(ulimit -Hn)" 2>/dev/null || true
  [[ "$(ulimit -n)" == unlimited || "$(ulimit -n)" -ge $((LOAD_CONNECTIONS + 256)) ]] ||
    warn "open-file limit $(ulimit -n): the $LOAD_CONNECTIONS-connection runs may fail"
fi

# ------------------------------------------------------------------------------ work folder, clean-up
mkdir -p "$PEERS_DIR"
work="$(mktemp -d "$PEERS_DIR/run.XXXXXX")"
chmod 755 "$work"
# Apache's children and the mapserv processes run as www-data when we are root: they must reach
# the work folder.
run_as=()
user_lines=""
if [[ $EUID -eq 0 ]]; then
  run_as=(setpriv --reuid=www-data --regid=www-data --clear-groups)
  user_lines=$'User www-data\nGroup www-data'
  "${run_as[@]}" test -x "$work" ||
    die "www-data cannot enter $work (a parent folder is not world-searchable); set PEERS_DIR to a folder it can reach, e.g. PEERS_DIR=/tmp/peers-bench"
fi

pids=()
apache_confs=()
cleanup() {
  local p c
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  for c in "${apache_confs[@]}"; do apache2 -f "$c" -k stop 2>/dev/null || true; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
  # KEEP=1 keeps the database's log too (the folder goes with the server).
  if [[ "$KEEP" == 1 && -f "${pg_dir:-}/server.log" ]]; then cp "$pg_dir/server.log" "$work/postgres.log"; fi
  [[ -z "${pg_dir:-}" ]] || "$repo/tests/support/postgres.sh" stop "$pg_dir" || true
  [[ -z "${s3_dir:-}" ]] || "$repo/tests/support/s3-server.sh" stop "$s3_dir" || true
  # Apache stops its children (and mod_fcgid its mapserv processes) after the parent got TERM
  for c in "${apache_confs[@]}"; do
    for _ in $(seq 1 100); do
      [[ -f "$(dirname "$c")/httpd.pid" ]] || break
      sleep 0.1
    done
  done
  if [[ "$KEEP" == 1 ]]; then
    echo "== kept: $work"
  else
    rm -rf "$work"
  fi
}
trap cleanup EXIT
trap 'exit 130' INT TERM

port_free() { ! ss -Htan "( sport = :$1 )" | grep -q .; }
free_port() {
  local candidate
  for _ in $(seq 1 200); do
    candidate=$((20000 + RANDOM % 10001))
    if port_free "$candidate"; then
      echo "$candidate"
      return 0
    fi
  done
  die "no free port found in 20000-30000"
}
# fill in a template: fill SRC DST NAME=VALUE...
fill() {
  local src=$1 dst=$2 kv
  shift 2
  cp "$src" "$dst"
  for kv in "$@"; do
    K="@${kv%%=*}@" V="${kv#*=}" python3 - "$dst" <<'EOF'
import os, sys
p = sys.argv[1]
t = open(p).read().replace(os.environ["K"], os.environ["V"])
open(p, "w").write(t)
EOF
  done
}
start_apache() { # CONF PORT [COMMAND PREFIX...]: start a private Apache and wait until it answers
  local conf=$1 port=$2
  shift 2
  apache_confs+=("$conf")
  "$@" apache2 -f "$conf" -k start || die "apache2 -f $conf did not start: $(cat "$(dirname "$conf")/error.log" 2>/dev/null)"
  for _ in $(seq 1 100); do
    curl -s -o /dev/null "http://127.0.0.1:$port/" && return 0
    sleep 0.1
  done
  die "apache2 -f $conf does not answer on port $port: $(cat "$(dirname "$conf")/error.log")"
}
apache_pids() { # CONF: parent and children
  local parent
  parent="$(cat "$(dirname "$1")/httpd.pid" 2>/dev/null)" || return 0
  echo "$parent" $(pgrep -P "$parent" || true)
}
gunicorn_pids() { echo "$mapproxy_pid" $(pgrep -P "$mapproxy_pid" || true); }

say "tellus vs MapCache vs MapProxy: $(date -u '+%Y-%m-%d %H:%M:%S UTC'), $(nproc) CPU(s), load: $(cut -d' ' -f1-3 /proc/loadavg)"
mkdir -p "$work/bin"
cp "$TELLUS" "$work/bin/tellus"
# the imaging module (dlopen()ed on the first miss) next to the copy, where the loader looks first
imaging_module="$(dirname "$TELLUS")/../../imaging/libtellus_imaging.so"
[[ ! -f $imaging_module ]] || cp "$imaging_module" "$work/bin/"
tellus="$work/bin/tellus"
commit="$(git -C "$repo" rev-parse --short HEAD 2>/dev/null || echo '?')"
[[ -z "$(git -C "$repo" status --porcelain --untracked-files=no 2>/dev/null)" ]] || commit="$commit+changes"
mp_banner="MapProxy $MAPPROXY_VERSION, gunicorn $GUNICORN_VERSION"
[[ "$ONLY" != burst ]] || mp_banner="MapProxy and gunicorn: Debian's (the burst line)"
say "tellus $TELLUS ($(stat -c '%y' "$TELLUS" | cut -d. -f1), tree $commit); $(apache2 -v | head -1 | sed 's/Server version: //');" \
  "mod_mapcache $(dpkg-query -W -f='${Version}' libapache2-mod-mapcache); $mp_banner;" \
  "MapServer $(/usr/lib/cgi-bin/mapserv -v | sed -E 's/MapServer version ([^ ]*).*/\1/'); $(wrk -v 2>&1 | head -1 | cut -d' ' -f1-2)"
IFS=, read -r RW RS RE RN <<<"$REGION"
LEVEL_LO="${LEVELS%-*}"
LEVEL_HI="${LEVELS#*-}"

# ------------------------------------------------------------------------------ URL lists
# One list of random tiles of the seeded set, written once per URL style; random boxes inside the
# region; every tile of the region (the ceiling: one GetMap per tile) and every 4x4 metatile of its
# finest level (the ceiling with metatiles).
python3 - "$work" "$REGION" "$LEVELS" "$URL_COUNT" "$ARB_COUNT" "$SEED" <<'EOF'
import os, random, sys
work, region, levels, count, arb_count, seed = sys.argv[1:7]
W, S, E, N = (float(v) for v in region.split(","))
lo, _, hi = levels.partition("-")
lo, hi = int(lo), int(hi or lo)
D0 = 36.0
for v, o in ((W, -180), (E, -180), (S, -90), (N, -90)):
    if abs((v - o) / D0 - round((v - o) / D0)) > 1e-9:
        sys.exit(f"run.sh: REGION={region} is not aligned to the 36-degree level-zero tiles "
                 "(the seeders would not agree on its tiles)")
if not (-180 <= W < E <= 180 and -90 <= S < N <= 90):
    sys.exit(f"run.sh: REGION={region} is not W,S,E,N inside the globe")
def tiles(level):
    d = D0 / 2**level
    c0, c1 = round((W + 180) / d), round((E + 180) / d)
    r0, r1 = round((S + 90) / d), round((N + 90) / d)
    return d, c0, c1, r0, r1
g = lambda v: f"{v:.10g}"
rng = random.Random(int(seed))
keys = []
for _ in range(int(count)):
    L = rng.randint(lo, hi)
    d, c0, c1, r0, r1 = tiles(L)
    keys.append((L, rng.randrange(r0, r1), rng.randrange(c0, c1), d))
def bbox(L, r, c, d):
    w, s = -180 + c * d, -90 + r * d
    return ",".join(map(g, (w, s, w + d, s + d)))
wms = "SERVICE=WMS&VERSION=1.1.1&REQUEST=GetMap&LAYERS=world&STYLES=&SRS=EPSG:4326&BBOX={}&WIDTH=512&HEIGHT=512&FORMAT=image/jpeg"
series = {
    "tw": lambda L, r, c, d: f"/wwtile?T=world&L={L}&X={c}&Y={r}",
    "ts": lambda L, r, c, d: f"/tiles/world/{L}/{r}/{r}_{c}.jpg",
    "tm": lambda L, r, c, d: "/wms?" + wms.format(bbox(L, r, c, d)),
    "ct": lambda L, r, c, d: f"/mapcache/tms/1.0.0/world@ww4326/{L}/{c}/{r}.jpg",
    "cm": lambda L, r, c, d: "/mapcache?" + wms.format(bbox(L, r, c, d)),
    # MapProxy's /tms/ skips the first level of a global EPSG:4326 grid (the TMS global-geodetic
    # profile): its z is our level - 1. /tiles/ uses the grid's own levels.
    "pt": lambda L, r, c, d: f"/tiles/world/ww4326/{L}/{c}/{r}.jpeg",
    "pm": lambda L, r, c, d: "/service?" + wms.format(bbox(L, r, c, d)),
}
for name, fmt in series.items():
    with open(os.path.join(work, f"urls-{name}.txt"), "w") as f:
        f.writelines(fmt(*k) + "\n" for k in keys)
# arbitrary boxes, as shared/peers/wms_arbitrary.lua draws them but inside the region
rng = random.Random(int(seed) + 1)
max_span = min(80.0, E - W, (N - S) / 0.75)
# 1024 px over 10-80 degrees: 0.0098-0.078 degrees per pixel, which the peers compose from levels
# 0 (0.0703) to 3 (0.0088); a level that is not seeded would be fetched from upstream
if lo != 0 or hi < 3:
    sys.exit(f"run.sh: LEVELS={levels}: the arbitrary boxes need levels 0-3 seeded (LEVELS=0-3 or more)")
boxes = []
for _ in range(int(arb_count)):
    span = rng.uniform(min(10.0, max_span), max_span)
    hs = span * 0.75
    w = rng.uniform(W, E - span)
    s = rng.uniform(S, N - hs)
    boxes.append(f"BBOX={s:.6f},{w:.6f},{s + hs:.6f},{w + span:.6f}")
arb = "SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=world&STYLES=&CRS=EPSG:4326&{}&WIDTH=1024&HEIGHT=768&FORMAT=image/jpeg"
for name, path in (("ta", "/wms?"), ("ca", "/mapcache?"), ("pa", "/service?")):
    with open(os.path.join(work, f"urls-{name}.txt"), "w") as f:
        f.writelines(path + arb.format(b) + "\n" for b in boxes)
# the ceiling: every tile of the region once, and the finest level's 4x4 metatiles
region_tiles = 0
with open(os.path.join(work, "urls-up512.txt"), "w") as f:
    for L in range(lo, hi + 1):
        d, c0, c1, r0, r1 = tiles(L)
        region_tiles += (c1 - c0) * (r1 - r0)
        for r in range(r0, r1):
            for c in range(c0, c1):
                f.write("/mapserv?" + wms.format(bbox(L, r, c, d)) + "\n")
d, c0, c1, r0, r1 = tiles(hi)
meta = 0
with open(os.path.join(work, "urls-up2048.txt"), "w") as f:
    for r in range(r0 - r0 % 4, r1, 4):
        for c in range(c0 - c0 % 4, c1, 4):
            w, s = -180 + c * d, -90 + r * d
            b = ",".join(map(g, (w, s, min(180, w + 4 * d), min(90, s + 4 * d))))
            if w + 4 * d > 180 or s + 4 * d > 90:
                continue
            f.write("/mapserv?" + wms.format(b).replace("WIDTH=512&HEIGHT=512", "WIDTH=2048&HEIGHT=2048") + "\n")
            meta += 1
open(os.path.join(work, "region_tiles"), "w").write(f"{region_tiles}\n")
print(f"== region {region}, levels {lo}-{hi}: {region_tiles} tiles; {count} random tile keys "
      f"({len({k[:3] for k in keys})} distinct) and {arb_count} boxes {min(10.0, max_span):.0f}-{max_span:.0f} "
      f"degrees wide (seed {seed}); {meta} metatiles of level {hi} for the ceiling")
EOF
region_tiles="$(cat "$work/region_tiles")"

# ------------------------------------------------------------------------------ upstream
say "upstream: MapServer (mapserv as FastCGI, $UPSTREAM_PROCS processes) on $(basename "$RASTER")"
mkdir -p "$work/upstream/apache/fcgid"
gdal_translate -q -of GTiff -co TILED=YES -a_srs EPSG:4326 "$RASTER" "$work/upstream/world.tif" ||
  die "gdal_translate could not read $RASTER (georeferenced? a world file next to it?)"
gdaladdo -q -r average "$work/upstream/world.tif" 2 4 8
up_port="$(free_port)"
upstream_url="http://127.0.0.1:$up_port/mapserv?"
fill "$here/world.map" "$work/upstream/world.map" "WORK=$work" "UPSTREAM_URL=$upstream_url"
fill "$here/mapserver.conf" "$work/upstream/mapserver.conf" "WORK=$work"
fill "$here/httpd-upstream.conf" "$work/upstream/apache/httpd.conf" "WORK=$work" "PORT=$up_port" \
  "PROCS=$UPSTREAM_PROCS" "USER_LINES=$user_lines"
[[ $EUID -ne 0 ]] || chown -R www-data:www-data "$work/upstream/apache/fcgid"
start_apache "$work/upstream/apache/httpd.conf" "$up_port" "${up_pin[@]}"
[[ -z "$UPSTREAM_CPUS" ]] || say "upstream pinned to CPU(s) $UPSTREAM_CPUS; the seeders and the ceiling's wrk to $other_cpus"
up_log="$work/upstream/apache/access.log"
upstream_requests() { if [[ -f "$up_log" ]]; then wc -l <"$up_log"; else echo 0; fi; }
# answers other than 200 the upstream gave (mod_fcgid's 503 when no mapserv process is free, ...)
upstream_failures() { if [[ -f "$up_log" ]]; then awk '$1 != 200' "$up_log" | wc -l; else echo 0; fi; }
check_image() { # NAME URL: 200, image/*, a body; prints the Content-Type
  local out
  out="$(curl -s -o "$work/check.bin" -w '%{http_code} %{content_type} %{size_download}' "$2")" ||
    die "$1: $2 failed"
  read -r code ctype size <<<"$out"
  if [[ "$code" != 200 || "$ctype" != image/* || "$size" -eq 0 ]]; then
    echo "$1: $2 answered $out: $(head -c 300 "$work/check.bin" | tr -d '\0')" >&2
    return 1
  fi
}
check_image upstream "http://127.0.0.1:$up_port$(head -n 1 "$work/urls-up512.txt")" || die "the upstream does not answer images"
if [[ "$ONLY" == burst ]]; then
  # shellcheck source=burst.sh
  source "$here/burst.sh"
  exit 0
fi

# ------------------------------------------------------------------------------ the three caches' configurations
mkdir -p "$work/tellus" "$work/mapproxy/cache" "$work/mapcache/apache" "$work/mapcache/cache" "$work/mapcache/locks"
fill "$here/tellus.yaml" "$work/tellus/tellus.yaml" "UPSTREAM_URL=$upstream_url" "SEED_CONCURRENCY=$SEED_CONCURRENCY"
fill "$here/mapproxy.yaml" "$work/mapproxy/mapproxy.yaml" "WORK=$work" "UPSTREAM_URL=$upstream_url"
fill "$here/mapproxy-seed.yaml" "$work/mapproxy/seed.yaml" "BBOX=$RW, $RS, $RE, $RN" "FROM_LEVEL=$LEVEL_LO" "TO_LEVEL=$LEVEL_HI"
mc_port="$(free_port)"
fill "$here/mapcache.xml" "$work/mapcache/mapcache.xml" "WORK=$work" "UPSTREAM_URL=$upstream_url"
fill "$here/httpd-mapcache.conf" "$work/mapcache/apache/httpd.conf" "WORK=$work" "PORT=$mc_port" "USER_LINES=$user_lines" \
  "PROCS=$MAPCACHE_PROCS" "THREADS=$MAPCACHE_THREADS" "MAX_WORKERS=$((MAPCACHE_PROCS * MAPCACHE_THREADS))"
[[ $EUID -ne 0 ]] || chown -R www-data:www-data "$work/mapcache/cache" "$work/mapcache/locks"
(cd "$work/mapproxy" && "$venv/bin/mapproxy-util" create -t wsgi-app -f mapproxy.yaml app.py >/dev/null)

# ------------------------------------------------------------------------------ 1. seeding
# Wait for the machine to calm down before the measurements start (the load after that is ours).
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
time_bin="$(command -v time 2>/dev/null | grep / || true)"
[[ -z "$time_bin" && -x /usr/bin/time ]] && time_bin=/usr/bin/time
seeds="$work/seed.tsv"
: >"$seeds"
now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.3f", b - a }'; }
# name round seconds tiles upstream_requests errors
seed_row() { echo -e "$1\t$2\t$3\t$4\t$5\t${6:-0}" >>"$seeds"; }
ceiling() { # NAME ROUND LIST TILES_PER_REQUEST: wrk on MapServer alone
  local name=$1 round=$2 list=$3 per=$4 res="$work/ceiling-$1-$2.txt" r0 r1
  if [[ $round == 1 ]]; then # start the mapserv processes and fill the page cache first
    URLS="$list" SEED="$SEED" "${seed_pin[@]}" wrk -t"$WRK_THREADS" -c"$SEED_CONCURRENCY" -d2s --timeout 60s -s "$repo/bench/proxy/urls.lua" \
      "http://127.0.0.1:$up_port" >"$work/ceiling-$name-warm.log" 2>&1 || die "wrk failed: $(cat "$work/ceiling-$name-warm.log")"
  fi
  r0=$(upstream_requests)
  URLS="$list" SEED="$SEED" RESULT="$res" "${seed_pin[@]}" wrk -t"$WRK_THREADS" -c"$SEED_CONCURRENCY" -d"$CEILING_DURATION" --timeout 60s \
    -s "$repo/bench/proxy/urls.lua" "http://127.0.0.1:$up_port" >"$work/ceiling-$name-$round.log" 2>&1 ||
    die "wrk failed: $(cat "$work/ceiling-$name-$round.log")"
  r1=$(upstream_requests)
  python3 - "$res" "$per" "$name" "$round" "$((r1 - r0))" >>"$seeds" <<'EOF2'
import sys
res, per, name, rnd, reqs = sys.argv[1:6]
kv = dict(x.split("=") for x in open(res).read().split()[1:])
errors = sum(int(kv[k]) for k in ("connect", "read", "write", "status", "timeout"))
print(f"{name}\t{rnd}\t{int(kv['duration_us']) / 1e6:.3f}\t{int(kv['requests']) * int(per)}\t{reqs}\t{errors}")
EOF2
}
seeder() { # NAME ROUND: one seeder into an empty cache, timed
  local name=$1 round=$2 r0 t0 t1 tiles log="$work/seed-$1-$2.log"
  case $name in
    tellus | tellus1) rm -rf "$work/tellus/cache" ;;
    MapProxy) rm -rf "$work/mapproxy/cache" && mkdir -p "$work/mapproxy/cache" ;;
    MapCache) find "$work/mapcache/cache" "$work/mapcache/locks" -mindepth 1 -delete ;;
  esac
  sync
  r0=$(upstream_requests)
  f0=$(upstream_failures)
  t0=$(now)
  case $name in
    tellus | tellus1)
      meta=()
      [[ $name == tellus1 ]] && meta=(--meta-tiles 1)
      timer=()
      [[ -n "$time_bin" ]] && timer=("$time_bin" -f '%U %S' -o "$work/seed-$name-$round.cpu")
      "${seed_pin[@]}" "${timer[@]}" "$tellus" seed --config "$work/tellus/tellus.yaml" --cache "$work/tellus/cache" --layer world \
        --levels "$LEVELS" --bbox "$REGION" --concurrency "$SEED_CONCURRENCY" "${meta[@]}" >"$log" 2>&1 ||
        die "tellus seed failed: $(tail -5 "$log")"
      ;;
    MapProxy)
      (cd "$work/mapproxy" && "${seed_pin[@]}" "$venv/bin/mapproxy-seed" -f mapproxy.yaml -s seed.yaml --seed ALL -c "$SEED_CONCURRENCY") \
        >"$log" 2>&1 || die "mapproxy-seed failed: $(tail -5 "$log")"
      ;;
    MapCache)
      "${seed_pin[@]}" "${run_as[@]}" mapcache_seed -c "$work/mapcache/mapcache.xml" -t world -g ww4326 -z "${LEVEL_LO},${LEVEL_HI}" \
        -e "$REGION" -n "$SEED_CONCURRENCY" >"$log" 2>&1 || die "mapcache_seed failed: $(tail -c 600 "$log")"
      ;;
  esac
  t1=$(now)
  case $name in
    tellus | tellus1) tiles="$(grep -o '[0-9]* written' "$log" | tail -1 | cut -d' ' -f1)" ;;
    MapProxy) tiles="$(find "$work/mapproxy/cache" -name '*.jpeg' | wc -l)" ;;
    MapCache) tiles="$(find "$work/mapcache/cache" -name '*.jpg' | wc -l)" ;;
  esac
  seed_row "$name" "$round" "$(elapsed "$t0" "$t1")" "${tiles:-0}" "$(($(upstream_requests) - r0))" \
    "$(($(upstream_failures) - f0))"
}
seed_order="up512 up2048 tellus1 tellus MapProxy MapCache"
[[ "$ONLY" != mercator ]] || seed_order="tellus MapProxy"
for round in $(seq 1 "$SEED_ROUNDS"); do
  order="$seed_order"
  ((round % 2)) || order="$(echo "$seed_order" | tr ' ' '\n' | tac | tr '\n' ' ' | sed 's/ $//')"
  say "seeding round $round/$SEED_ROUNDS: $order (every seeder into an empty cache, $SEED_CONCURRENCY parallel requests)"
  for s in $order; do
    case $s in
      up512) ceiling up512 "$round" "$work/urls-up512.txt" 1 ;;
      up2048) ceiling up2048 "$round" "$work/urls-up2048.txt" 16 ;;
      *) seeder "$s" "$round" ;;
    esac
    cpu=""
    [[ -s "$work/seed-$s-$round.cpu" ]] && cpu=", CPU $(awk '{ printf "%.2f s user+sys", $1 + $2 }' "$work/seed-$s-$round.cpu")"
    echo "   $(tail -n 1 "$seeds" | awk -F'\t' '{ printf "%s: %s s, %s tiles, %s upstream requests, %s failed", $1, $3, $4, $5, $6 }')$cpu"
  done
done
grep -E 'levels .* planned' "$work/seed-tellus-$SEED_ROUNDS.log" | sed 's/^/   tellus: /'
[[ ! -f "$work/seed-MapCache-$SEED_ROUNDS.log" ]] ||
  tail -c 300 "$work/seed-MapCache-$SEED_ROUNDS.log" | tr '\r' '\n' | grep seeded | tail -1 | sed 's/^ */   mapcache_seed: /'

tellus_arbitrary=1 up_during_load=0 arb_answer="" all_series=""
runs="$work/runs.tsv"
mem="$work/mem.tsv"
: >"$runs"
: >"$mem"
if [[ "$ONLY" != seed ]]; then
# ------------------------------------------------------------------------------ 2. servers
"$tellus" serve --config "$work/tellus/tellus.yaml" --cache "$work/tellus/cache" --listen 127.0.0.1:0 \
  >"$work/tellus/serve.log" 2>&1 &
tellus_pid=$!
pids+=("$tellus_pid")
(cd "$work/mapproxy" && exec "$venv/bin/gunicorn" -b 127.0.0.1:0 -w "$MAPPROXY_WORKERS" -k gthread \
  --threads "$MAPPROXY_THREADS" --no-control-socket app:application) >"$work/mapproxy/gunicorn.log" 2>&1 &
mapproxy_pid=$!
pids+=("$mapproxy_pid")
[[ "$ONLY" == mercator ]] || start_apache "$work/mapcache/apache/httpd.conf" "$mc_port"
tellus_port="" mp_port=""
for _ in $(seq 1 200); do
  [[ -n "$tellus_port" ]] || tellus_port="$(grep -o 'listening on http://127.0.0.1:[0-9]*' "$work/tellus/serve.log" | sed 's/.*://' || true)"
  [[ -n "$mp_port" ]] || mp_port="$(grep -o 'Listening at: http://127.0.0.1:[0-9]*' "$work/mapproxy/gunicorn.log" | sed 's/.*://' || true)"
  [[ -n "$tellus_port" && -n "$mp_port" ]] && break
  sleep 0.1
done
[[ -n "$tellus_port" ]] || die "tellus serve did not start: $(cat "$work/tellus/serve.log")"
[[ -n "$mp_port" ]] || die "gunicorn did not start: $(cat "$work/mapproxy/gunicorn.log")"
# gunicorn says it listens before its workers have imported MapProxy
for _ in $(seq 1 100); do
  [[ "$(pgrep -P "$mapproxy_pid" | wc -l)" -ge "$MAPPROXY_WORKERS" ]] && curl -sf -o /dev/null "http://127.0.0.1:$mp_port/tms/1.0.0/" && break
  sleep 0.2
done
say "tellus on 127.0.0.1:$tellus_port, MapCache on 127.0.0.1:$mc_port, MapProxy on 127.0.0.1:$mp_port, upstream on 127.0.0.1:$up_port"
if [[ "$ONLY" == mercator ]]; then
  # shellcheck source=mercator.sh
  source "$here/mercator.sh"
  exit 0
fi

declare -A label=(
  [tw]="tellus World Wind /wwtile"
  [ts]="tellus static /tiles/"
  [tm]="tellus WMS 1.1.1 tile"
  [ct]="MapCache TMS"
  [cm]="MapCache WMS 1.1.1 tile"
  [pt]="MapProxy /tiles/ (TMS-like)"
  [pm]="MapProxy WMS 1.1.1 tile"
  [ta]="tellus arbitrary 1024x768"
  [ca]="MapCache arbitrary 1024x768"
  [pa]="MapProxy arbitrary 1024x768"
)
port_of() {
  case $1 in
    t?) echo "$tellus_port" ;;
    c?) echo "$mc_port" ;;
    p?) echo "$mp_port" ;;
  esac
}
pids_of() {
  case $1 in
    t?) echo "$tellus_pid" ;;
    c?) apache_pids "$work/mapcache/apache/httpd.conf" ;;
    p?) gunicorn_pids ;;
  esac
}

# tellus's arbitrary boxes: one sample first
tellus_arbitrary=1
arb_sample="http://127.0.0.1:$tellus_port$(head -n 1 "$work/urls-ta.txt")"
arb_answer="$(curl -s -o "$work/arb.bin" -w '%{http_code} %{content_type}' "$arb_sample")"
if [[ "$arb_answer" != "200 image/"* ]]; then
  tellus_arbitrary=0
  say "tellus answers an arbitrary box with $arb_answer, not an image: row 'tellus: not supported'" \
    "($(tr -d '\n' <"$work/arb.bin" | grep -o '<ServiceException[^<]*' | sed 's/<ServiceException[^>]*>//' | head -c 120))"
fi
# per round the servers alternate within each kind of request (tellus, MapCache, MapProxy, ...)
series="tw ct pt ts tm cm pm"
arb_series="ca pa"
[[ $tellus_arbitrary == 0 ]] || arb_series="ta ca pa"
for s in $series $arb_series; do
  r0=$(upstream_requests)
  while read -r url; do
    check_image "$s" "http://127.0.0.1:$(port_of "$s")$url" || die "series $s (${label[$s]}) does not answer an image"
  done < <(head -n 20 "$work/urls-$s.txt")
  # every URL is inside the seeded set: a request upstream means a URL style that does not address
  # the seeded tiles (another level numbering or row order)
  r1=$(upstream_requests)
  [[ $r1 -eq $r0 ]] || die "series $s (${label[$s]}): $((r1 - r0)) upstream requests for 20 URLs that should all be cached"
done
say "checked: the first 20 URLs of every series answer 200, image/*, a body, without an upstream request"

# ------------------------------------------------------------------------------ 3. memory, idle
mem_sum() { # FIELD PIDS...: VmRSS from status, Pss from smaps_rollup, in KiB
  local f=$1 p t=0 v
  shift
  for p in "$@"; do
    if [[ $f == Pss ]]; then
      v="$(awk '$1 == "Pss:" { print $2 }' "/proc/$p/smaps_rollup" 2>/dev/null || true)"
    else
      v="$(awk -v f="$f:" '$1 == f { print $2 }' "/proc/$p/status" 2>/dev/null || true)"
    fi
    t=$((t + ${v:-0}))
  done
  echo "$t"
}
mem="$work/mem.tsv"
: >"$mem"
mem_row() { # WHEN SERVER SERIES
  local p
  p="$(pids_of "$3")"
  # shellcheck disable=SC2086
  echo -e "$1\t$2\t$(mem_sum VmRSS $p)\t$(mem_sum Pss $p)\t$(echo $p | wc -w)" >>"$mem"
}
sleep 1
for x in "tellus tw" "MapCache ct" "MapProxy pt"; do mem_row idle $x; done

# ------------------------------------------------------------------------------ 4. load runs
cpu_ticks() { # PIDS...: utime + stime, clock ticks, all threads
  local t=0 p
  for p in "$@"; do
    [[ -r /proc/$p/stat ]] || continue
    t=$((t + $(awk '{ sub(/.*\) /, ""); print $12 + $13 }' "/proc/$p/stat")))
  done
  echo "$t"
}
machine_ticks() { awk '$1 == "cpu" { print $2 + $3 + $4 + $7 + $8, $9 }' /proc/stat; }
one_run() { # SERIES ROUND DURATION CONNECTIONS -> a line of runs.tsv
  local s=$1 round=$2 dur=$3 conns=$4 t0 t1 m0 m1 load wrk_cpu=0
  local log="$work/wrk-$s-$round.log" res="$work/res-$s-$round.txt" tf="$work/time-$s-$round.txt"
  local timer=()
  [[ -n "$time_bin" ]] && timer=("$time_bin" -f '%U %S' -o "$tf")
  # shellcheck disable=SC2046
  t0=$(cpu_ticks $(pids_of "$s"))
  m0="$(machine_ticks)"
  load="$(load1)"
  URLS="$work/urls-$s.txt" SEED="$SEED" RESULT="$res" \
    "${timer[@]}" wrk -t"$WRK_THREADS" -c"$conns" -d"$dur" --timeout 30s --latency -s "$repo/bench/proxy/urls.lua" \
    "http://127.0.0.1:$(port_of "$s")" >"$log" 2>&1 || { servers_alive; die "wrk failed: $(cat "$log")"; }
  # shellcheck disable=SC2046
  t1=$(cpu_ticks $(pids_of "$s"))
  m1="$(machine_ticks)"
  [[ -s "$res" ]] || die "wrk wrote no result: $(cat "$log")"
  [[ -s "$tf" ]] && wrk_cpu="$(awk '{ print $1 + $2 }' "$tf")"
  echo -e "$s\t$round\t$load\t$((t1 - t0))\t$wrk_cpu\t$((${m1% *} - ${m0% *}))\t$((${m1#* } - ${m0#* }))\t$conns\t$(sed 's/^RESULT //' "$res")"
}
servers_alive() { # dies with the exit status and the log of a server that is gone
  local rc
  if ! kill -0 "$tellus_pid" 2>/dev/null; then
    rc=0
    wait "$tellus_pid" || rc=$?
    die "tellus serve exited with status $rc: $(tail -n 20 "$work/tellus/serve.log")"
  fi
  if ! kill -0 "$mapproxy_pid" 2>/dev/null; then
    die "gunicorn (MapProxy) exited: $(tail -n 20 "$work/mapproxy/gunicorn.log")"
  fi
  [[ -n "$(apache_pids "$work/mapcache/apache/httpd.conf")" ]] ||
    die "the MapCache Apache exited: $(tail -n 20 "$work/mapcache/apache/error.log")"
}
conns_of() { case $1 in ?a) echo "$ARB_CONNECTIONS" ;; *) echo "$CONNECTIONS" ;; esac; }


all_series="$series $arb_series"
servers_alive
up_before_load=$(upstream_requests)
say "load before the runs: $(cut -d' ' -f1-3 /proc/loadavg)"
runs="$work/runs.tsv"
: >"$runs"
rounds() { # WHAT SERIES...: a warm-up of each series, then ROUNDS rounds, the order reversed every other
  local what=$1 round order s line
  shift
  if [[ "$WARMUP" != 0 ]]; then
    say "$what: warm-up, $WARMUP per series"
    for s in "$@"; do one_run "$s" 0 "$WARMUP" "$(conns_of "$s")" >/dev/null; done
  fi
  for round in $(seq 1 "$ROUNDS"); do
    if ((round % 2)); then order="$*"; else order="$(printf '%s\n' "$@" | tac | tr '\n' ' ' | sed 's/ $//')"; fi
    say "$what, round $round/$ROUNDS: $order (wrk -t$WRK_THREADS -c$(conns_of "$1") -d$DURATION)"
    for s in $order; do
      line="$(one_run "$s" "$round" "$DURATION" "$(conns_of "$s")")"
      echo "$line" >>"$runs"
      echo "   $s ${label[$s]}: $(echo "$line" | cut -f9- | tr '\t' ' ' | grep -oE '(req_s|p99_us|status|timeout|connect|read)=[0-9.]+' | tr '\n' ' ')"
    done
  done
}
# The cached tiles first, then the arbitrary boxes: composing them grows the peers' memory, which
# stays (the rows "after the cached-tile runs" and "after the arbitrary-box runs").
# shellcheck disable=SC2086
rounds "cached tiles" $series
for x in "tellus tw" "MapCache ct" "MapProxy pt"; do mem_row "after the cached-tile runs" $x; done
# shellcheck disable=SC2086
rounds "arbitrary boxes" $arb_series
for x in "tellus tw" "MapCache ct" "MapProxy pt"; do mem_row "after the arbitrary-box runs" $x; done
up_during_load=$(($(upstream_requests) - up_before_load))

# ------------------------------------------------------------------------------ 5. memory under load
if [[ "$LOAD_CONNECTIONS" -gt 0 ]]; then
  for x in "tellus tw" "MapCache ct" "MapProxy pt"; do
    read -r name s <<<"$x"
    say "memory under load: $name, wrk -c$LOAD_CONNECTIONS -d$LOAD_DURATION on ${label[$s]}"
    URLS="$work/urls-$s.txt" SEED="$SEED" RESULT="$work/res-$s-load.txt" \
      wrk -t"$WRK_THREADS" -c"$LOAD_CONNECTIONS" -d"$LOAD_DURATION" --timeout 30s -s "$repo/bench/proxy/urls.lua" \
      "http://127.0.0.1:$(port_of "$s")" >"$work/wrk-$s-load.log" 2>&1 &
    wrk_pid=$!
    peak_rss=0 peak_pss=0 peak_n=0
    while kill -0 "$wrk_pid" 2>/dev/null; do
      p="$(pids_of "$s")"
      # shellcheck disable=SC2086
      rss=$(mem_sum VmRSS $p)
      # shellcheck disable=SC2086
      pss=$(mem_sum Pss $p)
      ((rss > peak_rss)) && peak_rss=$rss && peak_n=$(echo $p | wc -w)
      ((pss > peak_pss)) && peak_pss=$pss
      sleep 0.25
    done
    wait "$wrk_pid" || warn "wrk -c$LOAD_CONNECTIONS on $name failed: $(cat "$work/wrk-$s-load.log")"
    echo -e "peak under load ($LOAD_CONNECTIONS connections)\t$name\t$peak_rss\t$peak_pss\t$peak_n\t$(sed 's/^RESULT //' "$work/res-$s-load.txt" 2>/dev/null)" >>"$mem"
  done
fi

fi # ONLY != seed

# ------------------------------------------------------------------------------ summary
mkdir -p "$OUT_DIR"
cp "$runs" "$OUT_DIR/peers-runs.tsv"
summary="$OUT_DIR/peers-summary.txt"
for s in $all_series; do echo "$s ${label[$s]}"; done >"$work/labels.txt"
hz=$(getconf CLK_TCK)
python3 - "$runs" "$hz" "$(nproc)" "$work/labels.txt" "$seeds" "$mem" "$region_tiles" "$tellus_arbitrary" \
  "$up_during_load" "$DURATION" "$REGION" "$LEVELS" "$SEED_CONCURRENCY" "$arb_answer" <<'EOF' | tee "$summary"
import statistics, sys
(runs, hz, ncpu, labels, seeds, mem, region_tiles, tellus_arb, up_load, duration, region, levels,
 seed_conc, arb_answer) = sys.argv[1:15]
hz, ncpu, region_tiles = int(hz), int(ncpu), int(region_tiles)
label = dict(line.rstrip("\n").split(" ", 1) for line in open(labels))
rows = {}
for line in open(runs):
    f = line.rstrip("\n").split("\t")
    kv = dict(x.split("=") for x in f[8].split())
    wall = int(kv["duration_us"]) / 1e6
    kv.update(load=float(f[2]), cpu_s=int(f[3]) / hz, wrk_s=float(f[4]), conns=f[7], round=f[1])
    kv.update(other=(int(f[5]) / hz - kv["cpu_s"] - kv["wrk_s"]) / (wall * ncpu) * 100)
    rows.setdefault(f[0], []).append(kv)
med = lambda s, k: statistics.median(float(r[k]) for r in rows[s])
rps = {s: med(s, "req_s") for s in rows}

if rows:
    print()
    print(f"== Load runs: median of {len(next(iter(rows.values())))} rounds per series, wrk -d{duration}")
    print(f"{'series':<29}{'conns':>6}{'req/s':>9}{'(min-max)':>17}{'p50 ms':>8}{'p99 ms':>9}{'bytes/resp':>11}"
          f"{'CPU us/req':>11}{'srv CPU%':>9}{'other%':>7}  non-2xx / errors")
    for s in label:
        if s not in rows:
            continue
        rs = rows[s]
        lo, hi = min(float(r["req_s"]) for r in rs), max(float(r["req_s"]) for r in rs)
        cpu = statistics.median(r["cpu_s"] / max(1, int(r["requests"])) * 1e6 for r in rs)
        srv = statistics.median(r["cpu_s"] / (int(r["duration_us"]) / 1e6) * 100 for r in rs)
        other = statistics.median(r["other"] for r in rs)
        size = statistics.median(int(r["bytes"]) / max(1, int(r["requests"])) for r in rs)
        errs = {k: sum(int(r[k]) for r in rs) for k in ("status", "connect", "read", "write", "timeout")}
        err = "none" if not any(errs.values()) else " ".join(f"{k} {v}" for k, v in errs.items() if v)
        print(f"{label[s]:<29}{rs[0]['conns']:>6}{rps[s]:>9.0f}{f'({lo:.0f}-{hi:.0f})':>17}{med(s, 'p50_us') / 1000:>8.2f}"
              f"{med(s, 'p99_us') / 1000:>9.2f}{size:>11.0f}{cpu:>11.1f}{srv:>9.0f}{other:>7.0f}  {err}")
    print(f"upstream requests during the load runs: {up_load}"
          + (" (every answer came from the caches)" if up_load == "0" else " (SOME ANSWERS WERE NOT CACHED: compare with care)"))
    disturbed = [f"{s}{r['round']}" for s in rows for r in rows[s] if r["other"] > 10]
    if disturbed:
        print(f"WARNING: other tasks took more than 10% of the CPUs during {len(disturbed)} runs "
              f"({' '.join(disturbed)}): compare those with care")

    print()
    print("== Ratios (tellus / peer, req/s medians of this run) and issue #4's goals")
    def ratio_row(name, t, c, p, gc, gp):
        if t not in rps:
            print(f"{name:<38} tellus: not supported ({arb_answer}); MapCache {rps.get(c, 0):.0f} req/s, "
                  f"MapProxy {rps.get(p, 0):.0f} req/s")
            return
        rc, rp = rps[t] / rps[c], rps[t] / rps[p]
        v = lambda r, g: "met" if r >= g else "MISSED"
        print(f"{name:<38}{rc:>7.2f}x MapCache (goal >= {gc}x: {v(rc, gc)}){rp:>8.2f}x MapProxy (goal >= {gp}x: {v(rp, gp)})")
    ratio_row("cached tile, tellus /wwtile vs z/x/y", "tw", "ct", "pt", 1.05, 6)
    ratio_row("cached tile, tellus /tiles/ vs z/x/y", "ts", "ct", "pt", 1.05, 6)
    ratio_row("cached tile, WMS 1.1.1 tile-aligned", "tm", "cm", "pm", 1.05, 6)
    ratio_row("arbitrary box WMS 1.3.0 1024x768 JPEG", "ta", "ca", "pa", 1.7, 6)

print()
srows = [l.rstrip("\n").split("\t") for l in open(seeds)]
names = {"up512": "MapServer alone, 512 px GetMap per tile",
         "up2048": "MapServer alone, 2048 px per 4x4 metatile",
         "tellus1": "tellus seed --meta-tiles 1 (per tile)",
         "tellus": "tellus seed (4x4 metatiles)", "MapProxy": "mapproxy-seed (4x4 metatiles)",
         "MapCache": "mapcache_seed (4x4 metatiles)"}
by = {}
for f in srows:
    name, secs, tiles, reqs, errs = f[0], float(f[2]), int(f[3]), int(f[4]), int(f[5])
    # the ceiling runs: tiles answered per second; the seeders: the region's tiles per second
    rate = tiles / secs if name.startswith("up") else region_tiles / secs
    by.setdefault(name, []).append((rate, secs, tiles, reqs, errs))
rates = {n: statistics.median(r[0] for r in v) for n, v in by.items()}
ceil512 = rates.get("up512")
print(f"== Seeding region {region} levels {levels} ({region_tiles} tiles) from the upstream, "
      f"{seed_conc} parallel requests each; median of {max(len(v) for v in by.values())} rounds")
print(f"{'seeder':<44}{'tiles/s':>9}{'(min-max)':>13}{'seconds':>8}{'tiles':>7}{'upstream req':>13}{'vs 512 px ceiling':>19}")
for name in names:
    if name not in by:
        continue
    v = by[name]
    lo, hi = min(r[0] for r in v), max(r[0] for r in v)
    errs = sum(r[4] for r in v)
    print(f"{names[name]:<44}{rates[name]:>9.0f}{f'({lo:.0f}-{hi:.0f})':>13}{statistics.median(r[1] for r in v):>8.2f}"
          f"{v[-1][2]:>7}{statistics.median(r[3] for r in v):>13.0f}{rates[name] / ceil512:>18.2f}x"
          + (f"  upstream failures / wrk errors: {errs}" if errs else ""))
if "tellus" in rates and "MapProxy" in rates:
    print(f"tellus seed vs mapproxy-seed: {rates['tellus'] / rates['MapProxy']:.2f}x (goal >= 1: "
          f"{'met' if rates['tellus'] >= rates['MapProxy'] else 'MISSED'}); vs mapcache_seed "
          f"{rates['tellus'] / rates['MapCache']:.2f}x; vs MapServer alone (512 px per tile) {rates['tellus'] / ceil512:.2f}x"
          + (f", (2048 px per metatile) {rates['tellus'] / rates['up2048']:.2f}x" if "up2048" in rates else ""))
if "tellus" in rates and "tellus1" in rates:
    print(f"tellus seed with 4x4 metatiles vs one GetMap per tile: {rates['tellus'] / rates['tellus1']:.2f}x")
print("tiles: what the ceiling runs got answered / what each seeder wrote (metatiles reach past the region);"
      " tiles/s of a seeder: the region's tiles over its wall time, start-up included")

if not rows:  # ONLY=seed
    sys.exit(0)
print()
print("== Resident memory, summed over every process of each server (MiB)")
print(f"{'when':<36}{'server':<10}{'VmRSS':>8}{'PSS':>8}{'procs':>6}  load run")
for l in open(mem):
    f = l.rstrip("\n").split("\t")
    extra = ""
    if len(f) > 5 and f[5]:
        kv = dict(x.split("=") for x in f[5].split())
        errs = {k: int(kv[k]) for k in ("status", "connect", "read", "write", "timeout")}
        err = "none" if not any(errs.values()) else " ".join(f"{k} {v}" for k, v in errs.items() if v)
        extra = f"  {float(kv['req_s']):.0f} req/s, non-2xx / errors: {err}"
    print(f"{f[0]:<36}{f[1]:<10}{int(f[2]) / 1024:>8.1f}{int(f[3]) / 1024:>8.1f}{f[4]:>6}{extra}")
peak = {f[1]: int(f[2]) for f in (l.rstrip("\n").split("\t") for l in open(mem)) if f[0].startswith("peak")}
if "tellus" in peak:
    print(f"goal: tellus RSS < 100 MiB under load: {'met' if peak['tellus'] < 100 * 1024 else 'MISSED'} "
          f"({peak['tellus'] / 1024:.1f} MiB)")
print("PSS counts a page shared by several processes (Apache's children, gunicorn's workers) once.")
EOF
say "runs: $OUT_DIR/peers-runs.tsv, summary: $summary"
