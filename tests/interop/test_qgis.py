#!/usr/bin/python3
"""Interoperability: QGIS (Debian 12's python3-qgis and qgis-providers, 3.22) headless (Qt's
offscreen platform) reads tellus serve's WMTS capabilities through its "wms" provider, as a QGIS
user adding a WMTS layer does, and renders maps with QgsMapRendererParallelJob; their pixels are
compared with the tiles: in the layer's own World Wind set, a map of level 0's tile over Africa
is the cached tile (the same pixels); in GoogleMapsCompatible (EPSG:3857 map), a map of one zoom-3
tile's extent is tellus's composed tile (QGIS draws the tiles it fetched with its own resampling:
close, and far from the neighbouring tile). Everything on loopback: QGIS's profile and network cache
in a fresh folder, nothing fetched from elsewhere.

Usage: test_qgis.py path/to/tellus
"""
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.request


def fail(message):
    print("FAIL: " + message, file=sys.stderr)
    sys.exit(1)


def green_difference(a, b, size, step):
    """Mean |difference| of the green channel of two QImages over every step-th pixel."""
    total = count = 0
    for y in range(0, size, step):
        for x in range(0, size, step):
            total += abs(((a.pixel(x, y) >> 8) & 255) - ((b.pixel(x, y) >> 8) & 255))
            count += 1
    return total / count


def render(layer, crs, extent, size):
    from qgis.core import (QgsCoordinateReferenceSystem, QgsMapRendererParallelJob,
                           QgsMapSettings, QgsRectangle)
    from qgis.PyQt.QtCore import QSize
    settings = QgsMapSettings()
    settings.setLayers([layer])
    settings.setDestinationCrs(QgsCoordinateReferenceSystem(crs))
    settings.setExtent(QgsRectangle(*extent))
    settings.setOutputSize(QSize(size, size))
    job = QgsMapRendererParallelJob(settings)
    job.start()
    job.waitForFinished()
    errors = [e.message for e in job.errors()]
    if errors:
        fail("QGIS rendering %s: %s" % (crs, errors))
    return job.renderedImage()


def check(base, cache, work):
    from qgis.core import QgsRasterLayer
    from qgis.PyQt.QtGui import QImage
    capabilities = base + "/wmts/1.0.0/WMTSCapabilities.xml"
    uri = ("contextualWMSLegend=0&crs=%s&dpiMode=7&format=image/jpeg&layers=bluemarble"
           "&styles=default&tileMatrixSet=%s&url=" + capabilities)
    own = QgsRasterLayer(uri % ("EPSG:4326", "WorldWind_bluemarble"), "own", "wms")
    if not own.isValid():
        fail("QGIS does not take bluemarble in WorldWind_bluemarble from %s" % capabilities)
    # Level 0, tile row 2 (from the south), column 5: lon 0..36, lat -18..18, 512 px.
    image = render(own, "EPSG:4326", (0, -18, 36, 18), 512)
    cached = [os.path.join(root, f) for root, _, files in os.walk(cache) for f in files
              if f == "2_5.jpg"]
    if not cached:
        fail("no cached tile 2_5.jpg")
    tile = QImage(cached[0])
    other = QImage([os.path.join(root, f) for root, _, files in os.walk(cache) for f in files
                    if f == "3_5.jpg"][0])
    same, wrong = green_difference(image, tile, 512, 2), green_difference(image, other, 512, 2)
    print("own set: mean |green difference| %.2f against the cached tile, %.2f against the tile "
          "north of it" % (same, wrong))
    if not (same < 1.0 and wrong > 10.0):
        fail("own set: QGIS's map is not the cached tile (%.2f, %.2f)" % (same, wrong))
    image.save(os.path.join(work, "qgis-own.png"))

    gm = QgsRasterLayer(uri % ("EPSG:3857", "GoogleMapsCompatible"), "gm", "wms")
    if not gm.isValid():
        fail("QGIS does not take bluemarble in GoogleMapsCompatible")
    half = math.pi * 6378137.0
    z, row, col = 3, 2, 4  # lon 0..45, lat 41.0..66.5
    side = 2 * half / 2 ** z
    west, north = -half + col * side, half - row * side
    image = render(gm, "EPSG:3857", (west, north - side, west + side, north), 256)
    tiles = []
    for c in (col, col + 1):
        url = "%s/wmts/1.0.0/bluemarble/default/GoogleMapsCompatible/%d/%d/%d.jpg" % (base, z, row, c)
        tiles.append(QImage.fromData(urllib.request.urlopen(url, timeout=30).read()))
        if tiles[-1].width() != 256:
            fail("GoogleMapsCompatible tile %s is no 256 px image" % url)
    same, wrong = green_difference(image, tiles[0], 256, 1), green_difference(image, tiles[1], 256, 1)
    print("GoogleMapsCompatible: mean |green difference| %.2f against tellus's tile, %.2f against "
          "the tile east of it" % (same, wrong))
    if not (same < 6.0 and wrong > 4 * same):
        fail("GoogleMapsCompatible: QGIS's map is not tellus's tile (%.2f, %.2f)" % (same, wrong))
    image.save(os.path.join(work, "qgis-gm.png"))


def main():
    tellus = sys.argv[1]
    work = tempfile.mkdtemp(prefix="tellus-qgis.", dir=os.environ.get("TMPDIR"))
    # QGIS's profile, settings and network cache: in the work folder, never the user's.
    os.environ["HOME"] = work
    os.environ["XDG_RUNTIME_DIR"] = work
    os.environ["QT_QPA_PLATFORM"] = "offscreen"
    from qgis.core import QgsApplication
    QgsApplication.setPrefixPath("/usr", True)
    app = QgsApplication([], True)
    app.initQgis()
    cache = os.path.join(work, "cache")
    for bbox in ("1,-17,35,17", "1,37,35,71"):  # level-0 tiles 2/5 (Africa) and 3/5 (Europe)
        subprocess.run([tellus, "seed", "--cache", cache, "--layer", "bluemarble", "--levels", "0",
                        "--bbox", bbox], check=True, stdout=subprocess.DEVNULL)
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
        check("http://127.0.0.1:%s" % port, cache, work)
        print("qgis interop: all checks passed")
    finally:
        server.terminate()
        server.wait(10)
        log.close()
        app.exitQgis()
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
