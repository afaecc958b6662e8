#!/usr/bin/env bash
# `tellus view` driven as a user does (label gl: run under xvfb-run; needs xdotool): the window
# opens, P writes a screenshot, a drag and the wheel change the view, a double-click flies to the
# point under the cursor, Esc quits with exit 0.
set -euo pipefail
tellus=$1
here=$(cd "$(dirname "$0")" && pwd)
command -v xdotool >/dev/null || { echo "xdotool missing (tools/debian-packages.txt)" >&2; exit 1; }
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-view.XXXXXX")
pid=
cleanup() { [ -n "$pid" ] && kill "$pid" 2>/dev/null; [ -n "${TELLUS_TEST_KEEP:-}" ] || rm -rf "$work"; }
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

cd "$work"
# A fixed scene time (the default is now): the camera over the day side whenever the test runs.
"$tellus" view --no-atmosphere --cache "$work/cache" --size 320x200 --camera 0,0,2e7 --time 2024-03-20T12:00:00Z \
  >"$work/out.txt" 2>&1 &
pid=$!
win=$(timeout 30 xdotool search --sync --pid "$pid" --name '^tellus') || fail "no window: $(cat "$work/out.txt")"
win=$(echo "$win" | head -1)
xdotool windowfocus --sync "$win" || true
hold() { xdotool keydown "$1"; sleep 0.3; xdotool keyup "$1"; }
shot() { # waits for the n-th screenshot
  hold p
  for _ in $(seq 300); do [ -s "$work/tellus-$1.png" ] && return 0; sleep 0.1; done # 30 s: frames are slow under load
  fail "screenshot $1 not written: $(cat "$work/out.txt")"
}
sleep 3 # the level-zero textures stream in
shot 1
# Drag from the middle to the right: the globe turns.
xdotool mousemove --window "$win" 160 100 mousedown 1
for x in 180 200 220 240; do sleep 0.1; xdotool mousemove --window "$win" $x 100; done
sleep 0.2
xdotool mouseup 1
sleep 1
shot 2
cmp -s tellus-1.png tellus-2.png && fail "dragging changed nothing"
# The wheel zooms in.
for _ in 1 2 3 4 5; do xdotool click --window "$win" 4; sleep 0.1; done
sleep 2
shot 3
cmp -s tellus-2.png tellus-3.png && fail "the wheel changed nothing"
# A double-click right of the centre flies there: east of where the camera was, three times closer.
title_num() { xdotool getwindowname "$win" | python3 -c "import re,sys; t=sys.stdin.read(); m=re.search(r'(-?[0-9.]+), (-?[0-9.]+)  ([0-9]+) m', t); print(m.group(int(sys.argv[1])) if m else 'none')" "$1"; }
sleep 1
lon0=$(title_num 2); alt0=$(title_num 3)
[ "$lon0" != none ] || fail "no camera in the title: $(xdotool getwindowname "$win")"
xdotool mousemove --window "$win" 250 100 click --repeat 2 --delay 80 1
for _ in $(seq 300); do grep -q "fly to" "$work/out.txt" && break; sleep 0.1; done
grep -q "fly to" "$work/out.txt" || fail "a double-click did not fly: $(cat "$work/out.txt")"
sleep 3
lon1=$(title_num 2); alt1=$(title_num 3)
python3 -c "import sys; l0,l1,a0,a1=map(float,sys.argv[1:]); sys.exit(0 if l1>l0 and a1<a0/2 else 1)" \
  "$lon0" "$lon1" "$alt0" "$alt1" || fail "fly-to: lon $lon0 -> $lon1, altitude $alt0 -> $alt1"
# The scene's time (issue 23): L runs it ten times faster, J backwards, K pauses; each says so,
# and the title carries the time and its pace.
hold l
for _ in $(seq 300); do grep -q "^time 2024-03-20T12:.*, x10$" "$work/out.txt" && break; sleep 0.1; done
grep -q "^time 2024-03-20T12:.*, x10$" "$work/out.txt" || fail "L: $(cat "$work/out.txt")"
hold j
for _ in $(seq 300); do grep -q ", x-10$" "$work/out.txt" && break; sleep 0.1; done
grep -q ", x-10$" "$work/out.txt" || fail "J: $(cat "$work/out.txt")"
hold k
for _ in $(seq 300); do grep -q "(paused)" "$work/out.txt" && break; sleep 0.1; done
grep -q "(paused)" "$work/out.txt" || fail "K: $(cat "$work/out.txt")"
sleep 1
xdotool getwindowname "$win" | grep -q "2024-03-20T1[12]:[0-9:]*Z x0" || fail "title: $(xdotool getwindowname "$win")"
hold Escape
for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
kill -0 "$pid" 2>/dev/null && fail "Esc did not quit"
wait "$pid" || fail "tellus view exited with $?"
pid=
grep -q "frames" "$work/out.txt" || fail "output: $(cat "$work/out.txt")"

