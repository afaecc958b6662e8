"""Popping of a flight (issue 23, "No popping"): the change between consecutive frames as streamed
that the same frames settled do not show, i.e. not explained by camera motion.

For frames k = 1..N-1 of two renderings of one flight, S (as streamed: one renderer frame per
flight frame) and C (settled: each frame rendered to completion, --wait-complete), 8-bit RGB:
  dS_k(p) = max over R, G, B of |S_k(p) - S_(k-1)(p)|   (what a viewer sees change at pixel p)
  dC_k(p) = max over R, G, B of |C_k(p) - C_(k-1)(p)|   (the change the camera's motion explains)
  P_k(p)  = max(0, dS_k(p) - dC_k(p))                   (popping, 0..255)
Per frame: max_p P_k and the 99.9th and 99th percentiles of P_k over the pixels. Reported: the
worst frame's value of each (the largest over k), and the mean over k of the per-frame 99.9th
percentile. A second, area form (block8): dS and dC averaged over 8 x 8-pixel blocks before the
subtraction, Pb_k = max(0, mean8(dS_k) - mean8(dC_k)), its largest value over blocks and frames:
a texture or a height that pops changes whole blocks, while the residue of motion over different
detail (the streamed frames show coarser textures than the settled ones, so the same motion
changes other pixels) is thin lines that the block mean dilutes.
Held frames (hold): the frames k whose settled frames do not change at all (dC_k = 0 everywhere:
the camera holds still, as at the end of bench/paths/descent_low.json), where every change of the
streamed frames is popping: the largest P_k and the worst frame's 99.9th percentile over them.
Usage: popping.py STREAMED_DIR SETTLED_DIR [label]; prints one JSON object."""
import glob
import json
import os
import sys

import numpy as np
from PIL import Image


def frames(d):
    files = sorted(glob.glob(os.path.join(d, "frame_*.png")))
    return [np.asarray(Image.open(f).convert("RGB"), dtype=np.int16) for f in files]


def change(a, b):
    return np.abs(a - b).max(axis=2)


def block8(a):
    h, w = a.shape
    return a[: h // 8 * 8, : w // 8 * 8].reshape(h // 8, 8, w // 8, 8).mean(axis=(1, 3))


def popping(streamed, settled):
    s, c = frames(streamed), frames(settled)
    if len(s) != len(c) or len(s) < 2:
        raise SystemExit("popping.py: %d streamed and %d settled frames" % (len(s), len(c)))
    per = []
    blocks = 0.0
    held = []
    for k in range(1, len(s)):
        ds, dc = change(s[k], s[k - 1]), change(c[k], c[k - 1])
        p = np.maximum(0, ds - dc)
        per.append((int(p.max()), float(np.percentile(p, 99.9)), float(np.percentile(p, 99))))
        if dc.max() == 0:
            held.append(per[-1])
        blocks = max(blocks, float(np.maximum(0.0, block8(ds.astype(float)) - block8(dc.astype(float))).max()))
    worst = max(range(len(per)), key=lambda k: per[k][1])
    return {
        "frames": len(s),
        "max": max(x[0] for x in per),
        "p999_worst": max(x[1] for x in per),
        "p99_worst": max(x[2] for x in per),
        "p999_mean": sum(x[1] for x in per) / len(per),
        "worst_frame": worst + 1,
        "block8_max": blocks,
        "held_frames": len(held),
        "held_max": max((x[0] for x in held), default=0),
        "held_p999_worst": max((x[1] for x in held), default=0.0),
    }


if __name__ == "__main__":
    r = popping(sys.argv[1], sys.argv[2])
    if len(sys.argv) > 3:
        r["label"] = sys.argv[3]
    print(json.dumps(r))
