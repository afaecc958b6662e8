#!/usr/bin/python3
"""Interoperability: OWSLib (Debian's python3-owslib) reads tellus serve's capabilities in WMS
1.1.1 and 1.3.0 and fetches tile-aligned maps through its GetMap, as a Python user would; every
advertised format for every layer, and EXCEPTIONS=BLANK in 8-bit PNG; the elevation layer as a
value layer: its styles' legends (GetLegendGraphic) and GetFeatureInfo; a map in EPSG:3857
against the lon/lat map of the same place. WMTS 1.0.0 through OWSLib's
WebMapTileService: the capabilities (layers, tile matrix sets, the styles and formats), GetTile in
the layer's own World Wind set (the cached tile's bytes, rows counted from the top) and in
WorldCRS84Quad (composed, then kept: the same bytes again).

Usage: test_owslib.py path/to/tellus
"""
import json
import math
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import urllib.request

from owslib.wms import WebMapService
from owslib.wmts import WebMapTileService


def fail(message):
    print("FAIL: " + message, file=sys.stderr)
    sys.exit(1)


def check_value_layer(wms, version):
    """The elevation layer is a value layer (issue 24): queryable, its colour maps as styles with
    legends (GetLegendGraphic PNGs), and GetFeatureInfo answers its height in metres."""
    etopo = wms["etopo"]
    if not int(etopo.queryable) or wms["bluemarble"].queryable and int(wms["bluemarble"].queryable):
        fail("%s: queryable etopo %r, bluemarble %r" % (version, etopo.queryable,
                                                         wms["bluemarble"].queryable))
    if "terrain" not in etopo.styles or "viridis" not in etopo.styles:
        fail("%s: etopo styles %s" % (version, sorted(etopo.styles)))
    legend = etopo.styles["terrain"].get("legend")
    if not legend or "GetLegendGraphic" not in legend:
        fail("%s: terrain's legend URL %r" % (version, legend))
    body = urllib.request.urlopen(legend, timeout=10).read()
    if body[:8] != b"\x89PNG\r\n\x1a\n" or struct.unpack(">II", body[16:24]) != (256, 56):
        fail("%s: the legend is no 256x56 PNG: %r" % (version, body[:100]))
    if "application/json" not in wms.getOperationByName("GetFeatureInfo").formatOptions:
        fail("%s: GetFeatureInfo formats" % version)
    # GetLegendGraphic is declared: 1.1.1's own element, 1.3.0's sld:GetLegendGraphic (SLD 1.1.0).
    try:
        legend_formats = wms.getOperationByName("GetLegendGraphic").formatOptions
    except KeyError:
        fail("%s: GetLegendGraphic is not declared: %s" % (version,
                                                            [op.name for op in wms.operations]))
    if "image/png" not in legend_formats:
        fail("%s: GetLegendGraphic formats %s" % (version, legend_formats))
    # The Himalaya (86.9 E, 28 N) and the Pacific (150 W, 0) in maps of 1 pixel per degree.
    heights = []
    for bbox, xy in (((60, 10, 100, 40), (26, 12)), ((-170, -20, -130, 10), (20, 10))):
        answer = wms.getfeatureinfo(layers=["etopo"], styles=[""], srs="EPSG:4326", bbox=bbox,
                                    size=(40, 30), format="image/png", query_layers=["etopo"],
                                    info_format="application/json", xy=xy).read()
        feature = json.loads(answer)["features"][0]
        if feature["properties"]["unit"] != "m":
            fail("%s: GetFeatureInfo unit %r" % (version, feature))
        heights.append(feature["properties"]["value"])
    if not (heights[0] > 2000 and heights[1] < -3000):
        fail("%s: GetFeatureInfo heights, Himalaya and Pacific: %s" % (version, heights))
    text = wms.getfeatureinfo(layers=["etopo"], styles=[""], srs="EPSG:4326",
                              bbox=(60, 10, 100, 40), size=(40, 30), format="image/png",
                              query_layers=["etopo"], info_format="text/plain",
                              xy=(26, 12)).read().decode()
    if "Layer 'etopo'" not in text or " m\n" not in text:
        fail("%s: GetFeatureInfo text/plain: %r" % (version, text))


