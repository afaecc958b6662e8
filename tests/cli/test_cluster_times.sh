#!/usr/bin/env bash
# `tellus cluster` with a flight whose keyframes switch a layer's time (issue 28; labels gl and
# integration: run under xvfb-run): the master broadcasts where along --path the layer times are
# taken and every channel switches the layer as `tellus render --path` does. The layer is a WMS
# upstream whose every time is a solid colour of its own (time_upstream.py); with
# --wait-complete each channel's frames show January until the keyframe at 0.5 s, March from it,
# and the channels' digests equal the master's. A keyframe naming a layer that is not drawn is a
# usage error (a path the console loads with "times" gets a 400: test_cluster_live.sh). KEEP=1
# keeps the work folder.
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd)
data=$(cd "$here/../../data" && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-cluster-times.XXXXXX")
upstream_pid=
cleanup() {
  [ -n "$upstream_pid" ] && kill "$upstream_pid" 2>/dev/null || true
  [ -n "${KEEP:-}" ] || rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
pixel() { python3 "$here/png_pixels.py" "$@"; }
near() { python3 -c "import sys; v=list(map(int,sys.argv[1:7])); t=int(sys.argv[7]); sys.exit(0 if all(abs(a-b)<=t for a,b in zip(v[:3],v[3:])) else 1)" "$@"; }
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 # CI runs as root

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
echo "ok"
