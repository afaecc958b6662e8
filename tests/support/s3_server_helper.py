#!/usr/bin/python3
"""Helpers of s3-server.sh, run with Debian's /usr/bin/python3 (where the swift package is).

  s3_server_helper.py rings ETC OBJ_PORT CONTAINER_PORT ACCOUNT_PORT
      the three rings (one device each, one replica) in one process: swift-ring-builder would
      start Python nine times (a second or more each on a loaded machine)
  s3_server_helper.py bucket ENDPOINT BUCKET ACCESS_KEY SECRET REGION
      waits (up to 30 s) until the proxy answers and creates the bucket through S3 itself, SigV4
      signed here (tempauth's own token API would need memcached); prints the last HTTP status
"""
import datetime
import hashlib
import hmac
import os
import sys
import time
import urllib.error
import urllib.request


def rings(etc, obj, cont, acct):
    from swift.common.ring import RingBuilder
    for kind, port in (("object", obj), ("container", cont), ("account", acct)):
        b = RingBuilder(4, 1, 0)
        b.add_dev({"id": 0, "region": 1, "zone": 1, "ip": "127.0.0.1", "port": int(port),
                   "device": "d1", "weight": 100.0, "meta": ""})
        b.rebalance()
        b.get_ring().save(f"{etc}/{kind}.ring.gz")


def put_bucket(endpoint, bucket, key, secret, region):
    now = datetime.datetime.now(datetime.timezone.utc)
    amz, day = now.strftime("%Y%m%dT%H%M%SZ"), now.strftime("%Y%m%d")
    host = endpoint.split("//", 1)[1]
    empty = hashlib.sha256(b"").hexdigest()
    signed = "host;x-amz-content-sha256;x-amz-date"
    canonical = "\n".join(["PUT", "/" + bucket, "", "host:" + host,
                           "x-amz-content-sha256:" + empty, "x-amz-date:" + amz, "", signed,
                           empty])
    scope = f"{day}/{region}/s3/aws4_request"
    to_sign = "\n".join(["AWS4-HMAC-SHA256", amz, scope,
                         hashlib.sha256(canonical.encode()).hexdigest()])
    k = ("AWS4" + secret).encode()
    for part in (day, region, "s3", "aws4_request"):
        k = hmac.new(k, part.encode(), hashlib.sha256).digest()
    sig = hmac.new(k, to_sign.encode(), hashlib.sha256).hexdigest()
    auth = f"AWS4-HMAC-SHA256 Credential={key}/{scope}, SignedHeaders={signed}, Signature={sig}"
    req = urllib.request.Request(endpoint + "/" + bucket, method="PUT", data=b"", headers={
        "x-amz-date": amz, "x-amz-content-sha256": empty, "Authorization": auth})
    try:
        return urllib.request.urlopen(req, timeout=5).status
    except urllib.error.HTTPError as e:
        return e.code
    except OSError:
        return 0


def exited(pid):
    """Whether the process is gone or a zombie (a server that could not bind its port)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] == "Z"
    except OSError:
        return True


def bucket(endpoint, name, key, secret, region, seconds="90", pids=""):
    """Prints the status of the bucket's PUT once it is 200 or 409 (made), the last one after
    `seconds`, or "exited" as soon as one of the servers `pids` names has."""
    code = 0
    deadline = time.monotonic() + float(seconds)
    while time.monotonic() < deadline:
        code = put_bucket(endpoint, name, key, secret, region)
        if code in (200, 409):  # 409: BucketAlreadyOwnedByYou
            break
        if any(exited(p) for p in pids.split()):
            code = "exited"
            break
        time.sleep(0.1)
    print(code)


def listens(pid, port):
    """Whether process `pid` holds a socket listening on 127.0.0.1:`port` (its own, not another
    process's that took the port first)."""
    inodes = set()
    try:
        for fd in os.listdir(f"/proc/{pid}/fd"):
            try:
                link = os.readlink(f"/proc/{pid}/fd/{fd}")
            except OSError:
                continue
            if link.startswith("socket:["):
                inodes.add(link[8:-1])
    except OSError:
        return False
    with open("/proc/net/tcp") as f:
        for line in f.readlines()[1:]:
            parts = line.split()
            if parts[3] == "0A" and int(parts[1].split(":")[1], 16) == port and parts[9] in inodes:
                return True
    return False


def listening(seconds, pairs):
    """Prints "yes" once every server of `pairs` ("PID:PORT ...") listens on its port, or what
    went wrong: one exited (its port was taken and it gave up), or `seconds` passed."""
    deadline = time.monotonic() + float(seconds)
    while True:
        waiting = []
        for pair in pairs.split():
            pid, port = pair.split(":")
            if exited(pid):
                print(f"server {pid} exited (port {port})")
                return
            if not listens(pid, int(port)):
                waiting.append(pair)
        if not waiting:
            print("yes")
            return
        if time.monotonic() > deadline:
            print("not listening after " + seconds + " s: " + " ".join(waiting))
            return
        time.sleep(0.05)


if __name__ == "__main__":
    {"rings": rings, "bucket": bucket, "listening": listening}[sys.argv[1]](*sys.argv[2:])
