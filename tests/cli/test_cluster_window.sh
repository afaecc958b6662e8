#!/usr/bin/env bash
# `tellus cluster --window --preview` end to end (issue 28; labels gl and integration: run under
# xvfb-run): three channels, two with curved warp meshes and soft blend masks, shown in windows
# and warped and blended on the GPU, write the same PNGs as the headless run's CPU pass (PSNR at
# least BOUND each), and the windows show those pixels (grabbed from the X server); the master's
# preview window writes preview.png, the domemaster `tellus render
# --dome` draws of the same view (PSNR at least BOUND). Rendered at 1.5 x the projectors' sizes
# (--render-scale), the windows' images are still the CPU pass's. Without a display both are
# refused with a message, as are a preview too small, a scale out of range and an unknown option.
# KEEP=1 keeps the work folder.
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd) # png_pixels.py
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-window.XXXXXX")
trap '[ -n "${KEEP:-}" ] || rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 # CI runs as root
bound=40
cluster() { mpirun --oversubscribe -n 4 "$tellus" cluster "$@"; }
view=(--no-sun --no-atmosphere --no-stars --cache "$work/cache" --background 40,60,120
  --camera 45,7,3e5,0,0 --wait-complete)

# Three channels (north, east with warps and masks; the zenith plain); a warp bows the rows and
# bends the columns (not affine), a mask fades the left and top edges.
python3 - "$work" <<'PY'
import json, math, struct, sys, zlib
work = sys.argv[1]
def png_grey(w, h, value):
    raw = b"".join(b"\0" + bytes(value(x, y) for x in range(w)) for y in range(h))
    chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
def warp(c, r):
    uv = []
    for j in range(r):
        for i in range(c):
            x, y = i / (c - 1), j / (r - 1)
            uv.append([0.08 + 0.84 * x + 0.05 * math.sin(math.pi * y),
                       0.06 + 0.8 * y * y + 0.1 * y + 0.04 * math.sin(math.pi * x)])
    return {"columns": c, "rows": r, "uv": uv}
def mask(w, h):
    def value(x, y):
        e = min(1.0, (x + 0.5) / (0.2 * w)) * min(1.0, (y + 0.5) / (0.2 * h))
        return int(round(255 * e))
    return png_grey(w, h, value)
channels = []
for n, a in (("north", 0), ("east", 90)):
    json.dump(warp(9, 7), open(f"{work}/{n}-warp.json", "w"))
    open(f"{work}/{n}-blend.png", "wb").write(mask(200, 140))
    channels.append({"name": n, "azimuth": a, "elevation": 20, "hfov": 110, "vfov": 90,
                     "width": 200, "height": 140, "warp": f"{n}-warp.json",
                     "blend": f"{n}-blend.png"})
channels.append({"name": "zenith", "azimuth": 0, "elevation": 90, "hfov": 100, "vfov": 100,
                 "width": 140, "height": 140})
json.dump({"channels": channels}, open(f"{work}/dome.json", "w"))
PY

psnr() {
  PYTHONPATH="$here" python3 -c "
import math, sys
from png_pixels import pixels
wa, ha, ra, na = pixels(sys.argv[1]); wb, hb, rb, nb = pixels(sys.argv[2])
assert (wa, ha, na) == (wb, hb, nb), 'sizes differ'
se = sum((x - y) ** 2 for r, s in zip(ra, rb) for x, y in zip(r, s))
print(99.0 if se == 0 else round(10 * math.log10(255 ** 2 * wa * ha * na / se), 2))" "$1" "$2"
}
atleast() { python3 -c "import sys; sys.exit(float(sys.argv[1]) < float(sys.argv[2]))" "$1" "$2"; }

cluster "$work/dome.json" "${view[@]}" --out "$work/cpu" >/dev/null || fail "cluster without --window"
out=$(cluster "$work/dome.json" "${view[@]}" --window --preview 160 --out "$work/gl") ||
  fail "cluster --window --preview: $out"
echo "$out" | grep -q "1 frames of 3 channels" || fail "cluster said: $out"
for n in north east zenith; do
  a="$work/cpu/channel-$n-00000.png" b="$work/gl/channel-$n-00000.png"
  [ -f "$b" ] || fail "no image of channel $n with --window"
  p=$(psnr "$a" "$b")
  echo "channel $n: --window (GPU warp) against the CPU pass: $p dB"
  atleast "$p" "$bound" || fail "channel $n with --window differs from the headless run: $p dB"
done
# The warp did something: north's image is not its unwarped view.
"$tellus" render "${view[@]}" --channel "$work/dome.json,north" --out "$work/north-plain.png" \
  >/dev/null || fail "render --channel"
p=$(psnr "$work/north-plain.png" "$work/gl/channel-north-00000.png")
atleast "$p" 30 && fail "north's warp changed nothing: $p dB"

