#!/usr/bin/env python3
"""Opens N keep-alive connections to a server, sends one GET for a tile on each and reads the whole
response, then keeps every socket open (idle) until stdin reaches end of file or HOLD seconds pass.

    idle_conns.py HOST PORT URL_FILE N [HOLD_SECONDS]

Prints "OPEN <n> ok=<200 responses> bytes=<body bytes>" once every connection holds its answer
(the caller then measures the server), and "CLOSED" after closing them. Exit status 1 when a
connection could not be opened or did not get a whole 200 response.
"""
import os
import select
import socket
import sys
import time


def read_response(s: socket.socket) -> tuple[int, int]:
    """Reads one HTTP/1.1 response with a Content-Length; returns (status, body bytes)."""
    buf = b""
    while b"\r\n\r\n" not in buf:
        chunk = s.recv(65536)
        if not chunk:
            raise ConnectionError("closed before the headers ended")
        buf += chunk
    head, _, body = buf.partition(b"\r\n\r\n")
    lines = head.split(b"\r\n")
    status = int(lines[0].split()[1])
    length = 0
    for line in lines[1:]:
        name, _, value = line.partition(b":")
        if name.strip().lower() == b"content-length":
            length = int(value.strip())
    while len(body) < length:
        chunk = s.recv(65536)
        if not chunk:
            raise ConnectionError("closed in the body")
        body += chunk
    return status, len(body)


def main() -> int:
    host, port, url_file, n = sys.argv[1], int(sys.argv[2]), sys.argv[3], int(sys.argv[4])
    hold = float(sys.argv[5]) if len(sys.argv) > 5 else 30.0
    with open(url_file) as f:
        paths = [line.strip() for line in f if line.strip()]
    socks = []
    ok = 0
    total = 0
    failed = 0
    for i in range(n):
        path = paths[i % len(paths)]
        try:
            s = socket.create_connection((host, port), timeout=10)
            s.sendall(f"GET {path} HTTP/1.1\r\nHost: {host}:{port}\r\n\r\n".encode())
            status, size = read_response(s)
            ok += status == 200
            total += size
            socks.append(s)
        except (OSError, ConnectionError, ValueError, IndexError) as e:
            failed += 1
            if failed <= 3:
                print(f"idle_conns: connection {i}: {e}", file=sys.stderr)
    print(f"OPEN {len(socks)} ok={ok} bytes={total}", flush=True)
    deadline = time.monotonic() + hold
    while time.monotonic() < deadline:  # until the caller closes our stdin, or HOLD seconds
        r, _, _ = select.select([sys.stdin], [], [], max(0.0, deadline - time.monotonic()))
        if r and not os.read(sys.stdin.fileno(), 4096):
            break
    for s in socks:
        s.close()
    print("CLOSED", flush=True)
    return 0 if failed == 0 and ok == n else 1


if __name__ == "__main__":
    sys.exit(main())
