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


def bucket(endpoint, name, key, secret, region):
    code = 0
    deadline = time.monotonic() + 90
    while time.monotonic() < deadline:
        code = put_bucket(endpoint, name, key, secret, region)
        if code in (200, 409):  # 409: BucketAlreadyOwnedByYou
            break
        time.sleep(0.1)
    print(code)


if __name__ == "__main__":
    {"rings": rings, "bucket": bucket}[sys.argv[1]](*sys.argv[2:])
