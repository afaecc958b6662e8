"""A World Wind tile upstream for tests/cdn/test_varnish.sh: every GET answers a 256-px PNG whose
colour depends on the query (so tiles differ), unless the file FAILFILE exists, then 500. Every
request is logged to LOGFILE, one query string a line. Usage: tile_upstream.py PORTFILE LOGFILE
FAILFILE (binds 127.0.0.1 on a free port, writes the port to PORTFILE, serves until killed).
Standard library only."""
import os
import struct
import sys
import threading
import zlib
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from urllib.parse import urlsplit

LOCK = threading.Lock()


def png(w, h, rgb):
    raw = b"".join(b"\x00" + bytes(rgb) * w for _ in range(h))

    def chunk(kind, body):
        c = struct.pack(">I", len(body)) + kind + body
        return c + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def main():
    portfile, logfile, failfile = sys.argv[1:4]

    class Handler(BaseHTTPRequestHandler):
        protocol_version = "HTTP/1.1"

        def log_message(self, *args):
            pass

        def do_GET(self):
            query = urlsplit(self.path).query
            with LOCK, open(logfile, "a", encoding="utf-8") as log:
                log.write(query + "\n")
            if os.path.exists(failfile):
                body = b"down"
                self.send_response(500)
                self.send_header("Content-Type", "text/plain")
            else:
                h = zlib.crc32(query.encode())
                body = png(256, 256, (h & 255, (h >> 8) & 255, (h >> 16) & 255))
                self.send_response(200)
                self.send_header("Content-Type", "image/png")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

    server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    with open(portfile + ".tmp", "w", encoding="utf-8") as f:
        f.write(str(server.server_address[1]))
    os.replace(portfile + ".tmp", portfile)
    server.serve_forever()


if __name__ == "__main__":
    main()
