# ONLY=mercator of run.sh (sourced by it once tellus and MapProxy serve the lat/long caches that
# its seeding step filled): composed Web Mercator (GoogleMapsCompatible) tiles per second, tellus
# against MapProxy, side by side (issue 25's performance goal: at least 3x the faster peer).
#
#   ONLY=mercator bench/peers/run.sh                    # about 4-5 minutes
#   ONLY=mercator ROUNDS=1 DURATION=2s WARMUP=0 LEVELS=0-4 MERC_ZOOMS=3-5 bench/peers/run.sh  # smoke
#
# The tiles: every GoogleMapsCompatible tile of zoom levels MERC_ZOOMS (default 3-7) that lies
# wholly inside REGION (default -36,-18,72,54: Europe, North Africa, the Middle East; the z = 2
# tiles are 90 degrees wide and none fits), so that both servers compose them from the seeded
# lat/long tiles (levels 0-4 reach z = 7's pixels up to 56 N) and none reaches the upstream.
#   tg  tellus    WMTS RESTful /wmts/1.0.0/world/default/GoogleMapsCompatible/z/row/col.jpg
#   pg  MapProxy  WMTS RESTful /wmts/world_gm/GLOBAL_WEBMERCATOR/z/col/row.jpeg: a cache on
#                 MapProxy's GLOBAL_WEBMERCATOR grid whose source is the lat/long cache (MapProxy
#                 reprojects its EPSG:4326 tiles, bilinear; one tile per request: meta_size 1x1)
# MapCache is not in it: it has no reprojection of its own (a tileset's source is a WMS or a
# file, never another grid's cache), so its Web Mercator tiles would be MapServer's work.
#
#  1. Checks: the first 20 tiles of each series answer 200 image/* without an upstream request
#     (they are left out of the cold pass: composed here already).
#  2. Cold: every other tile of the list once (once.py, MERC_CONNECTIONS parallel keep-alive
#     connections), in MERC_COLD_PARTS (6) parts with the servers alternating: each tile composed
#     from the lat/long cache and written to the server's own Web Mercator cache. Tiles per second
#     over the parts' summed wall time, and the server's CPU per tile.
#  3. Warm: wrk (urls.lua, random tiles of the same list, -c MERC_CONNECTIONS) for DURATION per
#     series, ROUNDS rounds alternating, medians: every tile from the server's Web Mercator cache.
#  No upstream request may happen during 1-3 (checked).

MERC_ZOOMS="${MERC_ZOOMS:-3-7}"
MERC_CONNECTIONS="${MERC_CONNECTIONS:-16}"
MERC_COLD_PARTS="${MERC_COLD_PARTS:-6}"
merc_lo="${MERC_ZOOMS%-*}" merc_hi="${MERC_ZOOMS#*-}"

python3 - "$work" "$REGION" "$merc_lo" "$merc_hi" <<'EOF'
import math, os, sys
work, region, lo, hi = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
W, S, E, N = (float(v) for v in region.split(","))
lat = lambda y: math.degrees(math.atan(math.sinh(y)))  # y in units of the sphere's radius
tiles = []
for z in range(lo, hi + 1):
    n = 2**z
    for row in range(n):
        north, south = lat(math.pi * (1 - 2 * row / n)), lat(math.pi * (1 - 2 * (row + 1) / n))
        for col in range(n):
            west, east = -180 + col * 360 / n, -180 + (col + 1) * 360 / n
            if W <= west and east <= E and S <= south and north <= N:
                tiles.append((z, row, col))
if len(tiles) < 40:
    sys.exit(f"run.sh: MERC_ZOOMS={lo}-{hi} has {len(tiles)} tiles inside REGION={region}: too few")
with open(os.path.join(work, "urls-tg.txt"), "w") as f:
    f.writelines(f"/wmts/1.0.0/world/default/GoogleMapsCompatible/{z}/{r}/{c}.jpg\n" for z, r, c in tiles)
with open(os.path.join(work, "urls-pg.txt"), "w") as f:
    f.writelines(f"/wmts/world_gm/GLOBAL_WEBMERCATOR/{z:02d}/{c}/{r}.jpeg\n" for z, r, c in tiles)
