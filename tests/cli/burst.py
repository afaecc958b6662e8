"""N concurrent GETs of one target spread round-robin over several servers, all let go at once
(a barrier), for tests/cli/test_scale_out.sh (issue 27). Prints one JSON line: the statuses, how
many distinct bodies came back, and latency p50/p99/max in milliseconds. Exits 1 unless every
answer is a 200 and all bodies are the same (what every scale-out test asks of a burst).
Usage: burst.py N TARGET PORT [PORT...]"""
import hashlib
import http.client
import json
import sys
import threading
import time

n, target, ports = int(sys.argv[1]), sys.argv[2], [int(p) for p in sys.argv[3:]]
barrier = threading.Barrier(n)
results = [None] * n


def one(i):
    port = ports[i % len(ports)]
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    conn.connect()  # connected before the barrier: the burst is of requests, not of handshakes
    barrier.wait()
    start = time.monotonic()
    try:
        conn.request("GET", target)
        r = conn.getresponse()
        body = r.read()
        results[i] = (r.status, hashlib.sha256(body).hexdigest(), time.monotonic() - start)
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
bodies = len({r[1] for r in results})
print(json.dumps({
    "statuses": statuses,
    "bodies": bodies,
    "p50_ms": round(lat[len(lat) // 2], 1),
    "p99_ms": round(lat[min(len(lat) - 1, int(len(lat) * 0.99))], 1),
    "max_ms": round(lat[-1], 1),
}))
sys.exit(0 if statuses == {"200": n} and bodies == 1 else 1)
