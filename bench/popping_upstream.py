"""A synthetic WMS upstream for bench/popping.sh (issue 23, "No popping"): imagery and heights with
new detail at every level, so that a tile that arrives, or a node that splits, changes what is drawn
(the embedded default's Blue Marble has no detail past level 2: nothing pops there).

Both layers are pure functions of the position and the request's resolution (degrees per pixel,
res = BBOX width / WIDTH): a sum of octaves of value noise (a hashed lattice of cell size
c_o = 45 / 2^o degrees, o = 0, 1, ..., bilinearly interpolated with a smoothstep), of which a
request includes the octaves wide enough for its resolution. Each level of a quadtree halves res,
so each level's tiles hold exactly one octave more than their parent's: the detail a child's
texture brings (and the parent's texture, magnified, lacks).
  - LAYERS=img (image/jpeg or image/png, RGB): 8-bit colour = base + sum over the octaves with
    c_o >= 8 res of A (2 n_o - 1) w_o, A = 26 grey levels, n_o in [0, 1] the octave's noise, w_o a
    fixed colour of the octave (hue changes with the scale); clipped to 0..255. Pixel centres are
    sampled (pixel-is-area), so neighbouring tiles of a level join without a seam.
  - LAYERS=hgt (application/bil16: little-endian int16 metres, row 0 north): 1000 m + sum over the
    octaves with c_o >= 4 res of min(0.1 c_o [m], 300 m) (2 n_o - 1): slopes of about 10% at every
    scale (the octave of 1 km is 100 m high, the one of 230 m 23 m), hills of +-1 to 2 km.
Responses are cached in memory (by query string, the last 1500), so every configuration of one
bench run gets its tiles equally fast. Every other request (GetCapabilities included) gets 400.
Usage: popping_upstream.py PORTFILE (binds 127.0.0.1 on a free port, writes the port to PORTFILE,
serves until killed)."""
import collections
import io
import os
import sys
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from urllib.parse import parse_qsl, urlsplit

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one BLAS thread a request: no oversubscription
os.environ.setdefault("OMP_NUM_THREADS", "1")
import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402

BASE_RGB = np.array([96.0, 112.0, 80.0])
AMPLITUDE = 26.0
# One colour per octave (cycled): the detail of a scale has a hue of its own.
HUES = np.array([[1.0, 0.9, 0.6], [0.5, 1.0, 0.7], [0.9, 0.6, 1.0], [1.0, 1.0, 1.0], [0.6, 0.8, 1.0]])
METRES_PER_DEGREE = 111320.0


def lattice(i, j, seed):
    """Hashed values in [0, 1] of integer lattice points (numpy int64 arrays of one shape)."""
    x = (i.astype(np.uint64) * np.uint64(0x9E3779B1)) ^ (j.astype(np.uint64) * np.uint64(0x85EBCA77))
    x = x + np.uint64(seed) * np.uint64(0xC2B2AE3D)
    x ^= x >> np.uint64(15)
    x *= np.uint64(0x2C1B3C6D)
    x ^= x >> np.uint64(12)
    x *= np.uint64(0x297A2D39)
    x ^= x >> np.uint64(15)
    return (x & np.uint64(0xFFFF)).astype(np.float64) / 65535.0


def weights(t):
    """The interpolation matrix of positions t (lattice units, (N,)): (N, L) with the smoothstep
    weights of each position's two lattice points, and the first lattice index."""
    i0 = np.floor(t).astype(np.int64)
    f = t - i0
    f = f * f * (3 - 2 * f)
    first = i0.min()
    m = np.zeros((t.size, i0.max() - first + 2))
    rows = np.arange(t.size)
    m[rows, i0 - first] = 1 - f
    m[rows, i0 - first + 1] = f
    return m, first


