"""Popping of a flight (issue 23, "No popping"): the change between consecutive frames that the
camera's motion does not explain.

The measure (probe): a flight rendered as streamed (`tellus render --path --frames S`, one renderer
frame per flight frame) with `--probe-frames Q`: before frame k (k >= 1) changes anything, the
renderer draws frame k-1's state (its quadtree, draw list, textures, fades' weights, meshes and
heights) from frame k's camera (Renderer::redrawLast) into Q_k. S_k and Q_k share the camera, so
everything that differs between them is what frame k's update changed: textures that arrived,
fades that advanced, nodes that split or merged, heights that arrived. That is popping, exactly:
what a viewer sees change from one frame to the next, less what the motion of the camera alone
would change (the same state from the new pose).
  P_k(p) = max over R, G, B of |S_k(p) - Q_k(p)|          (0..255, 8-bit RGB)
over the pixels p that Q_k covers: a pixel Q_k leaves as background (the last frame culled that
part of the view: nothing was drawn there) does not count, nor its 8 neighbours (the globe's edge
blends into the background); the flight is rendered with --background 255,0,255, a colour the
globe never takes, so the background is told apart. Per frame: max_p P_k, the 99.9th and 99th
percentiles and the mean of P_k over the counted pixels. Reported: the largest max (max), the
worst frame's 99.9th and 99th percentile, the mean over frames of the per-frame 99.9th percentile
and of the per-frame mean, and the 8 x 8-block form (P_k averaged over 8 x 8-pixel blocks: the
largest block mean; an area that pops against a thin line of pixels), and the largest change
over a 2 x 2-pixel area (max_2x2: the largest min of P_k over any 2 x 2 window; a pop changes an
area, while a one-pixel crack that flickers, the globe's inside seen through a sliver between two
nodes, does not: both configurations show a few such pixels, a renderer defect of its own).

A second, older form (settled): the streamed frames' change less the settled frames' change,
max(0, dS_k - dC_k) per pixel, with C a rendering of the same flight with every frame complete
(--wait-complete). It counts motion over different detail as popping (the streamed frames show
coarser textures than the settled ones, so the same motion changes other pixels), and misses what
the settled frames do too (a split's jump in heights): kept for comparison with older results.
Usage: popping.py STREAMED_DIR PROBE_DIR [SETTLED_DIR]; prints one JSON object."""
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


BACKGROUND = np.array([255, 0, 255])


def counted(q):
    """The pixels of a probe frame drawn over (not background), less the 8 neighbours of any
    background pixel."""
    bg = (q == BACKGROUND).all(axis=2)
    grown = bg.copy()
    grown[1:, :] |= bg[:-1, :]
    grown[:-1, :] |= bg[1:, :]
    grown[:, 1:] |= grown[:, :-1].copy()
    grown[:, :-1] |= grown[:, 1:].copy()
    return ~grown


def popping(streamed, probe):
    s = frames(streamed)
    names = sorted(os.path.basename(f) for f in glob.glob(os.path.join(probe, "frame_*.png")))
    if len(s) < 2 or len(names) != len(s) - 1:
        raise SystemExit("popping.py: %d streamed and %d probe frames" % (len(s), len(names)))
    per = []
    blocks = 0.0
    for k in range(1, len(s)):
        q = np.asarray(Image.open(os.path.join(probe, names[k - 1])).convert("RGB"), dtype=np.int16)
        p = change(s[k], q)
        m = counted(q)
        if not m.any():
            continue
        v = p[m]
        pm = np.where(m, p, 0)
        area = np.minimum(np.minimum(pm[:-1, :-1], pm[1:, :-1]), np.minimum(pm[:-1, 1:], pm[1:, 1:]))
        per.append((int(v.max()), float(np.percentile(v, 99.9)), float(np.percentile(v, 99)), float(v.mean()),
                    int(area.max())))
        blocks = max(blocks, float(block8(np.where(m, p, 0).astype(float)).max()))
    worst = max(range(len(per)), key=lambda k: per[k][1])
    return {
        "frames": len(s),
        "counted_frames": len(per),
        "max": max(x[0] for x in per),
        "max_2x2": max(x[4] for x in per),
        "p999_worst": max(x[1] for x in per),
        "p99_worst": max(x[2] for x in per),
        "p999_mean": sum(x[1] for x in per) / len(per),
        "mean_mean": sum(x[3] for x in per) / len(per),
        "worst_frame": worst + 1,
        "block8_max": blocks,
        "frames_max_over_32": sum(1 for x in per if x[0] > 32),
    }


def settled_form(streamed, settled):
    """The older form: max(0, dS_k - dC_k), its largest value and mean 99.9th percentile."""
    s, c = frames(streamed), frames(settled)
    if len(s) != len(c) or len(s) < 2:
        raise SystemExit("popping.py: %d streamed and %d settled frames" % (len(s), len(c)))
    per = []
    for k in range(1, len(s)):
        p = np.maximum(0, change(s[k], s[k - 1]) - change(c[k], c[k - 1]))
        per.append((int(p.max()), float(np.percentile(p, 99.9))))
    return {"settled_max": max(x[0] for x in per), "settled_p999_mean": sum(x[1] for x in per) / len(per)}


if __name__ == "__main__":
    r = popping(sys.argv[1], sys.argv[2])
    if len(sys.argv) > 3:
        r.update(settled_form(sys.argv[1], sys.argv[3]))
    print(json.dumps(r))
