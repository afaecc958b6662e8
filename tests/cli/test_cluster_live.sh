#!/usr/bin/env bash
# `tellus cluster` live (issue 28; labels gl and integration: run under xvfb-run): a channel
# killed mid-show and restarted. mpirun --enable-recovery starts the master and three small
# channels looping a flight in real time; `kill -9` of one channel: the master says it is lost and
# the others go on frame-locked (their digests equal the master's, frame by frame); the channel
# restarted alone (its own mpirun job, joined through the master's port by ompi-server) draws
# the master's current frame first. The console (--control on loopback) is driven with curl:
# GET /status names the lost and the rejoined channel; POST /camera, /time and /path change what
# the next frames show; bad requests get a 400 and their error. KEEP=1 keeps the work folder.
set -euo pipefail
tellus=$1
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-cluster-live.XXXXXX")
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  [ -n "${KEEP:-}" ] || rm -rf "$work"
}
trap cleanup EXIT
fail() {
  echo "FAIL: $*" >&2
  tail -n 20 "$work"/*.err >&2 || true
  exit 1
}
. "$(dirname "$0")/cluster_support.sh"
lines() { [ -f "$1" ] && wc -l <"$1" || echo 0; }
at_least() { [ "$(lines "$1")" -ge "$2" ]; }

echo '{"channels": [
 {"name": "north", "azimuth": 0, "elevation": 20, "hfov": 110, "vfov": 90, "width": 40, "height": 28},
 {"name": "east", "azimuth": 90, "elevation": 20, "hfov": 110, "vfov": 90, "width": 40, "height": 28},
 {"name": "zenith", "azimuth": 0, "elevation": 90, "hfov": 100, "vfov": 100, "width": 28, "height": 28}
]}' >"$work/dome.json"
echo '[{"time": 0, "lat": 45, "lon": 7, "alt": 2e6}, {"time": 4, "lat": 46, "lon": 9, "alt": 1e6, "heading": 20}]' \
  >"$work/path.json"
common=(--no-sun --no-atmosphere --no-stars --cache "$work/cache" --path "$work/path.json" --fps 20)
opts=("${common[@]}" --realtime --loop --channel-timeout 10 --port "$work/port" --out "$work/o")

# Connecting two mpirun jobs takes Open MPI's rendezvous server.
ompi-server --no-daemonize -r "$work/uri" &
pids+=($!)
wait_for 20 test -s "$work/uri" || fail "ompi-server did not start"
mpi=(--oversubscribe --ompi-server "file:$work/uri")
# The flight once as fast as it goes: the tiles made (a fresh cache's first frames wait on its
# index, shared by the ranks), the plain show under these options.
mpirun "${mpi[@]}" --enable-recovery -n 4 "$tellus" cluster "$work/dome.json" "${common[@]}" \
  --out "$work/warm" >/dev/null || fail "the flight"

mpirun "${mpi[@]}" --enable-recovery -n 4 "$tellus" cluster "$work/dome.json" "${opts[@]}" \
  --control 127.0.0.1:0 >"$work/master.out" 2>"$work/master.err" &
job=$!
pids+=($job)
wait_for 120 at_least "$work/o/digest-master.txt" 10 || fail "the show did not start"
port=$(sed -n 's|^tellus cluster: control on http://127.0.0.1:\([0-9]*\)$|\1|p' "$work/master.out")
[ -n "$port" ] || fail "no control port: $(cat "$work/master.out")"
api=http://127.0.0.1:$port
# status KEY: a value of GET /status (jq's path)
status() { curl -s "$api/status" | jq -r "$1"; }
# post PATH BODY: the HTTP status of the answer (its body in $work/answer)
post() { curl -s -o "$work/answer" -w '%{http_code}' -X POST -d "$2" "$api$1"; }
# channel_state NAME STATE: the status says channel NAME is STATE
channel_state() { [ "$(status ".channels[] | select(.name == \"$1\") | .state")" = "$2" ]; }
east=$(rank_pid "$job" 2) || fail "no rank 2"
kill -9 "$east"
wait_for 30 grep -q "channel east lost at frame" "$work/master.err" || fail "the loss not reported"
wait_for 10 channel_state east lost || fail "the status: $(curl -s "$api/status")"
channel_state north alive || fail "north in the status: $(curl -s "$api/status")"
lost=$(lines "$work/o/digest-master.txt")
wait_for 30 at_least "$work/o/digest-master.txt" $((lost + 10)) || fail "the show stopped"

# The channel restarted alone: it joins at the master's current frame.
mpirun "${mpi[@]}" -n 1 "$tellus" cluster "$work/dome.json" "${opts[@]}" --join east \
  >"$work/east.out" 2>"$work/east.err" &
joiner=$!
pids+=($joiner)
wait_for 60 grep -q "channel east rejoined at frame" "$work/master.err" || fail "east did not rejoin"
rejoined=$(sed -n 's/.*channel east rejoined at frame \([0-9]*\).*/\1/p' "$work/master.err")
wait_for 30 at_least "$work/o/digest-master.txt" $((rejoined + 10)) || fail "the show stopped"
wait_for 10 channel_state east rejoined || fail "the status: $(curl -s "$api/status")"

# The console: bad requests refused with their error; the camera, the time and the path set.
[ "$(post /camera '{"lat": 10,')" = 400 ] && grep -q "not JSON" "$work/answer" || fail "bad JSON"
[ "$(post /camera '{"lat": 10, "zoom": 2}')" = 400 ] && grep -q 'unknown field \\"zoom\\"' "$work/answer" ||
  fail "an unknown field: $(cat "$work/answer")"
[ "$(post /camera '{"tilt": 200}')" = 400 ] || fail "a tilt out of range"
[ "$(post /path '{"action": "play", "file": "'"$work"'/none.json"}')" = 400 ] || fail "a missing path file"
sed 's/"time": 0,/"time": 0, "times": {"bluemarble": "x"},/' "$work/path.json" >"$work/timed.json"
[ "$(post /path '{"action": "play", "file": "'"$work"'/timed.json"}')" = 400 ] &&
  grep -q 'are not sent to channels' "$work/answer" || fail "a path with times: $(cat "$work/answer")"
[ "$(curl -s -o /dev/null -w '%{http_code}' "$api/nothing")" = 404 ] || fail "an unknown path"
[ "$(post /camera '{"lat": 10, "lon": 20, "altitude": 5e6}')" = 202 ] || fail "camera"
[ "$(post /time '{"unix": 1700000000}')" = 202 ] || fail "time"
# is EXPRESSION: GET /status makes jq's expression true
is() { [ "$(status "$1")" = true ]; }
wait_for 10 is '.camera.lat == 10 and .camera.altitude == 5e6 and .time == 1.7e9' ||
  fail "the camera and time not set: $(curl -s "$api/status")"
is '.path.playing == false' || fail "the path plays on after /camera: $(curl -s "$api/status")"
[ "$(post /path '{"action": "seek", "seconds": 2}')" = 202 ] || fail "seek"
wait_for 10 is '.path.seconds == 2' || fail "seek: $(curl -s "$api/status")"
[ "$(post /path '{"action": "play"}')" = 202 ] || fail "play"
wait_for 10 is '.path.playing' || fail "play: $(curl -s "$api/status")"
before=$(status .frame)
wait_for 10 is '.path.seconds != 2' || fail "the path does not play"
[ "$(status .frame)" -gt "$before" ] || fail "the frames do not advance"
kill -TERM "$(rank_pid "$job" 0)" # the master ends the show
wait "$joiner" || fail "the restarted channel failed: $(cat "$work/east.err")"
wait "$job" || true # mpirun reports the rank killed
grep -q "tellus cluster: [0-9]* frames of 3 channels" "$work/master.out" ||
  fail "the master did not end the show: $(cat "$work/master.out")"

# The others frame-locked throughout; east: what it drew before it died, then from its rejoin.
for n in north zenith; do
  cmp -s "$work/o/digest-master.txt" "$work/o/digest-$n.txt" || fail "channel $n drew other states"
done
python3 - "$work/o" "$rejoined" <<'PY' || fail "the restarted channel's states"
import sys
out, rejoined = sys.argv[1], int(sys.argv[2])
master = open(f"{out}/digest-master.txt").read().splitlines()
east = open(f"{out}/digest-east.txt").read().splitlines()
cut = next(i for i, line in enumerate(east) if int(line.split()[0]) == rejoined)
before, after = east[:cut], east[cut:]
assert before == master[:len(before)], "east before its death"
assert after[0] == master[rejoined], f"east's first frame {after[0]} != {master[rejoined]}"
assert after == master[rejoined:rejoined + len(after)], "east after its rejoin"
assert len(after) >= 10 and rejoined > len(before), (len(before), rejoined, len(after))
print(f"east: frames 0-{len(before) - 1}, killed, rejoined at {rejoined}: {len(after)} frames")
PY
[ -f "$work/o/channel-east-$(printf %05d "$rejoined").png" ] || fail "east's first frame not drawn"
echo "ok"
