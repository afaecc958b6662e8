"""The synthetic WMS of bench/fetch (issue 29): detail at every level, colours that say where a
texel is and how fine it is, and a count of what was asked of it.

A GetMap (EPSG:4326 or CRS:84, 1.1.1 or 1.3.0, any BBOX, WIDTH, HEIGHT) answers a PNG in which
  R = 255 (lon + 180) / 360, G = 255 (lat + 90) / 180 (pixel centres: neighbouring maps join),
  B = the map's resolution, res = BBOX height / HEIGHT in degrees a texel, as
      round(8 (log2(1 / res) + 4)) (1/8 of a level: res from 16 degrees down to 6e-9 degrees),
  and a graticule: black R and G (B kept) on the meridians and parallels at multiples of the
  spacing 360 / 2^k, the finest k with spacing >= 16 res. Each level of a quadtree halves res and
  brings lines of its own: detail at every level. B is constant in a map, so filtering keeps it:
  a screenshot tells at every pixel the texel size the renderer drew there.
GET /stats answers {"requests": N, "texels": T} (GetMaps since the last /reset, T = sum of
WIDTH x HEIGHT); GET /reset zeroes them. Every answer carries Access-Control-Allow-Origin: *.
Usage: upstream.py PORTFILE [LOG] (binds 127.0.0.1 on a free port, writes the port, serves until
killed; with LOG, appends "west south east north WIDTH HEIGHT" of each GetMap to it, and
"reset" at each /reset)."""
import io
import json
import math
import sys
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from urllib.parse import parse_qsl, urlsplit

from PIL import Image, ImageDraw

LOCK = threading.Lock()
COUNTS = {"requests": 0, "texels": 0}
LOG = open(sys.argv[2], "a") if len(sys.argv) > 2 else None  # a line per GetMap, when asked


def resolution_code(res):
    return max(1, min(255, round(8.0 * (math.log2(1.0 / res) + 4.0))))


def band(values):
    return bytes(max(0, min(255, round(v))) for v in values)


def render(minx, miny, maxx, maxy, width, height):
    resx, resy = (maxx - minx) / width, (maxy - miny) / height
    lons = [minx + (i + 0.5) * resx for i in range(width)]
    lats = [maxy - (j + 0.5) * resy for j in range(height)]
    r = Image.frombytes("L", (width, 1), band(255.0 * (x + 180.0) / 360.0 for x in lons))
    g = Image.frombytes("L", (1, height), band(255.0 * (y + 90.0) / 180.0 for y in lats))
    r = r.resize((width, height), Image.NEAREST)
    g = g.resize((width, height), Image.NEAREST)
    b = Image.new("L", (width, height), resolution_code(resy))
    k = max(0, math.floor(math.log2(360.0 / (16.0 * resy))))
    spacing = 360.0 / (1 << k)
    lines = Image.new("L", (width, height), 255)
    draw = ImageDraw.Draw(lines)
    first = math.ceil(minx / spacing)
    for n in range(first, first + int((maxx - minx) / spacing) + 2):
        x = math.floor((n * spacing - minx) / resx)
        if 0 <= x < width:
            draw.line([(x, 0), (x, height - 1)], fill=0)
    first = math.ceil(miny / spacing)
    for n in range(first, first + int((maxy - miny) / spacing) + 2):
        y = math.floor((maxy - n * spacing) / resy)
        if 0 <= y < height:
            draw.line([(0, y), (width - 1, y)], fill=0)
    black = Image.new("L", (width, height), 0)
    r = Image.composite(r, black, lines)
    g = Image.composite(g, black, lines)
    out = io.BytesIO()
    Image.merge("RGB", (r, g, b)).save(out, "PNG", compress_level=1)
    return out.getvalue()


class Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"

    def log_message(self, *args):
        pass

    def answer(self, status, body, kind):
        self.send_response(status)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Access-Control-Allow-Origin", "*")
        self.end_headers()
        self.wfile.write(body)

    def do_GET(self):
        url = urlsplit(self.path)
        if url.path == "/stats":
            with LOCK:
                return self.answer(200, json.dumps(COUNTS).encode(), "application/json")
        if url.path == "/reset":
            with LOCK:
                COUNTS.update(requests=0, texels=0)
                if LOG:
                    LOG.write("reset\n")
            return self.answer(200, b"{}", "application/json")
        q = {k.upper(): v for k, v in parse_qsl(url.query)}
        if q.get("REQUEST", "").lower() != "getmap":
            return self.answer(400, b"GetMap only", "text/plain")
        try:
            box = [float(v) for v in q["BBOX"].split(",")]
            width, height = int(q["WIDTH"]), int(q["HEIGHT"])
            crs = q.get("CRS", q.get("SRS", "")).upper()
            if q.get("VERSION") == "1.3.0" and crs == "EPSG:4326":
                box = [box[1], box[0], box[3], box[2]]  # lat,lon axis order
            if len(box) != 4 or not (0 < width <= 8192 and 0 < height <= 8192):
                raise ValueError("bad size")
        except (KeyError, ValueError) as e:
            return self.answer(400, f"bad GetMap: {e}".encode(), "text/plain")
        body = render(*box, width, height)
        with LOCK:
            COUNTS["requests"] += 1
            COUNTS["texels"] += width * height
            if LOG:
                LOG.write(f"{box[0]:.9g} {box[1]:.9g} {box[2]:.9g} {box[3]:.9g} {width} {height}\n")
                LOG.flush()
        self.answer(200, body, "image/png")


def main():
    server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    server.daemon_threads = True
    with open(sys.argv[1] + ".tmp", "w") as f:
        f.write(str(server.server_address[1]))
    import os
    os.replace(sys.argv[1] + ".tmp", sys.argv[1])
    server.serve_forever()


if __name__ == "__main__":
    main()
