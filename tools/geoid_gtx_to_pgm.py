#!/usr/bin/env python3
"""Converts the EGM96 15' geoid grid (PROJ's egm96_15.gtx, Float32 GTX) into a 30' grid in
GeographicLib's PGM format, which GeographicLib::Geoid (and so tellus::Geoid) reads.

    tools/geoid_gtx_to_pgm.py /usr/share/proj/egm96_15.gtx data/egm96-30.pgm

Run once; the output is committed (data/README.md gives its provenance and checksum). Only the
standard library: no numpy, no GDAL.

The 30' grid keeps every other 15' node (decimation, not averaging), so a node of the output holds
the EGM96 value itself, quantised to the PGM's 3 mm step. The 15' nodes that are left out (three in
four) measure what interpolating the coarser grid costs; the figures go into the file's header
(MaxBilinearError, RMSBilinearError) and are printed.

GTX: a 40-byte big-endian header (lat0, lon0, dlat, dlon as doubles; rows, cols as int32), then
rows of big-endian float32 from the south, columns from lon0 eastward.
PGM (GeographicLib): P5, comment lines "# Key value" (Offset and Scale are required), "width
height", "65535", then big-endian uint16 rows from the north (lat 90 first, lat -90 last), columns
from longitude 0 eastward, without a repeated 360 column; height = offset + scale * value.
"""

import hashlib
import math
import struct
import sys

OFFSET = -108.0
SCALE = 0.003
STEP_IN = 0.25  # degrees, the gtx
FACTOR = 2  # 30' out


def read_gtx(path):
    with open(path, "rb") as f:
        raw = f.read()
    lat0, lon0, dlat, dlon, rows, cols = struct.unpack(">4d2i", raw[:40])
    if (lat0, lon0, dlat, dlon, rows, cols) != (-90.0, -180.0, STEP_IN, STEP_IN, 721, 1440):
        sys.exit(f"unexpected gtx grid {lat0} {lon0} {dlat} {dlon} {rows} {cols}")
    values = struct.unpack(f">{rows * cols}f", raw[40 : 40 + 4 * rows * cols])
    if any(not math.isfinite(v) or abs(v) > 200.0 for v in values):
        sys.exit("gtx holds non-finite or implausible values")
    return rows, cols, values


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    src, dst = sys.argv[1], sys.argv[2]
    rows, cols, gtx = read_gtx(src)

    def node(lat_index, lon_index):  # gtx node: lat = -90 + i / 4, lon = -180 + j / 4 (wraps)
        return gtx[lat_index * cols + lon_index % cols]

    step = STEP_IN * FACTOR
    width = int(round(360.0 / step))  # 720
    height = int(round(180.0 / step)) + 1  # 361
    codes = []
    for r in range(height):  # from the north
        i = rows - 1 - r * FACTOR
        for c in range(width):  # from longitude 0
            j = cols // 2 + c * FACTOR
            code = int(round((node(i, j) - OFFSET) / SCALE))
            if not 0 <= code <= 65535:
                sys.exit(f"value {node(i, j)} does not fit the PGM's range")
            codes.append(code)

    def out(r, c):  # decoded output node, row from the north, column from longitude 0 (wraps)
        return OFFSET + SCALE * codes[r * width + c % width]

    # Bilinear interpolation of the output grid at the 15' nodes it dropped.
    worst, sum2, n, worst_at = 0.0, 0.0, 0, None
    quant = 0.0
    for i in range(rows):
        lat = -90.0 + i * STEP_IN
        for j in range(cols):
            lon = (-180.0 + j * STEP_IN) % 360.0
            fy = (90.0 - lat) / step
            fx = lon / step
            r0 = min(int(math.floor(fy)), height - 2)
            c0 = int(math.floor(fx))
            ty, tx = fy - r0, fx - c0
            v = (
                (1 - ty) * ((1 - tx) * out(r0, c0) + tx * out(r0, c0 + 1))
                + ty * ((1 - tx) * out(r0 + 1, c0) + tx * out(r0 + 1, c0 + 1))
            )
            e = abs(v - node(i, j))
            if i % FACTOR == 0 and j % FACTOR == 0:
                quant = max(quant, e)
                continue
            sum2 += e * e
            n += 1
            if e > worst:
                worst, worst_at = e, (lat, -180.0 + j * STEP_IN)
    rms = math.sqrt(sum2 / n)

    header = (
        "P5\n"
        "# Geoid file in PGM format for the GeographicLib::Geoid class\n"
        "# Description WGS84 EGM96, 30-minute grid (every other node of PROJ's egm96_15.gtx)\n"
        "# URL https://earth-info.nga.mil/ (EGM96, NGA/NASA, public domain)\n"
        "# DateTime 2026-11-24 00:00:00\n"
        f"# MaxBilinearError {worst:.3f}\n"
        f"# RMSBilinearError {rms:.3f}\n"
        f"# Offset {OFFSET:.0f}\n"
        f"# Scale {SCALE}\n"
        "# Origin\n"
        "#  made by tellus tools/geoid_gtx_to_pgm.py from Debian proj-data 9.1.1\n"
        "#  /usr/share/proj/egm96_15.gtx\n"
        f"{width} {height}\n"
        "65535\n"
    ).encode("ascii")
    body = struct.pack(f">{len(codes)}H", *codes)
    with open(dst, "wb") as f:
        f.write(header + body)
    print(f"{dst}: {width}x{height}, {len(header) + len(body)} bytes")
    print(f"nodes kept: largest quantisation error {quant * 1000:.2f} mm")
    print(
        f"bilinear at the {n} dropped 15' nodes: max {worst:.3f} m at lat {worst_at[0]} "
        f"lon {worst_at[1]}, rms {rms:.3f} m"
    )
    print(f"sha256 {hashlib.sha256(header + body).hexdigest()}")


if __name__ == "__main__":
    main()
