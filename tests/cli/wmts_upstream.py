"""A fake NASA GIBS WMTS for tests/cli/test_wmts.sh: serves the real GIBS capabilities document
saved in tests/data/wmts (its http://map1.vis.earthdata.nasa.gov/wmts-geo rewritten to this
server), and tiles in GIBS's layout, RESTful (/wmts-geo/<layer>/default/<time>/<set>/<matrix>/
<row>/<col>.png) and KVP (/wmts-geo/wmts.cgi?SERVICE=WMTS&REQUEST=GetTile&...). Every tile is a
512 x 512 PNG of one colour made from (time, matrix, row, col), also written to TILEDIR as
<time>_<matrix>_<row>_<col>.png so that the test can compare bytes. TIME 2000-01-01 answers 500.
Every request's path and query is logged to LOGFILE, one a line.
Usage: wmts_upstream.py CAPABILITIES PORTFILE LOGFILE TILEDIR. Standard library only."""
import hashlib
import os
import struct
import sys
import threading
import zlib
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from urllib.parse import parse_qsl, urlsplit

LOCK = threading.Lock()
CAPS, PORTFILE, LOGFILE, TILEDIR = sys.argv[1:5]


def png(w, h, rgb):
    raw = b"".join(b"\x00" + bytes(rgb) * w for _ in range(h))

    def chunk(kind, body):
        return (struct.pack(">I", len(body)) + kind + body +
                struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))
    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw)) +
            chunk(b"IEND", b""))


class Handler(BaseHTTPRequestHandler):
    def log_message(self, *args):
        pass

    def reply(self, status, body=b"", kind="text/plain"):
        self.send_response(status)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def do_GET(self):
        parts = urlsplit(self.path)
        with LOCK, open(LOGFILE, "a") as log:
            log.write(self.path + "\n")
        if parts.path == "/wmts-geo/1.0.0/WMTSCapabilities.xml":
            with open(CAPS, encoding="utf-8") as f:
                text = f.read().replace("http://map1.vis.earthdata.nasa.gov/wmts-geo",
                                        "http://127.0.0.1:%d/wmts-geo" % self.server.server_port)
            return self.reply(200, text.encode(), "application/xml")
        if parts.path == "/wmts-geo/wmts.cgi":
            q = {k.upper(): v for k, v in parse_qsl(parts.query)}
            if q.get("REQUEST") != "GetTile":
                return self.reply(400, b"bad request")
            key = (q.get("TIME", ""), q.get("TILEMATRIX"), q.get("TILEROW"), q.get("TILECOL"))
        else:
            p = parts.path.split("/")  # "", wmts-geo, layer, default, time, set, matrix, row, col
            if len(p) != 9 or not p[8].endswith(".png"):
                return self.reply(404, b"no such tile")
            key = (p[4], p[6], p[7], p[8][:-4])
        if key[0] == "2000-01-01":
            return self.reply(500, b"upstream trouble")
        digest = hashlib.sha1("/".join(key).encode()).digest()
        body = png(512, 512, digest[:3])
        with open(os.path.join(TILEDIR, "_".join(key) + ".png"), "wb") as f:
            f.write(body)
        self.reply(200, body, "image/png")


server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
with open(PORTFILE + ".tmp", "w") as f:
    f.write(str(server.server_port))
os.rename(PORTFILE + ".tmp", PORTFILE)
server.serve_forever()
