"""A World Wind tile upstream for tests/cdn/test_varnish.sh: every GET answers a 256-px PNG whose
colour depends on the query (so tiles differ), with a strong ETag of the query, unless the file
FAILFILE exists, then 500; an If-None-Match naming that ETag gets 304 and no body. Every request is
logged to LOGFILE, one query string a line (" 304" after it when so answered). Usage:
tile_upstream.py PORTFILE LOGFILE FAILFILE (binds 127.0.0.1 on a free port, writes the port to
PORTFILE, serves until killed). Standard library only."""
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
            h = zlib.crc32(query.encode())
            etag = '"%08x"' % h
            not_modified = (self.headers.get("If-None-Match") == etag
                            and not os.path.exists(failfile))
            with LOCK, open(logfile, "a", encoding="utf-8") as log:
                log.write(query + (" 304" if not_modified else "") + "\n")
            if not_modified:
                self.send_response(304)
                self.send_header("ETag", etag)
                self.end_headers()
                return
            if os.path.exists(failfile):
                body = b"down"
                self.send_response(500)
                self.send_header("Content-Type", "text/plain")
            else:
                body = png(256, 256, (h & 255, (h >> 8) & 255, (h >> 16) & 255))
                self.send_response(200)
                self.send_header("Content-Type", "image/png")
                self.send_header("ETag", etag)
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
