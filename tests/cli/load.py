"""Steady load over several servers until a stop file appears, for tests/cli/test_scale_out_s3.sh
(issue 27): THREADS threads GET the targets in turn, round-robin over the ports. Every 200 body is
checked to be a whole PNG (signature, chunks with good CRCs, IDAT inflating, IEND last). Prints one
JSON line: statuses, per target the distinct 200 bodies (sha256), and how many bodies were torn.
Usage: load.py STOPFILE THREADS PORTS(comma-separated) TARGET [TARGET...]"""
import hashlib
import http.client
import json
import os
import struct
import sys
import threading
import zlib

stop, threads = sys.argv[1], int(sys.argv[2])
ports = [int(p) for p in sys.argv[3].split(",")]
targets = sys.argv[4:]
lock = threading.Lock()
statuses, bodies, torn = {}, {t: set() for t in targets}, [0]


def whole_png(b):
    if not b.startswith(b"\x89PNG\r\n\x1a\n"):
        return False
    i, idat, last = 8, b"", b""
    while i + 8 <= len(b):
        n, kind = struct.unpack(">I4s", b[i:i + 8])
        body = b[i + 8:i + 8 + n]
        crc = b[i + 8 + n:i + 12 + n]
        if len(body) != n or len(crc) != 4:
            return False
        if struct.unpack(">I", crc)[0] != zlib.crc32(kind + body) & 0xFFFFFFFF:
            return False
        if kind == b"IDAT":
            idat += body
        last, i = kind, i + 12 + n
    try:
        zlib.decompress(idat)
    except zlib.error:
        return False
    return last == b"IEND" and i == len(b)


def run(k):
    j = k
    while not os.path.exists(stop):
        target, port = targets[j % len(targets)], ports[(j // len(targets)) % len(ports)]
        j += threads
        try:
            c = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
            c.request("GET", target)
            r = c.getresponse()
            body, status = r.read(), str(r.status)
            c.close()
        except Exception as e:  # noqa: BLE001 - counted, not raised
            body, status = b"", type(e).__name__
        with lock:
            statuses[status] = statuses.get(status, 0) + 1
            if status == "200":
                if whole_png(body):
                    bodies[target].add(hashlib.sha256(body).hexdigest())
                else:
                    torn[0] += 1


ts = [threading.Thread(target=run, args=(k,)) for k in range(threads)]
for t in ts:
    t.start()
for t in ts:
    t.join()
print(json.dumps({"statuses": statuses, "bodies": {t: sorted(b) for t, b in bodies.items()},
                  "torn": torn[0]}))
