"""A WMS upstream with a TIME dimension for tests/cli/test_animate.sh (issue 24, time that plays):
every GetMap answers a PNG of one solid colour per TIME (listed below), so that a render shows
which time each frame is at; a GetMap without TIME, or at a time not listed, gets 400 (tellus must
never ask for a time the layer does not declare). Every request is logged to LOGFILE, one query
string a line. Usage: time_upstream.py PORTFILE LOGFILE (binds 127.0.0.1 on a free port, writes
the port to PORTFILE, serves until killed). TIME_UPSTREAM_DELAY_MS in the environment delays
every answer (a slow upstream, to see fetching ahead at work). Standard library only."""
import os
import struct
import sys
import threading
import time
import zlib
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from urllib.parse import parse_qsl, urlsplit

COLOURS = {
    "2024-01-01": (220, 30, 30),
    "2024-02-01": (30, 200, 40),
    "2024-03-01": (40, 60, 230),
    "2024-04-01": (240, 230, 20),
}
LOCK = threading.Lock()
DELAY_S = float(os.environ.get("TIME_UPSTREAM_DELAY_MS", "0")) / 1000.0


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

    def do_GET(self):
        query = urlsplit(self.path).query
        with LOCK, open(sys.argv[2], "a") as log:
            log.write(query + "\n")
        q = {k.upper(): v for k, v in parse_qsl(query)}
        colour = COLOURS.get(q.get("TIME", ""))
        if q.get("REQUEST", "").lower() != "getmap" or colour is None:
            self.send_response(400)
            self.end_headers()
            return
        time.sleep(DELAY_S)
        body = png(int(q.get("WIDTH", "64")), int(q.get("HEIGHT", "64")), colour)
        self.send_response(200)
        self.send_header("Content-Type", "image/png")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)


class Server(ThreadingHTTPServer):
    # socketserver's backlog of 5 drops connections when the renderer opens 32 at once (SYNs
    # lost: curl waits and retries), which looked like a failing upstream.
    request_queue_size = 128
    daemon_threads = True


if __name__ == "__main__":
    server = Server(("127.0.0.1", 0), Handler)
    with open(sys.argv[1], "w") as f:
        f.write(str(server.server_address[1]))
    server.serve_forever()
