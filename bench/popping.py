"""Popping of a flight (issue 23, "No popping"): the change between consecutive frames as streamed
that the same frames settled do not show, i.e. not explained by camera motion.

For frames k = 1..N-1 of two renderings of one flight, S (as streamed: one renderer frame per
flight frame) and C (settled: each frame rendered to completion, --wait-complete), 8-bit RGB:
  dS_k(p) = max over R, G, B of |S_k(p) - S_(k-1)(p)|   (what a viewer sees change at pixel p)
  dC_k(p) = max over R, G, B of |C_k(p) - C_(k-1)(p)|   (the change the camera's motion explains)
  P_k(p)  = max(0, dS_k(p) - dC_k(p))                   (popping, 0..255)
Per frame: max_p P_k and the 99.9th and 99th percentiles of P_k over the pixels. Reported: the
worst frame's value of each (the largest over k), and the mean over k of the per-frame 99.9th
percentile. Usage: popping.py STREAMED_DIR SETTLED_DIR [label]; prints one JSON object."""
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


def popping(streamed, settled):
    s, c = frames(streamed), frames(settled)
    if len(s) != len(c) or len(s) < 2:
        raise SystemExit("popping.py: %d streamed and %d settled frames" % (len(s), len(c)))
    per = []
    for k in range(1, len(s)):
        p = np.maximum(0, change(s[k], s[k - 1]) - change(c[k], c[k - 1]))
        per.append((int(p.max()), float(np.percentile(p, 99.9)), float(np.percentile(p, 99))))
    worst = max(range(len(per)), key=lambda k: per[k][1])
    return {
        "frames": len(s),
        "max": max(x[0] for x in per),
        "p999_worst": max(x[1] for x in per),
        "p99_worst": max(x[2] for x in per),
        "p999_mean": sum(x[1] for x in per) / len(per),
        "worst_frame": worst + 1,
    }


if __name__ == "__main__":
    r = popping(sys.argv[1], sys.argv[2])
    if len(sys.argv) > 3:
        r["label"] = sys.argv[3]
    print(json.dumps(r))