def check_web_mercator(wms, version):
    """EPSG:3857 (issue 25) is advertised, and a map in it is the lon/lat map of the same place
    with its rows at the inverse Mercator: both asked through OWSLib as application/bil16 (the
    imagery's luminance, easy to read), the lon/lat one resampled here row by row."""
    if "EPSG:3857" not in wms["bluemarble"].crsOptions:
        fail("%s: EPSG:3857 is not advertised: %s" % (version, wms["bluemarble"].crsOptions))
    radius = 6378137.0
    x = lambda lon: math.radians(lon) * radius
    y = lambda lat: radius * math.asinh(math.tan(math.radians(lat)))
    lat_of = lambda v: math.degrees(math.atan(math.sinh(v / radius)))
    width, height = 250, 300
    merc = wms.getmap(layers=["bluemarble"], styles=[""], srs="EPSG:3857",
                      bbox=(x(5), y(40), x(30), y(70)), size=(width, height),
                      format="application/bil16").read()
    ref = wms.getmap(layers=["bluemarble"], styles=[""], srs="EPSG:4326", bbox=(5, 40, 30, 70),
                     size=(width, height), format="application/bil16").read()
    if len(merc) != width * height * 2 or len(ref) != len(merc):
        fail("%s: EPSG:3857 bil16 map: %r" % (version, merc[:300]))
    merc = struct.unpack("<%dh" % (width * height), merc)
    ref = struct.unpack("<%dh" % (width * height), ref)
    row = lambda m, j: m[j * width:(j + 1) * width]
    diff_mercator = diff_linear = 0.0
    for j in range(10, height - 10):
        lat = lat_of(y(70) - (j + 0.5) * (y(70) - y(40)) / height)
        r = (70 - lat) / 0.1 - 0.5  # the reference's fractional row
        r0 = min(int(math.floor(r)), height - 2)
        f = r - r0
        expected = [a * (1 - f) + b * f for a, b in zip(row(ref, r0), row(ref, r0 + 1))]
        diff_mercator += sum(abs(a - b) for a, b in zip(row(merc, j), expected))
        diff_linear += sum(abs(a - b) for a, b in zip(row(merc, j), row(ref, j)))
    count = (height - 20) * width
    diff_mercator /= count
    diff_linear /= count
    print("%s: EPSG:3857 rows against the lon/lat map: mean |difference| %.2f at the inverse "
          "Mercator, %.2f evenly in latitude" % (version, diff_mercator, diff_linear))
    if not (diff_mercator < 4.0 and diff_linear > 2 * diff_mercator):
        fail("%s: EPSG:3857 rows: mean |difference| %.2f at the inverse Mercator, %.2f evenly in "
             "latitude" % (version, diff_mercator, diff_linear))