print(f"   {len(tiles)} GoogleMapsCompatible tiles of z {lo}-{hi} inside {region}")
EOF
merc_port() { case $1 in t?) echo "$tellus_port" ;; p?) echo "$mp_port" ;; esac; }
declare -A merc_label=([tg]="tellus WMTS GoogleMapsCompatible" [pg]="MapProxy WMTS GLOBAL_WEBMERCATOR")
merc_runs="$work/merc-runs.tsv"
: >"$merc_runs"
up0=$(upstream_requests)

# 1. checks (these tiles are composed now, and left out of the cold pass)
for s in tg pg; do
  while read -r url; do
    check_image "$s" "http://127.0.0.1:$(merc_port "$s")$url" || die "series $s (${merc_label[$s]}) does not answer an image"
  done < <(head -n 20 "$work/urls-$s.txt")
  tail -n +21 "$work/urls-$s.txt" >"$work/cold-$s.txt"
done
[[ $(upstream_requests) -eq $up0 ]] || die "the first Web Mercator tiles reached the upstream: a tile outside the seeded set"
say "checked: the first 20 tiles of each series answer 200, image/*, without an upstream request"

# 2. cold: every tile once; the server's CPU time (all its processes) read before and after
merc_ticks() { # SERIES: utime + stime of the server's processes, clock ticks
  local t=0 p pids
  case $1 in t?) pids="$tellus_pid" ;; p?) pids="$(gunicorn_pids)" ;; esac
  for p in $pids; do
    [[ -r /proc/$p/stat ]] || continue
    t=$((t + $(awk '{ sub(/.*\) /, ""); print $12 + $13 }' "/proc/$p/stat")))
  done
  echo "$t"
}
# The list is cut into MERC_COLD_PARTS parts (every part-th tile: each spans every zoom level) and
# the servers alternate part by part (the order reversed every other part), so that a change in
# the machine's other load falls on both; the parts' times and CPU are summed.
for s in tg pg; do
  split -n "r/$MERC_COLD_PARTS" -d "$work/cold-$s.txt" "$work/cold-$s.part"
done
declare -A cold_us=([tg]=0 [pg]=0) cold_ticks=([tg]=0 [pg]=0) cold_n=([tg]=0 [pg]=0) cold_bytes=([tg]=0 [pg]=0) cold_err=([tg]=0 [pg]=0)
say "cold: $(wc -l <"$work/cold-tg.txt") tiles once each, in $MERC_COLD_PARTS parts alternating, $MERC_CONNECTIONS connections"
for part in $(seq 0 $((MERC_COLD_PARTS - 1))); do
  order="tg pg"
  ((part % 2)) && order="pg tg"
  for s in $order; do
    f="$work/cold-$s.part$(printf '%02d' "$part")"
    c0=$(merc_ticks "$s")
    python3 "$here/once.py" "http://127.0.0.1:$(merc_port "$s")" "$f" "$MERC_CONNECTIONS" "$f.res" >/dev/null ||
      die "once.py failed on $s"
    c1=$(merc_ticks "$s")
    read -r n us bytes errors < <(sed 's/^RESULT //' "$f.res" | tr ' ' '\n' | awk -F= '
      $1 == "requests" { n = $2 } $1 == "duration_us" { d = $2 } $1 == "bytes" { b = $2 } $1 == "errors" { e = $2 }
      END { print n, d, b, e }')
    echo "   part $part, $s: $n tiles in $((us / 1000)) ms, $((c1 - c0)) CPU ticks"
    cold_n[$s]=$((cold_n[$s] + n)) cold_us[$s]=$((cold_us[$s] + us)) cold_bytes[$s]=$((cold_bytes[$s] + bytes))
    cold_err[$s]=$((cold_err[$s] + errors)) cold_ticks[$s]=$((cold_ticks[$s] + c1 - c0))
  done
done
for s in tg pg; do
  rate="$(awk -v n="${cold_n[$s]}" -v us="${cold_us[$s]}" 'BEGIN { printf "%.1f", n / (us / 1e6) }')"
  echo -e "$s\tcold\trequests=${cold_n[$s]} duration_us=${cold_us[$s]} req_s=$rate bytes=${cold_bytes[$s]} errors=${cold_err[$s]} cpu_ticks=${cold_ticks[$s]}" >>"$merc_runs"
  echo "   ${merc_label[$s]}: $rate tiles/s over the parts"
done
[[ -n "$(find "$work/mapproxy/cache_gm" -name '*.jpeg' -print -quit 2>/dev/null)" ]] ||
  die "MapProxy kept no Web Mercator tile in $work/mapproxy/cache_gm"

# 3. warm: wrk on the same list, from each server's Web Mercator cache
merc_run() { # SERIES ROUND DURATION
  local s=$1 round=$2 res="$work/res-$1-warm-$2.txt"
  URLS="$work/urls-$s.txt" SEED="$SEED" RESULT="$res" wrk -t"$WRK_THREADS" -c"$MERC_CONNECTIONS" -d"$3" \
    --timeout 30s --latency -s "$repo/bench/proxy/urls.lua" "http://127.0.0.1:$(merc_port "$s")" \
    >"$work/wrk-$s-warm-$round.log" 2>&1 || die "wrk failed: $(cat "$work/wrk-$s-warm-$round.log")"
  echo -e "$s\twarm\t$(sed 's/^RESULT //' "$res")"
}
if [[ "$WARMUP" != 0 ]]; then
  for s in tg pg; do merc_run "$s" 0 "$WARMUP" >/dev/null; done
fi
for round in $(seq 1 "$ROUNDS"); do
  order="tg pg"
  ((round % 2)) || order="pg tg"
  say "warm, round $round/$ROUNDS: $order (wrk -t$WRK_THREADS -c$MERC_CONNECTIONS -d$DURATION)"
  for s in $order; do
    line="$(merc_run "$s" "$round" "$DURATION")"
    echo "$line" >>"$merc_runs"
    echo "   $s: $(echo "$line" | grep -oE '(req_s|p99_us|status|timeout)=[0-9.]+' | tr '\n' ' ')"
  done
done
up_merc=$(($(upstream_requests) - up0))
x_cache="$(curl -s -o /dev/null -D - "http://127.0.0.1:$tellus_port$(tail -n 1 "$work/urls-tg.txt")" | tr -d '\r' |
  awk -F': ' 'tolower($1) == "x-cache" { print $2 }')"

