#!/usr/bin/python3
"""Interoperability: OWSLib (Debian's python3-owslib) reads tellus serve's capabilities in WMS
1.1.1 and 1.3.0 and fetches tile-aligned maps through its GetMap, as a Python user would; every
advertised format for every layer, and EXCEPTIONS=BLANK in 8-bit PNG.

Usage: test_owslib.py path/to/tellus
"""
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import time

from owslib.wms import WebMapService


def fail(message):
    print("FAIL: " + message, file=sys.stderr)
    sys.exit(1)


def main():
    tellus = sys.argv[1]
    work = tempfile.mkdtemp(prefix="tellus-owslib.", dir=os.environ.get("TMPDIR"))
    cache = os.path.join(work, "cache")
    # Level 0 tile 2/5 (Africa) of bluemarble and the etopo tile over the Himalaya.
    subprocess.run([tellus, "seed", "--cache", cache, "--layer", "bluemarble", "--levels", "0",
                    "--bbox", "1,-17,35,17"], check=True, stdout=subprocess.DEVNULL)
    log = open(os.path.join(work, "serve.txt"), "w+")
    server = subprocess.Popen([tellus, "serve", "--cache", cache, "--listen", "127.0.0.1:0"],
                              stdout=log, stderr=subprocess.STDOUT)
    try:
        port = None
        for _ in range(100):
            log.seek(0)
            m = re.search(r"listening on http://127\.0\.0\.1:(\d+)", log.read())
            if m:
                port = m.group(1)
                break
            time.sleep(0.05)
        if not port:
            fail("tellus serve did not start")
        url = "http://127.0.0.1:%s/wms" % port
        tile = None
        composed = None
        for version in ("1.1.1", "1.3.0"):
            wms = WebMapService(url, version=version, timeout=10)
            names = set(wms.contents)
            if not {"bluemarble", "etopo"} <= names:
                fail("%s: layers %s" % (version, sorted(names)))
            layer = wms["bluemarble"]
            # OWSLib normalises both versions' bounding boxes to (minx, miny, maxx, maxy) lon/lat.
            if tuple(round(v) for v in layer.boundingBoxWGS84) != (-180, -90, 180, 90):
                fail("%s: bluemarble bounding box %s" % (version, layer.boundingBoxWGS84))
            if "image/jpeg" not in wms.getOperationByName("GetMap").formatOptions:
                fail("%s: GetMap formats %s" % (version, wms.getOperationByName("GetMap").formatOptions))
            # The level-0 tile over Africa: lon 0..36, lat -18..18, given in lon/lat order. OWSLib
            # swaps the axes itself for 1.3.0 EPSG:4326 (lat/lon): unswapped, the box would be
            # another box (composed, not the tile). Both versions must give the cached tile's bytes.
            response = wms.getmap(layers=["bluemarble"], styles=[""], srs="EPSG:4326",
                                  bbox=(0, -18, 36, 18), size=(512, 512), format="image/jpeg")
            body = response.read()
            if body[:3] != b"\xff\xd8\xff":
                fail("%s: GetMap did not return a JPEG: %r" % (version, body[:200]))
            if tile is None:
                tile = body
            elif body != tile:
                fail("1.1.1 and 1.3.0 GetMap gave different bytes")
            # A box that is no tile, composed from the cached tile: a 400x320 PNG, and the same
            # bytes through both versions (the axis order of each is honoured).
            response = wms.getmap(layers=["bluemarble"], styles=[""], srs="EPSG:4326",
                                  bbox=(5, -10, 30, 10), size=(400, 320), format="image/png")
            body = response.read()
            if body[:8] != b"\x89PNG\r\n\x1a\n":
                fail("%s: composed GetMap did not return a PNG: %r" % (version, body[:300]))
            width, height = struct.unpack(">II", body[16:24])
            if (width, height) != (400, 320):
                fail("%s: composed map is %dx%d" % (version, width, height))
            if composed is None:
                composed = body
            elif body != composed:
                fail("1.1.1 and 1.3.0 composed maps differ")
            # Every advertised format for every layer (the list is service-wide): the heights
            # layer as a JPEG picture, the imagery as BIL16 luminance.
            formats = wms.getOperationByName("GetMap").formatOptions
            for f in ("image/jpeg", "image/png", "image/png; mode=8bit", "application/bil16",
                      "image/tiff"):
                if f not in formats:
                    fail("%s: %s is not advertised: %s" % (version, f, formats))
            body = wms.getmap(layers=["etopo"], styles=[""], srs="EPSG:4326",
                              bbox=(60, 10, 100, 40), size=(80, 60), format="image/jpeg").read()
            if body[:3] != b"\xff\xd8\xff":
                fail("%s: heights as image/jpeg: %r" % (version, body[:300]))
            body = wms.getmap(layers=["bluemarble"], styles=[""], srs="EPSG:4326",
                              bbox=(5, -10, 30, 10), size=(64, 32),
                              format="application/bil16").read()
            if len(body) != 64 * 32 * 2 or max(struct.unpack("<2048h", body)) > 255:
                fail("%s: imagery as application/bil16: %r" % (version, body[:300]))
            # image/tiff: heights alone are Int16 heights, imagery a picture.
            body = wms.getmap(layers=["bluemarble"], styles=[""], srs="EPSG:4326",
                              bbox=(5, -10, 30, 10), size=(64, 32), format="image/tiff").read()
            if body[:4] not in (b"II*\x00", b"MM\x00*"):
                fail("%s: imagery as image/tiff: %r" % (version, body[:300]))
            # EXCEPTIONS=BLANK (each version's spelling) in 8-bit PNG: an image, never XML.
            blank = "BLANK" if version == "1.3.0" else "application/vnd.ogc.se_blank"
            body = wms.getmap(layers=["bluemarble"], styles=[""], srs="EPSG:3857",
                              bbox=(5, -10, 30, 10), size=(64, 32), format="image/png; mode=8bit",
                              transparent=True, exceptions=blank).read()
            if body[:8] != b"\x89PNG\r\n\x1a\n" or body[25] != 3:
                fail("%s: BLANK in image/png; mode=8bit: %r" % (version, body[:300]))
        cached = [os.path.join(root, f) for root, _, files in os.walk(cache) for f in files
                  if f == "2_5.jpg"]
        if not cached or open(cached[0], "rb").read() != tile:
            fail("GetMap did not answer the cached tile's bytes")
        print("owslib interop: all checks passed")
    finally:
        server.terminate()
        server.wait(10)
        log.close()
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