# What the windows show, grabbed from the X server (Debian's PIL), is each channel's PNG: the
# show looped on the same view, each window raised in turn (no window manager: they overlap at the
# top left) and grabbed once later frames have been swapped into it.
mpirun --oversubscribe -n 4 "$tellus" cluster "$work/dome.json" "${view[@]}" --window --loop \
  --realtime --out "$work/shown" >"$work/shown.out" 2>&1 &
show=$!
frames() { [ -f "$work/shown/digest-master.txt" ] && wc -l <"$work/shown/digest-master.txt" || echo 0; }
until [ "$(frames)" -ge 3 ]; do
  kill -0 $show 2>/dev/null || fail "the looped show ended: $(cat "$work/shown.out")"
  sleep 0.2
done
for n in north east zenith; do
  win=$(timeout 30 xdotool search --sync --name "^tellus cluster: channel $n\$") || fail "no window $n"
  xdotool windowraise "$win"
  seen=$(frames)
  until [ "$(frames)" -ge $((seen + 3)) ]; do sleep 0.1; done
  eval "$(xdotool getwindowgeometry --shell "$win")"
  /usr/bin/python3 - "$work/window-$n.png" "$X" "$Y" "$WIDTH" "$HEIGHT" <<'PY'
import os, sys
from PIL import ImageGrab
x, y, w, h = map(int, sys.argv[2:])
ImageGrab.grab(bbox=(x, y, x + w, y + h), xdisplay=os.environ["DISPLAY"]).save(sys.argv[1])
PY
  p=$(psnr "$work/cpu/channel-$n-00000.png" "$work/window-$n.png")
  echo "channel $n: its window's pixels against the CPU pass: $p dB"
  atleast "$p" "$bound" || fail "channel $n's window shows other pixels: $p dB"
done
for p in $(pgrep -P $show); do # the master ends the show
  grep -qxz "OMPI_COMM_WORLD_RANK=0" "/proc/$p/environ" && kill -TERM "$p"
done
wait $show || fail "the looped show: $(cat "$work/shown.out")"

# Rendered at 1.5 x the projectors' sizes (--render-scale; CONFIG.json's "render" per channel):
# each channel's image is still its projector's size, the GPU's the CPU's (the zenith, without a
# warp, only scaled), and the view the same as at 1 x.
cluster "$work/dome.json" "${view[@]}" --render-scale 1.5 --out "$work/cpu15" >/dev/null ||
  fail "cluster --render-scale 1.5"
cluster "$work/dome.json" "${view[@]}" --render-scale 1.5 --window --out "$work/gl15" >/dev/null ||
  fail "cluster --render-scale 1.5 --window"
for n in north east zenith; do
  p=$(psnr "$work/cpu15/channel-$n-00000.png" "$work/gl15/channel-$n-00000.png")
  q=$(psnr "$work/cpu/channel-$n-00000.png" "$work/cpu15/channel-$n-00000.png")
  echo "channel $n rendered at 1.5 x: --window against the CPU pass $p dB, against 1 x $q dB"
  atleast "$p" "$bound" || fail "channel $n at 1.5 x: --window differs from the CPU pass: $p dB"
  atleast "$q" 25 || fail "channel $n at 1.5 x shows another view than at 1 x: $q dB"
done

# The preview: the domemaster of the same view.
[ -f "$work/gl/preview.png" ] || fail "no preview.png"
"$tellus" render "${view[@]}" --dome --size 160 --out "$work/dome.png" >/dev/null ||
  fail "render --dome"
p=$(psnr "$work/dome.png" "$work/gl/preview.png")
echo "preview against render --dome: $p dB"
atleast "$p" "$bound" || fail "the preview differs from render --dome: $p dB"

# No display: refused with a message.
for opt in --window --preview; do
  set +e
  msg=$(env -u DISPLAY -u WAYLAND_DISPLAY mpirun --oversubscribe -n 4 "$tellus" cluster \
    "$work/dome.json" "${view[@]}" "$opt" --out "$work/u" 2>&1)
  rc=$?
  set -e
  [ $rc -ne 0 ] && echo "$msg" | grep -q -- "$opt opens a window and there is no display" ||
    fail "$opt without a display not refused: $rc $msg"
done
# Refused: a preview too small, an unknown option.
for bad in "--preview=8:--preview=SIZE must be a whole number" "--windows:unknown option --windows" \
  "--render-scale=5:--render-scale must be in [0.25, 4]"; do
  set +e
  msg=$(cluster "$work/dome.json" "${view[@]}" "${bad%%:*}" --out "$work/u" 2>&1)
  rc=$?
  set -e
  [ $rc -ne 0 ] && echo "$msg" | grep -qF -- "${bad#*:}" || fail "${bad%%:*} not refused: $rc $msg"
done
echo "ok"
