#!/usr/bin/env bash
# `tellus cluster` with a flight whose keyframes switch a layer's time (issue 28; labels gl and
# integration: run under xvfb-run): the master broadcasts where along --path the layer times are
# taken and every channel switches the layer as `tellus render --path` does. The layer is a WMS
# upstream whose every time is a solid colour of its own (time_upstream.py); with
# --wait-complete each channel's frames show January until the keyframe at 0.5 s, March from it,
# and the channels' digests equal the master's. A keyframe naming a layer that is not drawn is a
# usage error (a path the console loads with "times" gets a 400: test_cluster_live.sh). Then the
# console sets the layers of a looping show (POST /layer): a time (April), hidden, shown at half
# opacity: the channels' next frames show each; names, times and the base's opacity that are not
# the layers' are refused with a 400; the digests of every rank agree. KEEP=1 keeps the work
# folder.
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd)
data=$(cd "$here/../../data" && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-cluster-times.XXXXXX")
upstream_pid=
job=
cleanup() {
  [ -n "$upstream_pid" ] && kill "$upstream_pid" 2>/dev/null || true
  [ -n "$job" ] && kill "$job" 2>/dev/null || true
  [ -n "${KEEP:-}" ] || rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
pixel() { python3 "$here/png_pixels.py" "$@"; }
near() { python3 -c "import sys; v=list(map(int,sys.argv[1:7])); t=int(sys.argv[7]); sys.exit(0 if all(abs(a-b)<=t for a,b in zip(v[:3],v[3:])) else 1)" "$@"; }
. "$here/cluster_support.sh"

. "$here/time_upstream.sh"
time_upstream_config "$work/times.yaml"
# Two channels looking at the globe below the camera (the dome's axis: the view direction).
echo '{"channels": [
 {"name": "a", "azimuth": 0, "elevation": 80, "hfov": 20, "vfov": 20, "width": 32, "height": 32},
 {"name": "b", "azimuth": 180, "elevation": 80, "hfov": 20, "vfov": 20, "width": 32, "height": 32}
]}' >"$work/dome.json"
cat >"$work/path.json" <<'JSON'
[{"time": 0, "lat": 10, "lon": 20, "alt": 8e6, "times": {"monthly": "2024-01-01"}},
 {"time": 0.5, "lat": 10, "lon": 20, "alt": 8e6, "times": {"monthly": "2024-03-01"}},
 {"time": 1, "lat": 10, "lon": 20, "alt": 8e6}]
JSON
cluster() {
  mpirun --oversubscribe -n 3 "$tellus" cluster "$work/dome.json" --config "$work/times.yaml" \
    --overlay monthly,1 --no-sun --no-atmosphere --no-stars --fps 4 "$@"
}
out=$(cluster --path "$work/path.json" --wait-complete --out "$work/o" 2>&1) || fail "cluster: $out"
# Frames at 0, 0.25, 0.5, 0.75 and 1 s: January, January, then March.
want=("220 30 30" "220 30 30" "40 60 230" "40 60 230" "40 60 230")
for n in 0 1 2 3 4; do
  for ch in a b; do
    f=$(printf "%s/o/channel-%s-%05d.png" "$work" "$ch" "$n")
    [ -f "$f" ] || fail "no $f: $out"
    read -r r g b < <(pixel "$f" 16 16)
    # shellcheck disable=SC2086
    near "$r" "$g" "$b" ${want[$n]} 3 || fail "channel $ch, frame $n: $r $g $b, want ${want[$n]}"
  done
done
for ch in a b; do
  cmp -s "$work/o/digest-master.txt" "$work/o/digest-$ch.txt" || fail "channel $ch drew other states"
done
! grep -q "TIME=2024-02-01" "$work/upstream.log" || fail "a time no keyframe names was fetched"

# A keyframe naming a layer that is not drawn: a usage error, named.
sed 's/"monthly": "2024-03-01"/"nope": "2024-03-01"/' "$work/path.json" >"$work/bad.json"
set +e
msg=$(cluster --path "$work/bad.json" --out "$work/u" 2>&1)
rc=$?
set -e
[ $rc -ne 0 ] && grep -qF "a keyframe's \"times\" names a layer that is not drawn: nope" <<<"$msg" ||
  fail "a time for a layer not drawn: $rc $msg"

