"""A sample VESA MPCDI file of a channel configuration (issue 28, docs/design/cluster.md):

    make_mpcdi.py CONFIG.json OUT.mpcdi TEXELS [BLEND_DIR]

Writes OUT.mpcdi, a zip of mpcdi.xml in the "3d" (3D simulation) profile, one region a channel of
CONFIG (its frustum: yaw = -azimuth, pitch = elevation, roll, the angles half the fields of view),
NAME.pfm, the warp that changes nothing (TEXELS x TEXELS * 0.7 texels, each the 3D point 10 m out
along its centre's direction: x right, y up, -z forward), and, with BLEND_DIR, NAME-alpha.png: a
soft edge (255 inside, to 0 over the outer tenth; gammaEmbedded 2.2), also written to BLEND_DIR so
that CONFIG's "blend" can name the same mask. Python's standard library only."""
import json
import math
import os
import struct
import sys
import zipfile
import zlib


def frame(c):
    """Channels.hpp's channelFrame: forward, up, right in dome coordinates."""
    az, el, roll = (math.radians(c.get(k, 0.0)) for k in ("azimuth", "elevation", "roll"))
    forward = [math.cos(el) * math.sin(az), math.cos(el) * math.cos(az), -math.sin(el)]
    up0 = [-math.sin(el) * math.sin(az), -math.sin(el) * math.cos(az), -math.cos(el)]
    cross = lambda a, b: [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                          a[0] * b[1] - a[1] * b[0]]
    right0 = cross(forward, up0)
    up = [math.cos(roll) * up0[i] + math.sin(roll) * right0[i] for i in range(3)]
    n = math.sqrt(sum(v * v for v in up))
    up = [v / n for v in up]
    return forward, up, cross(forward, up)


def pixel_direction(c, px, py):
    """Channels.hpp's channelPixelDirection."""
    forward, up, right = frame(c)
    x = (2 * px / c["width"] - 1) * math.tan(math.radians(c["hfov"]) / 2)
    y = (1 - 2 * py / c["height"]) * math.tan(math.radians(c["vfov"]) / 2)
    d = [forward[i] + x * right[i] + y * up[i] for i in range(3)]
    n = math.sqrt(sum(v * v for v in d))
    return [v / n for v in d]


def pfm(c, w, h):
    rows = []
    for j in range(h):
        row = b""
        for i in range(w):
            d = pixel_direction(c, (i + 0.5) / w * c["width"], (j + 0.5) / h * c["height"])
            # dome (x, y, z) = (-right, forward, -up); the file's x right, y up, -z forward
            row += struct.pack("<3f", -10 * d[0], -10 * d[2], -10 * d[1])
        rows.append(row)
    return b"PF\n%d %d\n-1.0\n" % (w, h) + b"".join(reversed(rows))  # PFM: bottom row first


def png_grey(w, h, value):
    raw = b"".join(b"\0" + bytes(value(x, y) for x in range(w)) for y in range(h))
    chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def soft_edge(c):
    w, h = c["width"], c["height"]
    def value(x, y):
        e = min(1.0, min(x + 0.5, w - x - 0.5) / (0.1 * w), min(y + 0.5, h - y - 0.5) / (0.1 * h))
        return int(round(255 * e))
    return png_grey(w, h, value)


def main():
    config, out, texels = sys.argv[1], sys.argv[2], int(sys.argv[3])
    blend_dir = sys.argv[4] if len(sys.argv) > 4 else None
    channels = json.load(open(config))["channels"]
    regions, sets, files = "", "", {}
    for c in channels:
        n = c["name"]
        w, h = texels, max(2, round(texels * 0.7))
        files[f"{n}.pfm"] = pfm(c, w, h)
        regions += (f'<region id="{n}" x="0" y="0" xsize="1" ysize="1" xResolution="{c["width"]}"'
                    f' yResolution="{c["height"]}"><frustum><yaw>{-c["azimuth"]}</yaw>'
                    f'<pitch>{c["elevation"]}</pitch><roll>{c.get("roll", 0)}</roll>'
                    f'<rightAngle>{c["hfov"] / 2}</rightAngle><leftAngle>{-c["hfov"] / 2}'
                    f'</leftAngle><upAngle>{c["vfov"] / 2}</upAngle><downAngle>{-c["vfov"] / 2}'
                    f"</downAngle></frustum></region>\n")
        alpha = ""
        if blend_dir:
            files[f"{n}-alpha.png"] = soft_edge(c)
            with open(os.path.join(blend_dir, f"{n}-alpha.png"), "wb") as f:
                f.write(files[f"{n}-alpha.png"])
            alpha = (f"<alphaMap><path>{n}-alpha.png</path><componentDepth>1</componentDepth>"
                     "<bitDepth>8</bitDepth><gammaEmbedded>2.2</gammaEmbedded></alphaMap>")
        sets += (f'<fileset region="{n}"><geometryWarpFile><path>{n}.pfm</path>'
                 "<geometricUnit>m</geometricUnit><originOf3DData>idealEyePoint</originOf3DData>"
                 f"<interpolation>linear</interpolation></geometryWarpFile>{alpha}</fileset>\n")
    files["mpcdi.xml"] = ('<?xml version="1.0" encoding="utf-8"?>\n'
                          '<MPCDI profile="3d" geometry="1" version="2.0">\n<display>'
                          '<buffer id="dome" xResolution="1" yResolution="1">\n' + regions +
                          "</buffer></display>\n<files>\n" + sets + "</files>\n</MPCDI>\n").encode()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in files.items():
            z.writestr(name, data)


main()
