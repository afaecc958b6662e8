#!/usr/bin/env bash
# The stars pass's cost (issue 23): frame times with the star background and without (--no-stars),
# side by side in one run, the two alternated in each round, in the flat view (1024x768) and the
# dome (2048, direct method), on the scripted flights (bench/paths/: the descent and the level
# pass) and on a held view of the sky (looking up from 10,000 km: the stars fill the frame, the
# globe is behind the camera). Each flight is rendered settled (--repeat 2: the second pass, with
# everything resident, gives each frame's cost without streaming); the figure is the median frame
# time of that pass. Mesa llvmpipe under Xvfb renders on the CPU: every figure is a CPU figure;
# read the ratios.
# Usage: bench/stars.sh [path/to/tellus]   (ROUNDS=3 FPS=5 by default)
set -euo pipefail
tellus=${1:-build/tools/tellus/tellus}
rounds=${ROUNDS:-3}
fps=${FPS:-5}
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-stars-bench.XXXXXX")
trap 'rm -rf "$work"' EXIT
paths="$(cd "$(dirname "$0")/paths" && pwd)"
cp "$paths/descent.json" "$paths/level.json" "$work/"
# The sky: Orion overhead at the equator (no time given: the sky of J2000.0), held 2 s.
printf '[{"time": 0, "lat": 0, "lon": -60, "alt": 1e7, "heading": 0, "tilt": 180},\n' >"$work/sky.json"
printf ' {"time": 2, "lat": 0, "lon": -60, "alt": 1e7, "heading": 0, "tilt": 180}]\n' >>"$work/sky.json"
run() { # flight, view (flat | dome), stars (on | off)
  local args=(--size 1024x768)
  [ "$2" = dome ] && args=(--dome --dome-method direct --size 2048)
  [ "$3" = off ] && args+=(--no-stars)
  xvfb-run -a -s '-screen 0 2100x2100x24' "$tellus" render --cache "$work/cache" \
    --path "$work/$1.json" --frames "$work/frames" --fps "$fps" --repeat 2 \
    --stats "$work/s.json" "${args[@]}" >/dev/null
  python3 - "$1" "$2" "$3" "$work/s.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[4]))
t = sorted(s["frame_times_ms"][len(s["frame_times_ms"]) // 2:])  # the settled second pass
print("%s %s %s %.3f" % (sys.argv[1], sys.argv[2], sys.argv[3], t[len(t) // 2]))
PY
}
for f in descent level sky; do run "$f" flat off >/dev/null; done # warm the cache
for r in $(seq "$rounds"); do
  for f in descent level sky; do
    for v in flat dome; do
      run "$f" "$v" on
      run "$f" "$v" off
    done
  done
done >"$work/results.txt"
cat "$work/results.txt"
echo
echo "| flight | view | with stars: median frame ms per round | without | with / without per round | median ratio |"
echo "|---|---|---|---|---|---|"
python3 - "$work/results.txt" <<'PY'
import sys, collections
runs = collections.defaultdict(list)
for line in open(sys.argv[1]):
    f, v, s, ms = line.split()
    runs[(f, v, s)].append(float(ms))
for f in ("descent", "level", "sky"):
    for v in ("flat", "dome"):
        on, off = runs[(f, v, "on")], runs[(f, v, "off")]
        ratios = sorted(a / b for a, b in zip(on, off))  # the median: the middle (upper of two)
        print("| %s | %s | %s | %s | %s | %.3f |" % (
            f, "1024x768" if v == "flat" else "dome 2048 direct",
            ", ".join("%.2f" % x for x in on), ", ".join("%.2f" % x for x in off),
            ", ".join("%.3f" % x for x in ratios), ratios[len(ratios) // 2]))
PY
