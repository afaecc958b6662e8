#!/usr/bin/env python3
"""Request every URL of a list exactly once, CONNECTIONS at a time, and print the rate.

    once.py BASE_URL URLS_FILE CONNECTIONS [RESULT]

The cold pass of run.sh's ONLY=mercator (mercator.sh): every tile of the list is composed once by
the server, so a loop that picks URLs at random (wrk with urls.lua) would not do. Each thread keeps
one HTTP/1.1 connection open and takes the next URL of the list until none is left. Prints (and
writes to RESULT) one line:

    RESULT requests=.. duration_us=.. req_s=.. bytes=.. errors=.. p50_us=.. p99_us=..
"""
import http.client
import sys
import threading
import time
import urllib.parse


def main() -> int:
    base, urls_file, connections = sys.argv[1], sys.argv[2], int(sys.argv[3])
    result = sys.argv[4] if len(sys.argv) > 4 else ""
    urls = [u.strip() for u in open(urls_file) if u.strip()]
    host = urllib.parse.urlsplit(base)
    lock = threading.Lock()
    state = {"next": 0, "bytes": 0, "errors": 0}
    latencies: list[float] = []

    def worker() -> None:
        conn = http.client.HTTPConnection(host.hostname, host.port, timeout=120)
        while True:
            with lock:
                i = state["next"]
                state["next"] += 1
            if i >= len(urls):
                break
            t0 = time.perf_counter()
            try:
                conn.request("GET", urls[i])
                r = conn.getresponse()
                body = r.read()
                ok = r.status == 200 and r.getheader("Content-Type", "").startswith("image/")
            except (OSError, http.client.HTTPException):
                conn.close()
                conn = http.client.HTTPConnection(host.hostname, host.port, timeout=120)
                body, ok = b"", False
            dt = time.perf_counter() - t0
            with lock:
                state["bytes"] += len(body)
                state["errors"] += 0 if ok else 1
                latencies.append(dt)
        conn.close()

    threads = [threading.Thread(target=worker) for _ in range(connections)]
    t0 = time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    duration = time.perf_counter() - t0
    latencies.sort()
    pct = lambda p: int(latencies[min(len(latencies) - 1, int(p / 100 * len(latencies)))] * 1e6)
    line = (
        f"RESULT requests={len(urls)} duration_us={int(duration * 1e6)} "
        f"req_s={len(urls) / duration:.1f} bytes={state['bytes']} errors={state['errors']} "
        f"p50_us={pct(50)} p99_us={pct(99)}"
    )
    print(line)
    if result:
        with open(result, "w") as f:
            f.write(line + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
