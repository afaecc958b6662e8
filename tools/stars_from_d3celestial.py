#!/usr/bin/env python3
"""Converts d3-celestial's Hipparcos star file (GeoJSON, data/stars.8.json of the npm package
d3-celestial) into tellus's star catalogue (data/stars-hip-6.5.txt, read by
planet/src/StarCatalogue.cpp): one star a line, brightest first,

    HIP  RA_deg  Dec_deg  Vmag  B-V

RA in [0, 360) degrees and Dec in [-90, 90] degrees (ICRS/J2000 as d3-celestial gives them, four
decimals), V magnitude (two decimals), B-V colour index (three decimals, '-' when the source has
none). Lines starting with '#' are comments. Usage:

    tools/stars_from_d3celestial.py stars.8.json data/stars-hip-6.5.txt [--limit 6.5]
"""
import argparse
import json
import math


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("geojson")
    ap.add_argument("out")
    ap.add_argument("--limit", type=float, default=6.5, help="faintest V magnitude kept")
    a = ap.parse_args()
    with open(a.geojson, encoding="utf-8") as f:
        features = json.load(f)["features"]
    rows = []
    for s in features:
        mag = float(s["properties"]["mag"])
        if mag > a.limit:
            continue
        lon, lat = (float(v) for v in s["geometry"]["coordinates"])
        ra = lon % 360.0
        if not (math.isfinite(ra) and -90.0 <= lat <= 90.0):
            raise SystemExit(f"HIP {s['id']}: bad coordinates {lon} {lat}")
        bv = s["properties"].get("bv", "")
        bv = f"{float(bv):.3f}" if bv not in ("", None) else "-"
        rows.append((mag, int(s["id"]), ra, lat, bv))
    rows.sort()
    with open(a.out, "w", encoding="ascii", newline="\n") as f:
        f.write("# tellus star catalogue 1: Hipparcos stars to V = %.1f from d3-celestial 0.7.35\n"
                % a.limit)
        f.write("# (data/stars.8.json, BSD-3-Clause, Olaf Frohn); see data/README.md\n")
        f.write("# HIP RA_deg Dec_deg Vmag B-V   (J2000/ICRS; B-V '-' = unknown)\n")
        for mag, hip, ra, dec, bv in rows:
            f.write(f"{hip} {ra:.4f} {dec:.4f} {mag:.2f} {bv}\n")
    print(f"{len(rows)} stars to V = {a.limit} -> {a.out}")


if __name__ == "__main__":
    main()