# --earth: an unknown model is a usage error (exit 2); the sphere opens and draws.
set +e
"$tellus" view --no-atmosphere --cache "$work/cache" --earth flat >"$work/earth.txt" 2>&1
rc=$?
set -e
[ $rc -eq 2 ] && grep -q "wgs84 or sphere" "$work/earth.txt" ||
  fail "--earth flat: exit $rc, $(cat "$work/earth.txt")"
"$tellus" view --no-atmosphere --cache "$work/cache" --size 160x100 --earth sphere --exit-after 3 \
  >"$work/sphere.txt" 2>&1 || fail "--earth sphere: $(cat "$work/sphere.txt")"
grep -q "3 frames" "$work/sphere.txt" || fail "--earth sphere: $(cat "$work/sphere.txt")"
# Layer keys (issue #7): with an overlay, its digit hides it and shows it again, - lowers its opacity,
# ; lowers its deepest level.
"$tellus" view --no-atmosphere --cache "$work/cache" --size 160x100 --camera 0,0,2e7 --overlay bluemarble,0.5 \
  >"$work/layers.txt" 2>&1 &
pid=$!
win=$(timeout 30 xdotool search --sync --pid "$pid" --name '^tellus') || fail "no window: $(cat "$work/layers.txt")"
win=$(echo "$win" | head -1)
xdotool windowfocus --sync "$win" || true
# Each key once the one before has answered (under load a frame takes seconds; keys pressed
# within one frame are answered together).
for _ in $(seq 300); do xdotool getwindowname "$win" | grep -q " fps " && break; sleep 0.1; done
# (the embedded default's night lights are layer 1, issue 23: the --overlay is layer 2)
n=0
for k in 2 2 minus semicolon; do
  xdotool key --window "$win" "$k"
  n=$((n + 1))
  for _ in $(seq 300); do [ "$(grep -c "^layer 2 " "$work/layers.txt")" -ge $n ] && break; sleep 0.1; done
done
hold Escape
for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
wait "$pid" || fail "tellus view with an overlay exited with $?: $(cat "$work/layers.txt")"
pid=
grep -q "layer 2 bluemarble: hidden, opacity 0.5, levels 3" "$work/layers.txt" &&
  grep -q "layer 2 bluemarble: shown, opacity 0.4" "$work/layers.txt" &&
  grep -q "layer 2 bluemarble: shown, opacity 0.4, levels [23] (max 1)" "$work/layers.txt" ||
  fail "layer keys: $(cat "$work/layers.txt")"
# Time that plays (issue 24): --animate plays a daily layer at 4 times a second; the title names
# its time and state, Space pauses it (and says so), ] steps it by hand.
cat >"$work/daily.yaml" <<YAML
cache: {root: $work/dcache}
upstreams:
  - {name: local, type: local, path: $here/../../data/bmng_2048x1024.jpg}
layers:
  - {name: bluemarble, upstream: local, format: image/jpeg, grid: {levels: 2}}
  - name: daily
    upstream: local
    format: image/jpeg
    grid: {level_zero_delta: 36, tile_size: 128, levels: 1}
    time: {period: 2024-01-01/2024-01-31/P1D}
YAML
"$tellus" view --no-atmosphere --no-stars --config "$work/daily.yaml" --size 160x100 --camera 0,0,2e7 \
  --overlay daily,0.5 --animate daily=2024-01-01/2024-01-08/P1D --rate 4 >"$work/anim.txt" 2>&1 &
pid=$!
win=$(timeout 30 xdotool search --sync --pid "$pid" --name '^tellus') || fail "no window: $(cat "$work/anim.txt")"
win=$(echo "$win" | head -1)
xdotool windowfocus --sync "$win" || true
# (the next day's tiles are cut from the raster for the whole globe: under load that takes a while,
# and the layer holds its day meanwhile; the frames and the swaps are CliGl.Animate's and
# AnimationGl's to check)
state="daily 2024-01-0[1-8] \(playing\|holding\)"
for _ in $(seq 300); do xdotool getwindowname "$win" | grep -q "$state" && break; sleep 0.1; done
xdotool getwindowname "$win" | grep -q "$state" ||
  fail "no animation in the title: $(xdotool getwindowname "$win") $(cat "$work/anim.txt")"
