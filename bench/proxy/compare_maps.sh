#!/usr/bin/env bash
# Whether two tellus binaries compose the same JPEG maps: seeds the bundled Blue Marble (levels
# 0-2) once, serves that cache with both, asks each for the same maps (N random boxes as
# compose_cpu.sh's, 1024x768, plus six edge cases: across the antimeridian, past a pole, the
# whole world, odd sizes, a magnified one) and compares the answers byte for byte, then decoded
# (PSNR and largest difference per map that differs). Needs python3 with numpy and PIL.
#
#   bench/proxy/compare_maps.sh OLD_TELLUS NEW_TELLUS [N]
set -euo pipefail
a=$1
b=$2
n=${3:-40}
work="$(mktemp -d "${TMPDIR:-/tmp}/tellus-compare.XXXXXX")"
pa=
pb=
cleanup() {
  [ -n "$pa" ] && kill "$pa" 2>/dev/null
  [ -n "$pb" ] && kill "$pb" 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT
"$a" seed --cache "$work/cache" --layer bluemarble --levels 0-2 >/dev/null
"$a" serve --cache "$work/cache" --listen 127.0.0.1:0 >"$work/a.txt" 2>&1 &
pa=$!
"$b" serve --cache "$work/cache" --listen 127.0.0.1:0 >"$work/b.txt" 2>&1 &
pb=$!
for f in a b; do
  for _ in $(seq 100); do grep -q "listening on" "$work/$f.txt" && break; sleep 0.1; done
done
porta=$(grep "listening on" "$work/a.txt" | grep -o "127.0.0.1:[0-9]*" | head -n 1 | cut -d: -f2)
portb=$(grep "listening on" "$work/b.txt" | grep -o "127.0.0.1:[0-9]*" | head -n 1 | cut -d: -f2)
python3 - "$porta" "$portb" "$n" <<'PY'
import io, random, sys, urllib.request
import numpy as np
from PIL import Image
pa, pb, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
random.seed(42)
boxes = []
for _ in range(n):
    span = 10 + random.random() * 80
    w = -180 + random.random() * (360 - span)
    hs = span * 0.75
    s = -90 + random.random() * (180 - hs)
    boxes.append((s, w, s + hs, w + span, 1024, 768))
boxes += [(20, 160, 70, 210, 1024, 768), (-100, -30, 10, 80, 1024, 768),
          (45, -170, 95, -100, 1024, 768), (-90, -180, 90, 180, 1024, 512),
          (10.3, 20.7, 31.1, 47.9, 1023, 767), (0, 0, 1, 1, 333, 271)]
same = 0
worst_psnr = None
worst_max = 0
sizes = []
for (s, w, nn, e, W, H) in boxes:
    q = ("/wms?SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=bluemarble&STYLES=&CRS=EPSG:4326"
         f"&BBOX={s:.6f},{w:.6f},{nn:.6f},{e:.6f}&WIDTH={W}&HEIGHT={H}&FORMAT=image/jpeg")
    da = urllib.request.urlopen(f"http://127.0.0.1:{pa}{q}").read()
    db = urllib.request.urlopen(f"http://127.0.0.1:{pb}{q}").read()
    sizes.append(len(da))
    if da == db:
        same += 1
        continue
    ia = np.asarray(Image.open(io.BytesIO(da)).convert("RGB"), dtype=np.float64)
    ib = np.asarray(Image.open(io.BytesIO(db)).convert("RGB"), dtype=np.float64)
    mse = ((ia - ib) ** 2).mean()
    psnr = 99.0 if mse == 0 else 10 * np.log10(255 ** 2 / mse)
    diff = int(np.abs(ia - ib).max())
    worst_psnr = psnr if worst_psnr is None else min(worst_psnr, psnr)
    worst_max = max(worst_max, diff)
    print(f"differs: BBOX={s:.6f},{w:.6f},{nn:.6f},{e:.6f} {W}x{H}: PSNR {psnr:.2f} dB, largest difference {diff}")
print(f"{len(boxes)} maps ({sum(sizes) // len(sizes)} bytes on average): {same} byte-identical", end="")
if worst_psnr is not None:
    print(f"; the others: lowest PSNR {worst_psnr:.2f} dB, largest difference {worst_max}")
else:
    print()
PY
