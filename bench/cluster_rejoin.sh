#!/usr/bin/env bash
# How often a live show survives a channel lost twice (issue 28): a master and two channels
# looping a flight in real time; east killed (-9), restarted alone (its own mpirun job joined
# through the master's port), killed again, restarted again. A run counts when the master drew
# on through both losses and took east back both times. Run under an X display (xvfb-run -a).
#   bench/cluster_rejoin.sh [TELLUS] [RUNS]
set -uo pipefail
tellus=$(realpath "${1:-build/tools/tellus/tellus}")
runs=${2:-5}
. "$(dirname "$0")/../tests/cli/cluster_support.sh" # wait_for, rank_pid
lines() { [ -f "$1" ] && wc -l <"$1" || echo 0; }
at_least() { [ "$(lines "$1")" -ge "$2" ]; }
said() { [ "$(grep -c "$1" "$2")" -ge "$3" ]; }
one_run() {
  local work ok=1
  work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-rejoin.XXXXXX")
  echo '{"channels": [
   {"name": "north", "azimuth": 0, "elevation": 20, "hfov": 110, "vfov": 90, "width": 40, "height": 28},
   {"name": "east", "azimuth": 90, "elevation": 20, "hfov": 110, "vfov": 90, "width": 40, "height": 28}
  ]}' >"$work/dome.json"
  echo '[{"time": 0, "lat": 45, "lon": 7, "alt": 2e6}, {"time": 4, "lat": 46, "lon": 9, "alt": 1e6}]' \
    >"$work/path.json"
  local opts=(--no-sun --no-atmosphere --no-stars --cache "$work/cache" --path "$work/path.json"
    --fps 20 --realtime --loop --channel-timeout 5 --port "$work/port" --out "$work/o")
  ompi-server --no-daemonize -r "$work/uri" &
  local server=$!
  wait_for 20 test -s "$work/uri" || ok=0
  local mpi=(--oversubscribe --ompi-server "file:$work/uri")
  mpirun "${mpi[@]}" --enable-recovery -n 3 "$tellus" cluster "$work/dome.json" "${opts[@]}" \
    >"$work/master.out" 2>"$work/master.err" &
  local job=$! joiners=() frames
  wait_for 120 at_least "$work/o/digest-master.txt" 10 || ok=0
  kill -9 "$(rank_pid "$job" 2)" 2>/dev/null
  for round in 1 2; do
    wait_for 30 said "channel east lost" "$work/master.err" "$round" || ok=0
    mpirun "${mpi[@]}" -n 1 "$tellus" cluster "$work/dome.json" "${opts[@]}" --join east \
      >"$work/east$round.out" 2>&1 &
    joiners+=($!)
    wait_for 60 said "channel east rejoined" "$work/master.err" "$round" || ok=0
    frames=$(lines "$work/o/digest-master.txt")
    wait_for 30 at_least "$work/o/digest-master.txt" $((frames + 20)) || ok=0
    [ "$round" = 2 ] || kill -9 $(pgrep -P "${joiners[0]}") 2>/dev/null
  done
  kill -0 "$job" 2>/dev/null || ok=0
  echo "run: $([ $ok = 1 ] && echo survived || echo FAILED); $(lines "$work/o/digest-master.txt") frames;" \
    "$(grep -c "lost\|rejoined" "$work/master.err") losses and rejoins said" >&2
  kill -TERM "$(rank_pid "$job" 0)" 2>/dev/null
  sleep 2
  kill "$job" "${joiners[@]}" "$server" 2>/dev/null
  wait 2>/dev/null
  [ $ok = 1 ] && rm -rf "$work" || echo "kept: $work" >&2
  return $((1 - ok))
}
survived=0
for _ in $(seq "$runs"); do one_run && survived=$((survived + 1)); done
echo "survived a channel lost twice: $survived of $runs runs"
