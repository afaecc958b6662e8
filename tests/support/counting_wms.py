"""A WMS upstream that counts what is asked of it (issue 27's scale-out tests): every GetMap answers
the same small PNG of one colour per BBOX (so that two tiles differ and one tile is always the same
bytes), stored uncompressed (every tile of a size is as long), after an adjustable delay.
  GET /stats            {"getmaps": N, "by_bbox": {BBOX: n, ...}}
  GET /delay?ms=N       later GetMaps wait N ms before answering (a slow upstream)
  GET /salt?v=TEXT      later GetMaps answer another colour (a refreshed tile: same size, new bytes)
  anything else         a GetMap (the query is not checked beyond BBOX)
Usage: counting_wms.py PORTFILE (binds 127.0.0.1 on a free port, writes the port to PORTFILE,
serves until killed). Standard library only."""
import hashlib
import json
import struct
import sys
import threading
import time
import zlib
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from urllib.parse import parse_qsl, urlsplit

LOCK = threading.Lock()
STATE = {"getmaps": 0, "by_bbox": {}, "delay_s": 0.0, "salt": ""}


def png(w, h, rgb):
    raw = b"".join(b"\x00" + bytes(rgb) * w for _ in range(h))

    def chunk(kind, body):
        c = struct.pack(">I", len(body)) + kind + body
        return c + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 0))
            + chunk(b"IEND", b""))


class Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"

    def log_message(self, *args):
        pass

    def answer(self, status, body, kind):
        self.send_response(status)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def do_GET(self):
        url = urlsplit(self.path)
        query = {k.upper(): v for k, v in parse_qsl(url.query)}
        if url.path == "/stats":
            with LOCK:
                body = json.dumps({"getmaps": STATE["getmaps"], "by_bbox": STATE["by_bbox"]})
            return self.answer(200, body.encode(), "application/json")
        if url.path == "/delay":
            with LOCK:
                STATE["delay_s"] = float(query.get("MS", "0")) / 1000.0
            return self.answer(200, b"ok", "text/plain")
        if url.path == "/salt":
            with LOCK:
                STATE["salt"] = query.get("V", "")
            return self.answer(200, b"ok", "text/plain")
        bbox = query.get("BBOX", "")
        with LOCK:
            salt = STATE["salt"]
            STATE["getmaps"] += 1
            STATE["by_bbox"][bbox] = STATE["by_bbox"].get(bbox, 0) + 1
            delay = STATE["delay_s"]
        if delay:
            time.sleep(delay)
        w = int(query.get("WIDTH", "64"))
        h = int(query.get("HEIGHT", "64"))
        colour = hashlib.sha256((salt + bbox).encode()).digest()[:3]
        self.answer(200, png(w, h, colour), "image/png")


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