# The console sets the layer while the show loops (a still path: January by its keyframe; the
# console's time wins over it).
echo '[{"time": 0, "lat": 10, "lon": 20, "alt": 8e6, "times": {"monthly": "2024-01-01"}},
 {"time": 1, "lat": 10, "lon": 20, "alt": 8e6}]' >"$work/still.json"
mpirun --oversubscribe -n 3 "$tellus" cluster "$work/dome.json" --config "$work/times.yaml" \
  --overlay monthly,1 --no-sun --no-atmosphere --no-stars --path "$work/still.json" --loop \
  --wait-complete --control 127.0.0.1:0 --out "$work/l" >"$work/master.out" 2>"$work/master.err" &
job=$!
port_of() { sed -n 's|^tellus cluster: control on http://127.0.0.1:\([0-9]*\)$|\1|p' "$work/master.out"; }
has_port() { [ -n "$(port_of)" ]; }
wait_for 60 has_port || fail "no console: $(cat "$work/master.err")"
api="http://127.0.0.1:$(port_of)"
post() { curl -s -o "$work/answer" -w '%{http_code}' -X POST -d "$1" "$api/layer"; }
# The newest frame of channel a, and its centre pixel.
latest() { find "$work/l" -name 'channel-a-*.png' | sort | tail -n 1; }
centre() { pixel "$(latest)" 16 16; }
newer() { [ "$(latest)" != "$1" ]; }
shows() { # shows R G B TOLERANCE: a frame drawn after now shows it
  local f
  f=$(latest)
  wait_for 30 newer "$f" || return 1
  read -r r g b < <(centre)
  near "$r" "$g" "$b" "$1" "$2" "$3" "$4"
}
has_frame() { [ -n "$(latest)" ]; }
wait_for 60 has_frame || fail "no frame: $(cat "$work/master.err")"
curl -s "$api/status" | grep -qF '"name":"monthly"' || fail "no layers in the status"
[ "$(post '{"layer": "monthly", "time": "2024-04-01"}')" = 202 ] || fail "time: $(cat "$work/answer")"
wait_for 30 shows 240 230 20 3 || fail "not April after /layer: $(centre)"
grep -qF '"time":"2024-04-01"' <<<"$(curl -s "$api/status")" || fail "the status has no April"
[ "$(post '{"layer": "monthly", "visible": false}')" = 202 ] || fail "hide: $(cat "$work/answer")"
hidden() { read -r r g b < <(centre); ! near "$r" "$g" "$b" 240 230 20 40; }
wait_for 30 hidden || fail "still April when hidden: $(centre)"
read -r br bg bb < <(centre) # the Blue Marble beneath
[ "$(post '{"layer": "monthly", "visible": true, "opacity": 0.5}')" = 202 ] ||
  fail "half: $(cat "$work/answer")"
half() { shows $(((240 + br) / 2)) $(((230 + bg) / 2)) $(((20 + bb) / 2)) 4; }
wait_for 30 half || fail "not half April over the base: $(centre) (base $br $bg $bb)"
for bad in '{"layer": "nope", "opacity": 1}|no drawn layer nope (drawn: bluemarble, monthly)' \
  '{"layer": "monthly", "time": "2024-05-01"}|monthly has no time 2024-05-01' \
  '{"layer": "bluemarble", "opacity": 0.5}|bluemarble is the base layer'; do
  [ "$(post "${bad%%|*}")" = 400 ] && grep -qF "${bad#*|}" "$work/answer" ||
    fail "not refused: ${bad%%|*}: $(cat "$work/answer")"
done
kill -TERM "$(rank_pid "$job" 0)" # the master ends the show
wait "$job" || fail "the show did not end well: $(cat "$work/master.err")"
job=
for ch in a b; do
  cmp -s "$work/l/digest-master.txt" "$work/l/digest-$ch.txt" ||
    fail "channel $ch drew other states than the console's"
done
echo "ok"
