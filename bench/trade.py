#!/usr/bin/env python3
"""bench/trade.sh's helper: the renders' statistics and images, and tellus_trade_geometry's
geometric errors, into bench/trade/trade.csv and the plots bench/trade/*.png.

Usage: trade.py RUNS_DIR OUT_DIR   (RUNS_DIR: manifest.tsv, VIEW-NAME.json and .png per render;
OUT_DIR: geometry.csv already written there)
"""
import csv
import json
import math
import os
import statistics
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

SETTLED = 15  # the last frames of each run: the view settled (see trade.sh)
PSNR_CAP = 99.0  # identical images (infinite PSNR) are plotted and written as this

DEFAULTS = {"threshold": "1", "mesh": "33", "earth": "wgs84", "geoid": "on",
            "vertices": "double", "upload": "8388608"}
KNOBS = [
    ("threshold", ["0.5", "1", "2", "4"]),
    ("mesh", ["9", "17", "33", "65"]),
    ("earth", ["wgs84", "sphere"]),
    ("geoid", ["on", "off"]),
    ("vertices", ["double", "float"]),
    ("upload", ["524288", "2097152", "8388608", "33554432"]),
]


def load_png(path):
    img = mpimg.imread(path)  # float in [0, 1]
    return np.round(img[:, :, :3] * 255.0).astype(np.float64)


def psnr(a, b):
    mse = float(np.mean((a - b) ** 2))
    return PSNR_CAP if mse == 0.0 else min(PSNR_CAP, 10.0 * math.log10(255.0 ** 2 / mse))


