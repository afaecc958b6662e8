"""N concurrent GETs spread round-robin over several servers, all let go at once (a barrier), for
tests/cli/test_scale_out*.sh (issue 27) and bench/peers/burst.sh. Prints one JSON line: the
statuses, how many distinct bodies came back, and latency p50/p99/max in milliseconds. Exits 1
unless every answer is a 200 with an image/* Content-Type and every target's answers have one
body (what every scale-out test asks of a burst).
Usage: burst.py N TARGET PORT [PORT...]
TARGET is a path and query, or @FILE: one per line, request i asks for the (i mod count)-th."""
import hashlib
import http.client
import json
import sys
import threading
import time

n, target, ports = int(sys.argv[1]), sys.argv[2], [int(p) for p in sys.argv[3:]]
targets = [t for t in open(target[1:]).read().split("\n") if t] if target.startswith("@") else [target]
barrier = threading.Barrier(n)
results = [None] * n


def one(i):
    port = ports[i % len(ports)]
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=120)
    conn.connect()  # connected before the barrier: the burst is of requests, not of handshakes
    barrier.wait()
    start = time.monotonic()
    try:
        conn.request("GET", targets[i % len(targets)])
        r = conn.getresponse()
        body = r.read()
        status = r.status if (r.getheader("Content-Type") or "").startswith("image/") else f"{r.status} not an image"
        results[i] = (status, hashlib.sha256(body).hexdigest(), time.monotonic() - start)
    except Exception as e:  # noqa: BLE001 - reported, not raised
        results[i] = (str(e), "", time.monotonic() - start)


threads = [threading.Thread(target=one, args=(i,)) for i in range(n)]
for t in threads:
    t.start()
for t in threads:
    t.join()
lat = sorted(r[2] * 1000.0 for r in results)
statuses = {}
for r in results:
    statuses[str(r[0])] = statuses.get(str(r[0]), 0) + 1
per_target = {}
for i, r in enumerate(results):
    per_target.setdefault(i % len(targets), set()).add(r[1])
bodies = len({r[1] for r in results})
print(json.dumps({
    "statuses": statuses,
    "bodies": bodies,
    "p50_ms": round(lat[len(lat) // 2], 1),
    "p99_ms": round(lat[min(len(lat) - 1, int(len(lat) * 0.99))], 1),
    "max_ms": round(lat[-1], 1),
}))
one_body_each = all(len(b) == 1 for b in per_target.values())
sys.exit(0 if statuses == {"200": n} and one_body_each else 1)