def octave(lon, lat, cell, seed):
    """Value noise of one octave at the grid lon (W,) x lat (H,) degrees: an (H, W) array in
    [0, 1]. Bilinear interpolation is separable: Wv G Wu^T, G the lattice over the request's
    cells only."""
    wu, ia = weights(lon / cell)
    wv, ja = weights(lat / cell)
    ii, jj = np.meshgrid(np.arange(ia, ia + wu.shape[1]), np.arange(ja, ja + wv.shape[1]))
    wrap = int(round(360.0 / cell))  # the lattice wraps at the antimeridian
    return wv @ lattice(np.mod(ii, wrap), jj, seed) @ wu.T


def centres(bbox, width, height):
    west, south, east, north = bbox
    lon = west + (np.arange(width) + 0.5) * (east - west) / width
    lat = north - (np.arange(height) + 0.5) * (north - south) / height  # row 0 north
    return lon, lat, (east - west) / width


def imagery(bbox, width, height):
    lon, lat, res = centres(bbox, width, height)
    count = 0
    while 45.0 / 2**count >= 8 * res:
        count += 1
    noise = np.stack([2 * octave(lon, lat, 45.0 / 2**o, 1000 + o) - 1 for o in range(count)])
    hues = HUES[np.arange(count) % len(HUES)]
    rgb = BASE_RGB + AMPLITUDE * np.tensordot(noise, hues, axes=(0, 0))
    return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


def heights(bbox, width, height):
    lon, lat, res = centres(bbox, width, height)
    h = np.full((height, width), 1000.0)
    o = 0
    while 45.0 / 2**o >= 4 * res:
        cell = 45.0 / 2**o
        h += min(0.1 * cell * METRES_PER_DEGREE, 300.0) * (2 * octave(lon, lat, cell, 2000 + o) - 1)
        o += 1
    return np.clip(np.rint(h), -32767, 32767).astype("<i2")


class Handler(BaseHTTPRequestHandler):
    cache = collections.OrderedDict()
    lock = threading.Lock()

    def log_message(self, *args):
        pass

    def do_GET(self):
        query = urlsplit(self.path).query
        with self.lock:
            hit = self.cache.get(query)
            if hit:
                self.cache.move_to_end(query)
        if hit is None:
            hit = self.answer(query)
            if hit[0] == 200:
                with self.lock:
                    self.cache[query] = hit
                    while len(self.cache) > 1500:
                        self.cache.popitem(last=False)
        status, mime, body = hit
        self.send_response(status)
        self.send_header("Content-Type", mime)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def answer(self, query):
        q = {k.upper(): v for k, v in parse_qsl(query)}
        try:
            if q.get("REQUEST", "").lower() != "getmap":
                raise ValueError("only GetMap")
            bbox = [float(x) for x in q["BBOX"].split(",")]
            if q.get("VERSION") == "1.3.0" and q.get("CRS", "").upper() == "EPSG:4326":
                bbox = [bbox[1], bbox[0], bbox[3], bbox[2]]  # 1.3.0 EPSG:4326 is lat, lon
            w, h, layer, fmt = int(q["WIDTH"]), int(q["HEIGHT"]), q["LAYERS"], q.get("FORMAT", "")
            if not (0 < w <= 4096 and 0 < h <= 4096):
                raise ValueError("size")
            if layer == "hgt":
                return 200, "application/bil16", heights(bbox, w, h).tobytes()
            if layer != "img":
                raise ValueError("layer")
            out = io.BytesIO()
            png = fmt == "image/png"
            Image.fromarray(imagery(bbox, w, h)).save(out, "PNG" if png else "JPEG", quality=90)
            return 200, fmt if png else "image/jpeg", out.getvalue()
        except (KeyError, ValueError) as e:
            return 400, "text/plain", ("bad request: %s\n" % e).encode()


def main():
    server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    with open(sys.argv[1], "w") as f:
        f.write(str(server.server_address[1]))
    server.serve_forever()


if __name__ == "__main__":
    main()
