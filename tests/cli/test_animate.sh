#!/usr/bin/env bash
# Time that plays in `tellus render` (issue 24; label gl: needs an X display): a monthly layer of a
# WMS upstream whose every time is a colour of its own (tests/cli/time_upstream.py), animated over
# a flight with --animate at a rate; with --wait-complete frame n shows the time of n / fps, whole,
# and two runs write the same bytes; the upstream is never asked for a time the layer does not
# declare; bad --animate values are usage errors naming what is wrong.
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd)
data=$(cd "$here/../../data" && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-animate.XXXXXX")
upstream_pid=
cleanup() {
  [ -n "$upstream_pid" ] && kill "$upstream_pid" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
pixel() { python3 "$here/png_pixels.py" "$@"; }
near() { python3 -c "import sys; v=list(map(int,sys.argv[1:7])); t=int(sys.argv[7]); sys.exit(0 if all(abs(a-b)<=t for a,b in zip(v[:3],v[3:])) else 1)" "$@"; }

. "$here/time_upstream.sh"
time_upstream_config "$work/animate.yaml"
cat >"$work/path.json" <<'JSON'
[{"time": 0, "lat": 10, "lon": 20, "alt": 8e6}, {"time": 2, "lat": 10, "lon": 20, "alt": 8e6}]
JSON
render() {
  "$tellus" render --no-sun --no-atmosphere --no-stars --config "$work/animate.yaml" --overlay monthly,1 \
    --path "$work/path.json" --fps 2 --size 64x48 "$@"
}

# 1 time a second at 2 frames a second, once: frames 0-1 January, 2-3 February, 4 March.
render --frames "$work/a" --wait-complete --stats "$work/a.json" \
  --animate monthly=2024-01-01/2024-03-01/P1M --rate 1 --once >"$work/a.txt" || fail "render: $(cat "$work/a.txt")"
grep -q "5 frames.*every frame complete" "$work/a.txt" || fail "$(cat "$work/a.txt")"
want=("220 30 30" "220 30 30" "30 200 40" "30 200 40" "40 60 230")
for n in 0 1 2 3 4; do
  f=$(printf "%s/a/frame_%05d.png" "$work" "$n")
  for xy in "32 24" "26 20" "38 28"; do
    read -r r g b < <(pixel "$f" $xy)
    # shellcheck disable=SC2086
    near "$r" "$g" "$b" ${want[$n]} 3 || fail "frame $n at $xy: $r $g $b, want ${want[$n]}"
  done
done
python3 - "$work/a.json" <<'PY' || fail "the animation in --stats"
import json, sys
s = json.load(open(sys.argv[1]))
layer = s["layers"][1]
a = layer["animation"]
assert layer["time"] == "2024-03-01" and layer["pending_time"] == "", layer
assert a["target"] == "2024-03-01" and a["times"] == 3 and a["steps"] == 3, a
assert a["held_steps"] == 0, a  # --wait-complete: every frame waited for its time
assert a["ahead_max_in_flight"] <= 4, a
assert s["layers"][0]["animation"] is None, s["layers"][0]
PY
# The same flight again, from the cache: the same bytes.
render --frames "$work/b" --wait-complete --animate monthly=2024-01-01/2024-03-01/P1M --rate 1 --once \
  >/dev/null || fail "second render"
for n in 0 1 2 3 4; do
  f=$(printf "frame_%05d.png" "$n")
  cmp -s "$work/a/$f" "$work/b/$f" || fail "$f differs between two runs"
done
# Only declared times were asked for, and nothing past the animation's end (--once).
grep -q "TIME=2024-02-01" "$work/upstream.log" || fail "February never fetched"
if grep -v "TIME=2024-0[123]-01" "$work/upstream.log" | grep -q .; then
  fail "the upstream was asked for another time: $(grep -v 'TIME=2024-0[123]-01' "$work/upstream.log" | head -3)"
fi

# Refused: a time off the layer's grid (named), a layer not drawn, no flight, a bad rate, and
# --rate without --animate.
refused() {
  local want=$1
  shift
  set +e
  "$tellus" render --no-sun --no-atmosphere --no-stars --config "$work/animate.yaml" --overlay monthly,1 --size 64x48 \
    "$@" >"$work/out.txt" 2>"$work/err.txt"
  local rc=$?
  set -e
  [ $rc -eq 2 ] || fail "exit $rc (want 2) for $*: $(cat "$work/err.txt")"
  grep -qF -- "$want" "$work/err.txt" || fail "message for $*: $(cat "$work/err.txt")"
}
flight=(--path "$work/path.json" --frames "$work/x")
refused "does not declare 2024-01-02" "${flight[@]}" --animate monthly=2024-01-01/2024-02-01/P1D
refused "does not declare 2024-05-01" "${flight[@]}" --animate monthly=2024-03-01,2024-05-01
refused "not drawn" "${flight[@]}" --animate bluemarbl=2024-01-01/2024-02-01/P1M
refused "needs a flight" --camera 0,0,1e7 --out "$work/x.png" --animate monthly=2024-01-01/2024-02-01/P1M
refused "--rate must be" "${flight[@]}" --animate monthly=2024-01-01/2024-02-01/P1M --rate 0
refused "--rate needs --animate" "${flight[@]}" --rate 2
refused "LAYER=TIMES" "${flight[@]}" --animate monthly
echo "animate: ok"