# (each key waits for its answer, 30 s: a frame that cuts tiles under load is slow)
said() { for _ in $(seq 300); do [ "$(grep -c "$1" "$work/anim.txt")" -ge "$2" ] && return 0; sleep 0.1; done; return 1; }
xdotool key --window "$win" space
said "animation of layer 1: paused" 1 || fail "Space: $(cat "$work/anim.txt")"
xdotool key --window "$win" 1 # select the overlay (and hide it)
said "layer 1 daily: hidden" 1 || fail "1: $(cat "$work/anim.txt")"
xdotool key --window "$win" bracketright
said "animation of layer 1: paused, time 2024-01-0" 2 || fail "]: $(cat "$work/anim.txt")"
hold Escape
for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
wait "$pid" || fail "tellus view --animate exited with $?: $(cat "$work/anim.txt")"
pid=
# Several bodies (issue 26): with --bodies moon, B orbits the Moon with the eye kept where it was
# (the Earth's day side, the Indian Ocean, now the Moon's scene body, fills the middle), and B
# again the Earth; each renderer says what it orbits, and all draw in the same window.
rm -f "$work"/tellus-*.png
"$tellus" view --no-atmosphere --no-stars --cache "$work/cache" --size 160x100 --camera -20,95,2e7 \
  --time 2024-01-18T03:52:00Z --bodies moon >"$work/bodies.txt" 2>&1 &
pid=$!
orbiting() { # waits for the n-th renderer's line, checks it, and finds its window
  for _ in $(seq 300); do [ "$(grep -c "^tellus view: orbiting" "$work/bodies.txt")" -ge "$1" ] && break; sleep 0.1; done
  [ "$(grep "^tellus view: orbiting" "$work/bodies.txt" | sed -n "$1p")" = "tellus view: orbiting $2" ] ||
    fail "B: want 'orbiting $2': $(cat "$work/bodies.txt")"
  for _ in $(seq 300); do # (the last renderer's window may still be going)
    win=$(xdotool search --pid "$pid" --name '^tellus' 2>/dev/null | tail -1 || true)
    [ -n "$win" ] && xdotool getwindowname "$win" 2>/dev/null | grep -q " fps " && break
    sleep 0.1
  done
  xdotool windowfocus --sync "$win" 2>/dev/null || true
}
press_b() { # B until the n-th renderer says what it orbits (a press lost to a closing window)
  for _ in $(seq 30); do
    [ "$(grep -c "^tellus view: orbiting" "$work/bodies.txt")" -ge "$1" ] && return 0
    xdotool key --window "$win" b 2>/dev/null || true
    for _ in $(seq 30); do [ "$(grep -c "^tellus view: orbiting" "$work/bodies.txt")" -ge "$1" ] && return 0; sleep 0.1; done
  done
}
orbiting 1 "earth; B orbits moon"
first_win=$win
shot 1
mv "$work/tellus-1.png" "$work/before-b.png"
press_b 2
orbiting 2 "moon; B orbits earth"
[ "$win" = "$first_win" ] || fail "B opened another window ($first_win, then $win)"
[ "$(xdotool search --pid "$pid" --name '^tellus' | wc -l)" = 1 ] ||
  fail "B: more than one window: $(xdotool search --pid "$pid" --name '^tellus')"
shot 1
# The middle 16 x 16 pixels before and after B: the same ocean (the quadtree's tiles, then the
# Moon's scene body with the same map), lit, within what their texel sampling leaves.
PYTHONPATH="$here" python3 - "$work/before-b.png" "$work/tellus-1.png" <<'PY' ||
import sys
from png_pixels import pixels
def mean(path):
    w, h, rows, n = pixels(path)
    s = [0, 0, 0]
    for y in range(h // 2 - 8, h // 2 + 8):
        for x in range(w // 2 - 8, w // 2 + 8):
            for c in range(3):
                s[c] += rows[y][x * n + c]
    return [v / 256.0 for v in s]
a, b = mean(sys.argv[1]), mean(sys.argv[2])
print("middle before B %s, after %s" % (a, b))
assert a[2] > 8 and b[2] > 8 and all(abs(p - q) < 8 for p, q in zip(a, b)), (a, b)
PY
  fail "the eye moved with B"
press_b 3
orbiting 3 "earth; B orbits moon"
hold Escape
for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
wait "$pid" || fail "tellus view --bodies exited with $?: $(cat "$work/bodies.txt")"
pid=
echo "view CLI: ok"
