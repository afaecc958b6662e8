#!/usr/bin/env python3
"""Converts one month of the COADS sea-surface-temperature climatology that Debian's
ferret-datasets ships (NOAA, public domain) into the small Int16 GeoTIFF that tellus bundles as a
layer of values (issue 24): 2-degree cells, hundredths of a degree Celsius, land no-data.

    apt-get download ferret-datasets && dpkg -x ferret-datasets_7.6.0-5_all.deb x
    tools/sst_from_coads.py x/usr/share/ferret-vis/data/coads_climatology.cdf 1 \\
        data/sst_coads_jan_int16.tif

Run once; the output is committed (data/README.md gives its provenance and checksum). Needs the
GDAL command-line tools (gdal_translate, package gdal-bin) to read the netCDF and to write the
TIFF; the samples are rearranged here with the standard library only (no numpy).

The source variable SST[TIME=12][COADSY=90][COADSX=180] is Float32 degrees C, cell centres at
21 E, 23 E, ... 379 E and 89 S .. 89 N, missing value -1e34 over land (and where COADS has no
observations). GDAL reads it north row first. The output:
- columns start at the antimeridian (-180..180, centre of column 0 at 179 W): the source's
  columns rolled by 80;
- raw = round(100 x degrees C) as Int16 (value = raw x 0.01), -32768 where the source is missing;
- Deflate-compressed GeoTIFF, EPSG:4326, pixel-is-area, with a world file (.tfw) beside it,
  which is what tellus's local upstream reads.
"""

import math
import os
import struct
import subprocess
import sys
import tempfile

COLS, ROWS = 180, 90
STEP = 2.0
ROLL = 80  # output column i is source column (i + ROLL) % COLS: lon -179 = 181 E = 21 E + 80 x 2
MISSING_ABOVE = 1e30  # the source's missing value is -1e34 (|v| above this)
NO_DATA = -32768
SCALE = 100.0


def read_month(cdf, month):
    with tempfile.TemporaryDirectory() as tmp:
        raw = os.path.join(tmp, "sst.bil")
        subprocess.run(
            ["gdal_translate", "-q", "-of", "EHdr", "-ot", "Float32", "-b", str(month),
             f"NETCDF:{cdf}:SST", raw],
            check=True,
        )
        with open(os.path.join(tmp, "sst.hdr")) as f:
            header = dict(line.split(None, 1) for line in f if line.strip())
        if (int(header["NROWS"]), int(header["NCOLS"])) != (ROWS, COLS):
            sys.exit(f"unexpected grid {header['NROWS']} x {header['NCOLS']}")
        if float(header["ULXMAP"]) != 21.0 or float(header["ULYMAP"]) != 89.0:
            sys.exit(f"unexpected origin {header['ULXMAP']}, {header['ULYMAP']}")
        order = "<" if header.get("BYTEORDER", "I").strip() == "I" else ">"
        with open(raw, "rb") as f:
            return struct.unpack(f"{order}{ROWS * COLS}f", f.read())


def to_int16(values):
    out = []
    land = 0
    for j in range(ROWS):
        row = values[j * COLS : (j + 1) * COLS]
        for i in range(COLS):
            v = row[(i + ROLL) % COLS]
            if not math.isfinite(v) or abs(v) > MISSING_ABOVE:
                out.append(NO_DATA)
                land += 1
            else:
                if not -5.0 < v < 40.0:
                    sys.exit(f"implausible SST {v} at row {j}, column {i}")
                out.append(int(round(v * SCALE)))
    return out, land


def write_tiff(samples, path):
    with tempfile.TemporaryDirectory() as tmp:
        raw = os.path.join(tmp, "sst.bil")
        with open(raw, "wb") as f:
            f.write(struct.pack(f"<{len(samples)}h", *samples))
        with open(os.path.join(tmp, "sst.hdr"), "w") as f:
            f.write(
                f"BYTEORDER I\nLAYOUT BIL\nNROWS {ROWS}\nNCOLS {COLS}\nNBANDS 1\nNBITS 16\n"
                f"PIXELTYPE SIGNEDINT\nULXMAP {-180 + STEP / 2}\nULYMAP {90 - STEP / 2}\n"
                f"XDIM {STEP}\nYDIM {STEP}\nNODATA {NO_DATA}\n"
            )
        subprocess.run(
            ["gdal_translate", "-q", "-of", "GTiff", "-a_srs", "EPSG:4326",
             "-a_nodata", str(NO_DATA), "-co", "COMPRESS=DEFLATE", "-co", "TFW=YES",
             "-mo", "UNITS=0.01 degree Celsius", raw, path],
            check=True,
        )
    aux = path + ".aux.xml"
    if os.path.exists(aux):
        os.remove(aux)


def main():
    if len(sys.argv) != 4 or not sys.argv[2].isdigit() or not 1 <= int(sys.argv[2]) <= 12:
        sys.exit("usage: sst_from_coads.py coads_climatology.cdf MONTH(1-12) out.tif")
    values = read_month(sys.argv[1], int(sys.argv[2]))
    samples, land = to_int16(values)
    write_tiff(samples, sys.argv[3])
    sea = [s for s in samples if s != NO_DATA]
    print(f"{sys.argv[3]}: {COLS}x{ROWS}, {len(sea)} sea cells ({min(sea) / SCALE:.2f} .. "
          f"{max(sea) / SCALE:.2f} C), {land} no-data")


if __name__ == "__main__":
    main()