# summary
mkdir -p "$OUT_DIR"
python3 - "$merc_runs" "$up_merc" "$x_cache" "$MERC_ZOOMS" "$REGION" "$commit" <<'EOF' | tee "$OUT_DIR/peers-mercator-summary.txt"
import os, statistics, sys
runs, up, x_cache, zooms, region, commit = sys.argv[1:7]
rows = {}
for line in open(runs):
    f = line.rstrip("\n").split("\t")
    kv = dict(x.split("=") for x in " ".join(f[2:]).split())
    rows.setdefault((f[0], f[1]), []).append(kv)
name = {"tg": "tellus", "pg": "MapProxy"}
print(f"Web Mercator (GoogleMapsCompatible) tiles from the lat/long cache, z {zooms} inside {region}, tree {commit}")
hz = os.sysconf("SC_CLK_TCK")
print(f"{'':10} {'cold tiles/s':>13} {'CPU ms/tile':>12} {'errors':>7} {'warm tiles/s':>13} {'p99 ms':>8} {'bytes/tile':>11}")
rate = {}
for s in ("tg", "pg"):
    cold = rows[(s, "cold")][0]
    warm = rows.get((s, "warm"), [])
    w = statistics.median(float(k["req_s"]) for k in warm) if warm else float("nan")
    p99 = statistics.median(int(k["p99_us"]) for k in warm) / 1000 if warm else float("nan")
    errors = int(cold["errors"]) + sum(int(k["status"]) + int(k["timeout"]) for k in warm)
    rate[s] = (float(cold["req_s"]), w)
    cpu = int(cold["cpu_ticks"]) / hz * 1000 / int(cold["requests"])
    rate[s] = rate[s] + (cpu,)
    print(f"{name[s]:10} {float(cold['req_s']):13.1f} {cpu:12.2f} {errors:7d} {w:13.1f} {p99:8.2f} "
          f"{int(cold['bytes']) / int(cold['requests']):11.0f}")
print(f"tellus / MapProxy: cold {rate['tg'][0] / rate['pg'][0]:.2f}x, warm {rate['tg'][1] / rate['pg'][1]:.2f}x "
      f"(goal: >= 3x the faster peer); server CPU per cold tile: MapProxy / tellus {rate['pg'][2] / rate['tg'][2]:.2f}x")
print(f"upstream requests during the Web Mercator runs: {up} (must be 0); tellus's X-Cache on a warm tile: {x_cache}")
EOF
