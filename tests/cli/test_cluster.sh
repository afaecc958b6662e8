#!/usr/bin/env bash
# `tellus cluster` end to end (issue 28; labels gl and integration: run under xvfb-run): six
# ranks of mpirun on one machine, the master and five channels (four around at elevation 20, one
# at the zenith, overlapping). The channels put back into a domemaster (cluster_domemaster.py)
# match `tellus render --dome` of the same view; with one channel turned by a degree they do not.
# Frame lock: over a flight of FRAMES frames (the second argument, 20 by default; the issue asks
# 200) every rank's digest of each frame's state is the same. Usage errors: exit 2, a message.
# KEEP=1 keeps the work folder.
set -euo pipefail
tellus=$1
frames=${2:-20}
here=$(cd "$(dirname "$0")" && pwd) # png_pixels.py, cluster_domemaster.py
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-cluster.XXXXXX")
trap '[ -n "${KEEP:-}" ] || rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 # CI runs as root
# The bounds (docs/design/cluster.md; measured on llvmpipe: 41.16 dB over the circle, each
# channel's part 37.1-51.9 dB; the north channel turned by a degree: its part 42.55 -> 37.59 dB).
threshold=40 # the whole circle against the single-machine domemaster (the issue's 40 dB)
part=36      # every channel's part (where it weighs most): no channel's view is off
drop=3       # one channel turned by a degree: its part loses at least this many dB
cluster() { mpirun --oversubscribe -n "$1" "$tellus" cluster "${@:2}"; }
opts=(--no-sun --no-atmosphere --no-stars --cache "$work/cache" --background 40,60,120)
camera=45,7,3e5,0,0 # 300 km over the Alps looking down: the Earth fills the dome but its rim

# dome SCALE NORTH_AZIMUTH: the five channels, SCALE x (100 x 70 around, 70 x 70 at the top).
dome() {
  python3 - "$1" "$2" <<'PY'
import json, sys
s, north = int(sys.argv[1]), float(sys.argv[2])
around = [{"name": n, "azimuth": a, "elevation": 20, "hfov": 110, "vfov": 90,
           "width": 100 * s, "height": 70 * s}
          for n, a in (("north", north), ("east", 90), ("south", 180), ("west", 270))]
top = {"name": "zenith", "azimuth": 0, "elevation": 90, "hfov": 100, "vfov": 100,
       "width": 70 * s, "height": 70 * s}
print(json.dumps({"channels": around + [top]}))
PY
}
dome 4 0 >"$work/dome.json"
dome 4 1 >"$work/off.json"
dome 1 0 >"$work/small.json"

"$tellus" render "${opts[@]}" --dome --size 320 --camera "$camera" --wait-complete \
  --out "$work/ref.png" >/dev/null || fail "the reference domemaster"
out=$(cluster 6 "$work/dome.json" "${opts[@]}" --camera "$camera" --wait-complete --out "$work/c") ||
  fail "cluster: $out"
echo "$out" | grep -q "1 frames of 5 channels" || fail "cluster said: $out"
for n in north east south west zenith; do
  [ -f "$work/c/channel-$n-00000.png" ] || fail "no image of channel $n"
done
measure() { (cd "$here" && python3 cluster_domemaster.py "$work/dome.json" "$1" 0 "$work/ref.png"); }
# "psnr P worst W unseen U north N east E ..." -> the value after a word
value() { echo "$1" | awk -v k="$2" '{for (i = 1; i < NF; i++) if ($i == k) print $(i + 1)}'; }
got=$(measure "$work/c")
echo "channels against the domemaster: $got"
python3 -c "import sys; p, w, u = map(float, sys.argv[1:]); sys.exit(p < $threshold or w < $part or u > 0)" \
  "$(value "$got" psnr)" "$(value "$got" worst)" "$(value "$got" unseen)" ||
  fail "the channels do not make the domemaster: $got"
# The north channel a degree off (rendered turned, put back as configured): its part drops.
cluster 6 "$work/off.json" "${opts[@]}" --camera "$camera" --wait-complete --out "$work/p" \
  >/dev/null || fail "cluster of the turned channel"