def main():
    runs, out = sys.argv[1], sys.argv[2]
    geometry = list(csv.DictReader(open(os.path.join(out, "geometry.csv"))))

    def geo(kind, surface, view, level=None, n=None):
        for g in geometry:
            if g["kind"] == kind and g["surface"] == surface and g["view"] == view and (
                    level is None or int(g["level"]) == level) and (n is None or int(g["n"]) == n):
                return float(g["max_m"])
        return float("nan")

    manifest = [line.rstrip("\n").split("\t") for line in open(os.path.join(runs, "manifest.tsv"))]
    by = {}
    for view, name, _args in manifest:
        by[(view, name)] = name
    rows = []
    views = []
    for view, _name, _args in manifest:
        if view not in views:
            views.append(view)
    for view in views:
        ref = load_png(os.path.join(runs, f"{view}-reference.png"))
        default = load_png(os.path.join(runs, f"{view}-default.png"))
        for knob, values in KNOBS:
            for value in values:
                name = "default" if value == DEFAULTS[knob] else f"{knob}={value}"
                if (view, name) not in by:
                    continue
                s = json.load(open(os.path.join(runs, f"{view}-{name}.json")))
                frames = s["frame_times_ms"]
                updates = s["update_times_ms"]
                settled = frames[-SETTLED:]
                img = load_png(os.path.join(runs, f"{view}-{name}.png"))
                settings = dict(DEFAULTS)
                settings[knob] = value
                n = int(settings["mesh"])
                level = int(s["max_level"])
                chord = geo("chord", "terrain", view, level, n)
                if math.isnan(chord):
                    chord = geo("chord", "ellipsoid", view, level, n)
                model = 0.0
                if settings["earth"] == "sphere":
                    model += geo("sphere", "ellipsoid", view)
                if settings["geoid"] == "off":
                    model += geo("geoid", "terrain", view)
                if settings["vertices"] == "float":
                    model += geo("float", "ellipsoid", view)
                rows.append({
                    "view": view, "knob": knob, "value": value,
                    "default": int(value == DEFAULTS[knob]),
                    "update_ms": round(statistics.median(updates[-SETTLED:]), 3),
                    "frame_ms": round(statistics.median(settled), 2),
                    "frame_cpu_ms": round(statistics.median(s.get("frame_cpu_ms", frames)[-SETTLED:]),
                                          2),
                    "seconds_to_complete": round(s["seconds"] - sum(settled) / 1000.0, 3),
                    "frames_to_complete": len(frames) - SETTLED,
                    "longest_frame_ms": round(max(frames[:-SETTLED]), 1),
                    "nodes_drawn": s["nodes_drawn"], "max_level": level,
                    "tiles": s["tiles_received"], "bytes": s["bytes_received"],
                    "height_tiles": s["height_tiles_received"],
                    "mib_uploaded": round(s["bytes_uploaded"] / 2 ** 20, 1),
                    "psnr_db": round(psnr(img, ref), 2),
                    "psnr_vs_default_db": round(psnr(img, default), 2),
                    "mesh_error_m": round(chord, 3),
                    "model_error_m": round(model, 3),
                    "geometric_error_m": round(chord + model, 3),
                })
    fields = list(rows[0].keys())
    with open(os.path.join(out, "trade.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)

    # Plots: per knob, frame time against image error and against geometric error, one line per
    # view, points labelled with the knob's value (the default ringed).
    fig, axes = plt.subplots(2, len(KNOBS), figsize=(3.2 * len(KNOBS), 6.0), dpi=80)
    colours = {"global": "tab:blue", "alps": "tab:orange", "low": "tab:green"}
    for col, (knob, _values) in enumerate(KNOBS):
        for row, (metric, label) in enumerate([("psnr_db", "PSNR vs reference (dB)"),
                                               ("geometric_error_m", "geometric error (m)")]):
            ax = axes[row][col]
            for view in views:
                pts = [r for r in rows if r["view"] == view and r["knob"] == knob]
                x = [r["frame_cpu_ms"] if knob != "upload" else r["seconds_to_complete"]
                     for r in pts]
                y = [r[metric] for r in pts]
                ax.plot(x, y, "o-", color=colours.get(view), label=view, markersize=4)
                for r, xi, yi in zip(pts, x, y):
                    ax.annotate(r["value"] if knob != "upload" else
                                f"{int(r['value']) >> 20 or int(r['value']) >> 10}"
                                f"{'M' if int(r['value']) >= 2 ** 20 else 'K'}",
                                (xi, yi), fontsize=7, xytext=(3, 3), textcoords="offset points")
                    if r["default"]:
                        ax.plot([xi], [yi], "o", mfc="none", mec="black", markersize=9)
            if metric == "geometric_error_m":
                ax.set_yscale("symlog", linthresh=0.1)
            ax.set_xlabel("s to complete" if knob == "upload" else "frame CPU ms (llvmpipe)",
                          fontsize=8)
            if col == 0:
                ax.set_ylabel(label, fontsize=8)
            if row == 0:
                ax.set_title(knob, fontsize=9)
            ax.tick_params(labelsize=7)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "trade.png"))

    # The chord error of an n-vertex node by level (the ellipsoid and the terrain, the low view).
    fig, ax = plt.subplots(figsize=(6.0, 4.0), dpi=80)
    for n, c in zip([9, 17, 33, 65], ["tab:red", "tab:orange", "tab:green", "tab:blue"]):
        for surface, style in [("ellipsoid", "--"), ("terrain", "-")]:
            pts = [g for g in geometry if g["kind"] == "chord" and g["view"] == "low"
                   and g["surface"] == surface and int(g["n"]) == n]
            if pts:
                ax.plot([int(g["level"]) for g in pts], [float(g["max_m"]) for g in pts],
                        style, color=c, label=f"{n} vertices, {surface}", marker=".")
    ax.set_yscale("log")
    ax.set_xlabel("node level (36-degree level zero), node containing 46.5 N, 8 E (the low view)")
    ax.set_ylabel("largest mesh error (m)")
    ax.legend(fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "chord.png"))
    print(f"trade.py: {len(rows)} rows in {out}/trade.csv; plots trade.png, chord.png")


if __name__ == "__main__":
    main()
