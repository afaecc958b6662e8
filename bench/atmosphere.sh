#!/usr/bin/env bash
# The atmosphere's cost (issue 23): frame time with and without it (--no-atmosphere), side by
# side in one run, on the scripted flights of bench/paths/ (the descent, 20,000 km to 20 km, and
# the level pass at 2,000 km), flat 1024x768 and a 2048 domemaster (direct method), each flight
# flown twice in one renderer (--repeat 2: the second pass, everything resident, gives each
# view's cost without streaming; its median is the figure), the two configurations alternated in
# each round; then the tables' precomputation time (--stats atmosphere_precompute_ms) of each
# run. Mesa llvmpipe under Xvfb renders on the CPU: every figure is a CPU figure; read the ratios.
# Usage: bench/atmosphere.sh [path/to/tellus]   (ROUNDS=2, FPS=25 by default; FPS=5 flies each
# 4-second flight in 21 frames instead of 101; VIEWS="flat" leaves the dome out). OFF="..." sets
# what "without" turns off: the whole look of issue 23 against none of it is
# OFF="--no-atmosphere --no-stars --no-sun --no-night --no-fade-in --no-geomorph".
# BEFORE=path/to/other/tellus: side by side in one run, before (that binary) and after (this
# one): each round renders, alternated, after with everything ("on"), before with everything
# ("before"), after without the atmosphere ("noatmo"), without the stars ("nostars") and without
# the whole look ("none"); the table then gives the whole look (on / none) and the atmosphere
# alone (on / noatmo) for both binaries, and the stars alone (on / nostars).
# RESOLUTIONS=1: the atmosphere's resolutions side by side (renderer.atmosphere.resolution): each
# round renders, alternated, with the whole look at --atmosphere-resolution full, half and
# quarter, without the atmosphere ("noatmo") and without any of the look ("none"); the table
# gives the settled frames' median and each whole run's CPU seconds (less sensitive to other
# load than wall time: the runs differ only in the look).
set -euo pipefail
tellus=${1:-build/tools/tellus/tellus}
rounds=${ROUNDS:-2}
fps=${FPS:-25}
views=${VIEWS:-flat dome}
read -r -a off <<<"${OFF:---no-atmosphere}"
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-atmosphere-bench.XXXXXX")
trap 'rm -rf "$work"' EXIT
paths="$(dirname "$0")/paths"
run() { # flight, view name, configuration name, arguments...
  local flight=$1 view=$2 name=$3
  shift 3
  /usr/bin/time -f "%U %S" -o "$work/cpu.txt" xvfb-run -a -s '-screen 0 1280x1024x24' \
    "$tellus" render --cache "$work/cache" \
    --path "$paths/$flight.json" --frames "$work/frames" --fps "$fps" --repeat 2 \
    --stats "$work/s.json" "$@" >/dev/null
  python3 - "$flight" "$view" "$name" "$work/s.json" "$work/cpu.txt" <<'PY'
import json, sys
s = json.load(open(sys.argv[4]))
t = s["frame_times_ms"][len(s["frame_times_ms"]) // 2:]  # the settled second pass
t.sort()
cpu = sum(float(x) for x in open(sys.argv[5]).read().split()[-2:])  # the whole run's CPU s
print("%s %s %s %.2f %.1f %.2f" % (sys.argv[1], sys.argv[2], sys.argv[3], t[len(t) // 2],
                                   s.get("atmosphere_precompute_ms", 0.0), cpu))
PY
}
for flight in descent level; do # warm the cache
  run "$flight" flat warm --size 1024x768 "${off[@]}" >/dev/null
done
for r in $(seq "$rounds"); do
  for flight in descent level; do
    for v in $views; do
      size=(--size 1024x768)
      [ "$v" = dome ] && size=(--dome --size 2048)
      if [ -n "${RESOLUTIONS:-}" ]; then
        none=(--no-atmosphere --no-stars --no-sun --no-night --no-fade-in --no-geomorph)
        for res in full half quarter; do
          run "$flight" "$v" "$res" "${size[@]}" --atmosphere-resolution "$res"
        done
        run "$flight" "$v" noatmo "${size[@]}" --no-atmosphere
        run "$flight" "$v" none "${size[@]}" "${none[@]}"
      elif [ -n "${BEFORE:-}" ]; then
        none=(--no-atmosphere --no-stars --no-sun --no-night --no-fade-in --no-geomorph)
        run "$flight" "$v" on "${size[@]}"
        tellus=$BEFORE run "$flight" "$v" before "${size[@]}"
        run "$flight" "$v" noatmo "${size[@]}" --no-atmosphere
        run "$flight" "$v" nostars "${size[@]}" --no-stars
        run "$flight" "$v" none "${size[@]}" "${none[@]}"
      else
        run "$flight" "$v" on "${size[@]}"
        run "$flight" "$v" off "${size[@]}" "${off[@]}"
      fi
    done
  done
done >"$work/results.txt"
cat "$work/results.txt"
echo
if [ -n "${RESOLUTIONS:-}" ]; then
  echo "| flight | view | median frame ms: full, half, quarter, no atmosphere, none of the look | whole look / none: full, half, quarter | run CPU s: full, half, quarter, no atmosphere, none | the atmosphere's CPU share of the look (full, half, quarter - no atmosphere) / (full - none) |"
  echo "|---|---|---|---|---|---|"
  python3 - "$work/results.txt" <<'PY'
import sys, collections, statistics
rows = collections.defaultdict(lambda: collections.defaultdict(list))
cpu = collections.defaultdict(lambda: collections.defaultdict(list))
for line in open(sys.argv[1]):
    flight, view, name, ms, _, c = line.split()
    rows[(flight, view)][name].append(float(ms))
    cpu[(flight, view)][name].append(float(c))
r = ("full", "half", "quarter")
for key, d in rows.items():
    m = {k: statistics.median(v) for k, v in d.items()}
    c = {k: statistics.median(v) for k, v in cpu[key].items()}
    look = c["full"] - c["none"]
    print("| %s | %s | %s | %s | %s | %s |" % (
        key[0], "1024x768" if key[1] == "flat" else "dome 2048 direct",
        ", ".join("%.1f" % m[k] for k in r + ("noatmo", "none")),
        ", ".join("%.2fx" % (m[k] / m["none"]) for k in r),
        ", ".join("%.1f" % c[k] for k in r + ("noatmo", "none")),
        ", ".join("%.2f" % ((c[k] - c["noatmo"]) / look) for k in r)))
PY
  exit 0
fi
if [ -n "${BEFORE:-}" ]; then
  echo "| flight | view | median frame ms: after, before, no atmosphere, no stars, none of the look | whole look after / before | atmosphere alone after / before | stars alone | tables ms after / before |"
  echo "|---|---|---|---|---|---|---|"
  python3 - "$work/results.txt" <<'PY'
import sys, collections, statistics
rows = collections.defaultdict(lambda: collections.defaultdict(list))
pre = collections.defaultdict(list)
for line in open(sys.argv[1]):
    flight, view, name, ms, p = line.split()[:5]
    rows[(flight, view)][name].append(float(ms))
    if name in ("on", "before"):
        pre[name].append(float(p))
med = statistics.median
for (flight, view), d in rows.items():
    m = {k: med(v) for k, v in d.items()}
    print("| %s | %s | %.1f, %.1f, %.1f, %.1f, %.1f | %.2fx / %.2fx | %.2fx / %.2fx | %.2fx | %.0f / %.0f |" % (
        flight, "1024x768" if view == "flat" else "dome 2048 direct",
        m["on"], m["before"], m["noatmo"], m["nostars"], m["none"],
        m["on"] / m["none"], m["before"] / m["none"], m["on"] / m["noatmo"],
        m["before"] / m["noatmo"], m["on"] / m["nostars"], med(pre["on"]), med(pre["before"])))
PY
  exit 0
fi
echo "| flight | view | with atmosphere: median frame ms per round | without | with / without per round | with / without (median of rounds) | precomputation ms per run (median) |"
echo "|---|---|---|---|---|---|---|"
python3 - "$work/results.txt" <<'PY'
import sys, collections
rows = collections.defaultdict(lambda: collections.defaultdict(list))
pre = []
for line in open(sys.argv[1]):
    flight, view, name, ms, p = line.split()[:5]
    rows[(flight, view)][name].append(float(ms))
    if name == "on":
        pre.append(float(p))
pre.sort()
for (flight, view), d in rows.items():
    ratios = sorted(a / b for a, b in zip(d["on"], d["off"]))
    print("| %s | %s | %s | %s | %s | %.2f | %.0f |" % (
        flight, "1024x768" if view == "flat" else "dome 2048 direct",
        ", ".join("%.1f" % x for x in d["on"]), ", ".join("%.1f" % x for x in d["off"]),
        ", ".join("%.2f" % x for x in ratios), ratios[len(ratios) // 2], pre[len(pre) // 2]))
PY
