#!/usr/bin/env bash
# The frame cost of a two-body scene against one body (issue 26; docs/design/bodies.md "Several
# bodies"): `tellus render` of a flight flown twice in one renderer (--repeat 2), settled frames
# (the second pass: everything resident, each view's own cost), on the embedded default, with and
# without `--bodies moon` at 2024-01-18 03:52 UTC (the Moon at first quarter), alternating the two
# round after round. Two flights: the level pass of bench/paths/level.json (the Moon off screen:
# the pass's CPU and upload cost alone) and a view from 800,000 km with the Earth and the Moon in
# one frame (bench/paths/earth-moon.json). Then flying between bodies (PARTS=switch): the dome
# show bench/paths/earth-to-moon-dome.json (512 x 512 dome, 10 fps) without --body, the camera
# switching from the Earth's renderer to the Moon's on the way (planet/OrbitChoice.hpp), against
# the same flight orbiting the Moon throughout (--body moon) and the Earth throughout (--body
# earth: the flight as it was drawn before switching, the same frames until the switch),
# alternating. Mesa llvmpipe under
# Xvfb: frame times are CPU figures.
# Usage: [PARTS="scene switch"] bench/bodies.sh [path/to/tellus] [rounds]
#        (default build/tools/tellus/tellus, 3; both parts)
set -euo pipefail
tellus=${1:-build/tools/tellus/tellus}
rounds=${2:-3}
parts=${PARTS:-scene switch}
paths="$(dirname "$0")/paths"
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-bodies-bench.XXXXXX")
trap 'rm -rf "$work"' EXIT
settled() { # settled median, settled longest, as streamed median of a --repeat 2 --stats file
  python3 - "$1" "$(dirname "$0")" <<'PY'
import sys
sys.path.insert(0, sys.argv[2])
from flight_stats import flight
f = flight(sys.argv[1])
print("%.2f %.2f %.2f" % (f["settled_median"], f["settled_longest"], f["median"]))
PY
}
if [[ " $parts " == *" scene "* ]]; then
echo "| flight | scene | round | settled median ms | settled longest ms | as streamed median ms |"
echo "|---|---|---|---|---|---|"
declare -A sum
for r in $(seq 1 "$rounds"); do
  for flight in level earth-moon; do
    for scene in one two; do
      extra=()
      [ "$scene" = two ] && extra=(--bodies moon)
      xvfb-run -a -s '-screen 0 1280x1024x24' "$tellus" render --cache "$work/cache" \
        --path "$paths/$flight.json" --frames "$work/frames" --fps 10 --size 1024x768 \
        --repeat 2 --time 2024-01-18T03:52:00Z --stats "$work/s.json" "${extra[@]}" \
        >/dev/null
      read -r med longest streamed <<<"$(settled "$work/s.json")"
      echo "| $flight | $scene | $r | $med | $longest | $streamed |"
      sum[$flight-$scene]=$(python3 -c "print(${sum[$flight-$scene]:-0} + $med)")
    done
  done
done
echo
echo "| flight | one body: mean of settled medians, ms | two bodies | two / one |"
echo "|---|---|---|---|"
for flight in level earth-moon; do
  python3 -c "a=${sum[$flight-one]}/$rounds; b=${sum[$flight-two]}/$rounds; print('| $flight | %.2f | %.2f | %.3f |' % (a, b, b / a))"
done
fi
if [[ " $parts " == *" switch "* ]]; then
  echo
  echo "| earth-to-moon-dome | round | settled median ms | settled longest ms | as streamed median ms | switches |"
  echo "|---|---|---|---|---|---|"
  declare -A flown
  for r in $(seq 1 "$rounds"); do
    for scene in switch moon earth; do
      extra=()
      [ "$scene" != switch ] && extra=(--body "$scene")
      xvfb-run -a -s '-screen 0 1280x1024x24' "$tellus" render --cache "$work/cache" \
        --path "$paths/earth-to-moon-dome.json" --frames "$work/frames" --fps 10 --dome 180 \
        --size 512 --no-stars --repeat 2 --stats "$work/s.json" "${extra[@]}" >/dev/null
      read -r med longest streamed <<<"$(settled "$work/s.json")"
      switches=$(python3 -c "import json,sys; print(len(json.load(open(sys.argv[1]))['orbit_switches']))" "$work/s.json")
      echo "| $scene | $r | $med | $longest | $streamed | $switches |"
      flown[$scene]=$(python3 -c "print(${flown[$scene]:-0} + $med)")
    done
  done
  echo
  python3 -c "m=${flown[moon]}/$rounds; e=${flown[earth]}/$rounds; s=${flown[switch]}/$rounds; print('switching: mean of settled medians %.2f ms; --body moon %.2f ms (switch / moon %.3f); --body earth %.2f ms (switch / earth %.3f)' % (s, m, s / m, e, s / e))"
fi