def check_wmts(base, tile):
    """OWSLib's WebMapTileService on /wmts: what it reads of the capabilities, and GetTile (KVP)."""
    wmts = WebMapTileService(base + "/wmts", version="1.0.0", timeout=10)
    if wmts.identification.type != "OGC WMTS":
        fail("WMTS: service type %r" % wmts.identification.type)
    if not {"bluemarble", "etopo"} <= set(wmts.contents):
        fail("WMTS: layers %s" % sorted(wmts.contents))
    sets = set(wmts.tilematrixsets)
    if not {"WorldWind_bluemarble", "WorldCRS84Quad", "GoogleMapsCompatible"} <= sets:
        fail("WMTS: tile matrix sets %s" % sorted(sets))
    layer = wmts["bluemarble"]
    if set(layer.tilematrixsetlinks) != {"WorldWind_bluemarble", "WorldCRS84Quad",
                                          "GoogleMapsCompatible"}:
        fail("WMTS: bluemarble's sets %s" % sorted(layer.tilematrixsetlinks))
    if layer.formats != ["image/jpeg"] or "default" not in layer.styles:
        fail("WMTS: formats %s, styles %s" % (layer.formats, layer.styles))
    own = wmts.tilematrixsets["WorldWind_bluemarble"].tilematrix
    if (own["0"].matrixwidth, own["0"].matrixheight, own["0"].tilewidth) != (10, 5, 512):
        fail("WMTS: level 0 of the own set is %sx%s tiles of %s px" % (
            own["0"].matrixwidth, own["0"].matrixheight, own["0"].tilewidth))
    quad = wmts.tilematrixsets["WorldCRS84Quad"].tilematrix["0"]
    if round(quad.scaledenominator, 4) != 279541132.0144 or tuple(quad.topleftcorner) != (-180, 90):
        fail("WMTS: WorldCRS84Quad 0 is %s at %s" % (quad.scaledenominator, quad.topleftcorner))
    limits = layer.tilematrixsetlinks["WorldWind_bluemarble"].tilematrixlimits["0"]
    if (limits.mintilerow, limits.maxtilerow, limits.mintilecol, limits.maxtilecol) != (0, 4, 0, 9):
        fail("WMTS: limits of level 0 %s" % vars(limits))
    # World Wind's level-0 tile row 2 (from the south), column 5 is WMTS row 5 - 1 - 2 = 2.
    body = wmts.gettile(layer="bluemarble", tilematrixset="WorldWind_bluemarble", tilematrix="0",
                        row=2, column=5, format="image/jpeg", style="default").read()
    if body != tile:
        fail("WMTS: GetTile in the own set is not the cached tile: %r" % body[:200])
    composed = []
    for _ in range(2):
        r = wmts.gettile(layer="bluemarble", tilematrixset="WorldCRS84Quad", tilematrix="2",
                         row=1, column=4, format="image/jpeg", style="default")
        composed.append(r.read())
    if composed[0][:3] != b"\xff\xd8\xff" or composed[0] != composed[1]:
        fail("WMTS: WorldCRS84Quad tiles %r, %r" % (composed[0][:100], composed[1][:100]))


def main():
    tellus = sys.argv[1]
    work = tempfile.mkdtemp(prefix="tellus-owslib.", dir=os.environ.get("TMPDIR"))
    cache = os.path.join(work, "cache")
    # Level 0 tile 2/5 (Africa) of bluemarble and the etopo tile over the Himalaya.
    subprocess.run([tellus, "seed", "--cache", cache, "--layer", "bluemarble", "--levels", "0",
                    "--bbox", "1,-17,35,17"], check=True, stdout=subprocess.DEVNULL)
    # And tile 3/5 (lon 0..36, lat 36..72) for the Web Mercator map.
    subprocess.run([tellus, "seed", "--cache", cache, "--layer", "bluemarble", "--levels", "0",
                    "--bbox", "1,37,35,71"], check=True, stdout=subprocess.DEVNULL)
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
            body = wms.getmap(layers=["bluemarble"], styles=[""], srs="EPSG:32633",
                              bbox=(5, -10, 30, 10), size=(64, 32), format="image/png; mode=8bit",
                              transparent=True, exceptions=blank).read()
            if body[:8] != b"\x89PNG\r\n\x1a\n" or body[25] != 3:
                fail("%s: BLANK in image/png; mode=8bit: %r" % (version, body[:300]))
            check_value_layer(wms, version)
            check_web_mercator(wms, version)
        cached = [os.path.join(root, f) for root, _, files in os.walk(cache) for f in files
                  if f == "2_5.jpg"]
        if not cached or open(cached[0], "rb").read() != tile:
            fail("GetMap did not answer the cached tile's bytes")
        check_wmts("http://127.0.0.1:%s" % port, tile)
        print("owslib interop: all checks passed")
    finally:
        server.terminate()
        server.wait(10)
        log.close()
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