off=$(measure "$work/p")
echo "north channel turned by a degree: $off"
python3 -c "import sys; a, b = map(float, sys.argv[1:]); sys.exit(b > a - $drop)" \
  "$(value "$got" north)" "$(value "$off" north)" ||
  fail "a channel a degree off still makes the domemaster: $off"

# Frame lock: a flight of $frames frames at 10 fps, as streamed; every rank's digests equal.
python3 - "$frames" >"$work/path.json" <<'PY'
import json, sys
end = (int(sys.argv[1]) - 1) / 10
print(json.dumps([{"time": 0, "lat": 45, "lon": 7, "alt": 2e6, "heading": 0, "tilt": 0},
                  {"time": end, "lat": 46, "lon": 9, "alt": 1e6, "heading": 20, "tilt": 10}]))
PY
cluster 6 "$work/small.json" "${opts[@]}" --path "$work/path.json" --fps 10 --out "$work/f" \
  >/dev/null || fail "cluster flight"
[ "$(wc -l <"$work/f/digest-master.txt")" -eq "$frames" ] || fail "master digests: $(wc -l <"$work/f/digest-master.txt")"
[ "$(sort -u "$work/f/digest-master.txt" | awk '{print $2}' | sort -u | wc -l)" -gt 1 ] ||
  fail "every frame's state has the same digest"
for n in north east south west zenith; do
  cmp -s "$work/f/digest-master.txt" "$work/f/digest-$n.txt" || fail "channel $n drew other states"
  [ "$(ls "$work/f" | grep -c "^channel-$n-")" -eq "$frames" ] || fail "channel $n: not $frames images"
done

# Warp and blend (a pass after rendering): the identity warp with a white mask changes no byte of
# the north channel; a black mask makes the east channel black.
python3 - "$work" <<'PY'
import json, struct, sys, zlib
work = sys.argv[1]
def png(path, w, h, v):
    raw = b"".join(b"\0" + bytes([v]) * w for _ in range(h))
    chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
    open(path, "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
                           + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
png(f"{work}/white.png", 100, 70, 255)
png(f"{work}/black.png", 100, 70, 0)
json.dump({"columns": 3, "rows": 2, "uv": [[0, 0], [0.5, 0], [1, 0], [0, 1], [0.5, 1], [1, 1]]},
          open(f"{work}/identity.json", "w"))
d = json.load(open(f"{work}/small.json"))
d["channels"][0].update(warp="identity.json", blend="white.png")
d["channels"][1]["blend"] = f"{work}/black.png"
json.dump(d, open(f"{work}/warped.json", "w"))
PY
cluster 6 "$work/small.json" "${opts[@]}" --camera "$camera" --wait-complete --out "$work/w0" >/dev/null ||
  fail "cluster without warps"
cluster 6 "$work/warped.json" "${opts[@]}" --camera "$camera" --wait-complete --out "$work/w1" >/dev/null ||
  fail "cluster with warps"
cmp -s "$work/w0/channel-north-00000.png" "$work/w1/channel-north-00000.png" ||
  fail "the identity warp changed the north channel"
cmp -s "$work/w0/channel-east-00000.png" "$work/w1/channel-east-00000.png" &&
  fail "the black mask did not change the east channel"
PYTHONPATH="$here" python3 -c "
import sys
from png_pixels import pixels
w, h, rows, n = pixels(sys.argv[1])
sys.exit(any(any(r) for r in rows))" "$work/w1/channel-east-00000.png" || fail "east is not black"

# Usage errors: exit 2 and a message naming what is wrong.
set +e
msg=$(cluster 2 "$work/dome.json" --camera "$camera" --out "$work/u" 2>&1)
rc=$?
set -e
[ $rc -ne 0 ] && echo "$msg" | grep -q "mpirun -n 6 (got 2)" || fail "ranks not refused: $rc $msg"
echo '{"channels": [{"name": "a", "azimuth": 0}]}' >"$work/bad.json"
set +e
msg=$(cluster 1 "$work/bad.json" --camera "$camera" --out "$work/u" 2>&1)
rc=$?
set -e
[ $rc -ne 0 ] && echo "$msg" | grep -q "bad.json: channels\[0\]: elevation: missing" ||
  fail "malformed configuration not refused: $rc $msg"
echo "ok"
