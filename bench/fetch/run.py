#!/usr/bin/env python3
"""bench/fetch (issue 29): what the renderer fetches for a view, against CesiumJS on the same WMS.

Starts the synthetic WMS of upstream.py (detail at every level; blue = each map's resolution),
then for every view (1280x720, 35.98 degrees vertically: CesiumJS's default 60 across):
  - `tellus render --wait-complete` with a new cache (and --threshold T for each T of THRESHOLDS),
  - CesiumJS 1.145 in headless Chromium, a new browser context (cesium_views.mjs), unless NO_CESIUM,
and for every dome (DOMES: a 180-degree domemaster, tellus only) `tellus render --dome`;
and reports per view and renderer: GetMaps asked of the upstream, texels fetched per screen pixel
(sum of WIDTH x HEIGHT / 1280 x 720), the texel size on screen at the centre (pixels, N-S/E-W) and
over the screen (p10/p50/p90 of the larger and of the smaller side, on a 32 x 18 grid of samples
on the globe), and the seconds to a complete image. Texel sizes come from the screenshot's blue
(the resolution of the map drawn there) and the camera's rays cast onto the WGS84 ellipsoid (both
renderers place the same pose the same way: heading from north, tilt from the nadir).
With PROXY=1, instead: CesiumJS through `tellus serve` (a fresh server and cache per view, the
same configuration, CesiumJS asking its layer synthetic-imagery), and per view what the server
returned (tellus_compose_output_texels_total), what it fetched upstream for it (the upstream's
own count, and tellus_compose_source_texels_total{origin="upstream"}) and their ratio (issue 29's
goal: at most 2).
Usage: bench/fetch/run.py [TELLUS] (default build/tools/tellus/tellus); env THRESHOLDS (default
"1 2"), OVERVIEW (default "0 1": without and with renderer.overview, issue 29), VIEWS (names,
default all), NO_CESIUM=1, PROXY=1, NODE_MODULES (default build/tests/web-npm/node_modules), CONFIG
(default bench/fetch/fetch.yaml; a copy of it with another grid), OUT (default a new temporary
directory). Prints a Markdown table and writes OUT/results.json."""
import json
import math
import os
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request

from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
W, H, VFOV = 1280, 720, 35.98
VIEWS = [  # name, lat, lon, alt (m), heading, tilt
    ("globe", 0.0, 0.0, 2e7, 0.0, 0.0),
    ("alps", 46.5, 9.0, 5e3, 0.0, 70.0),
    ("pole", 90.0, 0.0, 5e5, 0.0, 0.0),
    ("equator", 0.0, 0.0, 5e5, 0.0, 0.0),  # the pole's view at the equator (issue 5's 1.5x)
    ("antimeridian", 0.0, 180.0, 2e5, 0.0, 0.0),
    ("paris", 48.8584, 2.2945, 10.0, 0.0, 80.0),
    ("descent", 45.0, 7.0, 5e5, 30.0, 40.0),
]
# Domes (tellus only: CesiumJS draws no fisheye): name, lat, lon, alt, heading, tilt, the dome's
# tilt (its axis turned up from the view), the domemaster's size; 180 degrees, the direct method.
DOMES = [
    ("dome", 45.0, 7.0, 2e4, 30.0, 60.0, 0.0, 1024),  # over the Alps, nadir to horizon
]
A, F = 6378137.0, 1 / 298.257223563
B = A * (1 - F)
E2 = F * (2 - F)


def ecef(lat, lon, h):
    la, lo = math.radians(lat), math.radians(lon)
    n = A / math.sqrt(1 - E2 * math.sin(la) ** 2)
    return ((n + h) * math.cos(la) * math.cos(lo), (n + h) * math.cos(la) * math.sin(lo),
            (n * (1 - E2) + h) * math.sin(la))


def geodetic(p):
    x, y, z = p
    lon = math.degrees(math.atan2(y, x))
    r = math.hypot(x, y)
    lat = math.atan2(z, r * (1 - E2))
    for _ in range(5):  # on the surface: converges in a few steps
        n = A / math.sqrt(1 - E2 * math.sin(lat) ** 2)
        lat = math.atan2(z + E2 * n * math.sin(lat), r)
    return math.degrees(lat), lon


def add(a, b, s=1.0):
    return tuple(x + s * y for x, y in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def unit(a):
    n = math.sqrt(sum(x * x for x in a))
    return tuple(x / n for x in a)


class Rays:
    """The camera of tellus's Camera.cpp (and Cesium's setView with pitch = tilt - 90)."""

    def __init__(self, lat, lon, alt, heading, tilt):
        la, lo = math.radians(lat), math.radians(lon)
        up = (math.cos(la) * math.cos(lo), math.cos(la) * math.sin(lo), math.sin(la))
        east = (-math.sin(lo), math.cos(lo), 0.0)
        north = cross(up, east)
        sh, ch = math.sin(math.radians(heading)), math.cos(math.radians(heading))
        st, ct = math.sin(math.radians(tilt)), math.cos(math.radians(tilt))
        hd = add(tuple(ch * v for v in north), east, sh)
        self.fwd = unit(add(tuple(-ct * v for v in up), hd, st))
        self.up = unit(add(tuple(st * v for v in up), hd, ct))
        self.right = unit(cross(self.fwd, self.up))
        self.eye = ecef(lat, lon, alt)
        self.ty = math.tan(math.radians(VFOV) / 2)
        self.tx = self.ty * W / H

    def direction(self, px, py):
        nx, ny = 2 * px / W - 1, 1 - 2 * py / H
        return add(add(self.fwd, self.right, nx * self.tx), self.up, ny * self.ty)

    def ground(self, px, py):
        """(lat, lon) where the ray through window point (px, py) meets the ellipsoid, or None."""
        d = self.direction(px, py)
        if d is None:
            return None
        # Scale z so that the ellipsoid is the sphere of radius A.
        o = (self.eye[0], self.eye[1], self.eye[2] * A / B)
        d = (d[0], d[1], d[2] * A / B)
        a = sum(v * v for v in d)
        b = 2 * sum(u * v for u, v in zip(o, d))
        c = sum(v * v for v in o) - A * A
        disc = b * b - 4 * a * c
        if disc < 0:
            return None
        t = (-b - math.sqrt(disc)) / (2 * a)
        if t <= 0:
            return None
        p = add(o, d, t)
        return geodetic((p[0], p[1], p[2] * B / A))


class DomeRays(Rays):
    """The fisheye camera of Camera.cpp (Fisheye): the axis turned up by the dome's tilt, an
    azimuthal equidistant map of 180 degrees onto the inscribed circle of a size x size image."""

    def __init__(self, lat, lon, alt, heading, tilt, dome_tilt, size):
        super().__init__(lat, lon, alt, heading, tilt)
        sd, cd = math.sin(math.radians(dome_tilt)), math.cos(math.radians(dome_tilt))
        f, u = self.fwd, self.up
        self.fwd = unit(add(tuple(cd * v for v in f), u, sd))
        self.up = unit(add(tuple(cd * v for v in u), f, -sd))
        self.right = unit(cross(self.fwd, self.up))
        self.size = size

    def direction(self, px, py):
        nx, ny = 2 * px / self.size - 1, 1 - 2 * py / self.size
        r = math.hypot(nx, ny)
        if r > 1:
            return None
        theta = r * math.pi / 2
        side = add(tuple(nx / r * v for v in self.right), self.up, ny / r) if r > 0 else self.up
        return add(tuple(math.cos(theta) * v for v in self.fwd), side, math.sin(theta))


def texel_sizes(rays, image, px, py):
    """(N-S, E-W) size in pixels of the texel drawn at window point (px, py), or None."""
    # Forward differences over one pixel (a central one is 0 at a pole under the camera).
    gx0 = gy0 = c = rays.ground(px, py)
    gx1, gy1 = rays.ground(px + 1, py), rays.ground(px, py + 1)
    if None in (c, gx1, gy1):
        return None
    code = image.getpixel((min(image.width - 1, int(px)), min(image.height - 1, int(py))))[2]
    if code == 0:
        return None
    res = 2.0 ** -(code / 8.0 - 4.0)
    wrap = lambda d: (d + 180.0) % 360.0 - 180.0  # noqa: E731
    dlat = math.hypot(gx1[0] - gx0[0], gy1[0] - gy0[0])
    dlon = math.hypot(wrap(gx1[1] - gx0[1]), wrap(gy1[1] - gy0[1]))
    return (res / dlat if dlat > 0 else math.inf, res / dlon if dlon > 0 else math.inf)


def pct(values, p):
    v = sorted(values)
    return v[min(len(v) - 1, int(p / 100 * len(v)))] if v else float("nan")


def is_dome(view):
    return len(view) == 8


def pixels(view):
    """The pixels a view shows: the screen's, or the domemaster's circle."""
    return math.pi * (view[7] / 2) ** 2 if is_dome(view) else W * H


def measure(view, png):
    rays = DomeRays(*view[1:]) if is_dome(view) else Rays(*view[1:])
    image = Image.open(png).convert("RGB")
    w, h = image.width, image.height
    cols, rows = (24, 24) if is_dome(view) else (32, 18)  # a dome's samples off its circle: none
    centre = texel_sizes(rays, image, w / 2, h / 2)
    big, small = [], []
    for j in range(rows):
        for i in range(cols):
            s = texel_sizes(rays, image, (i + 0.5) * w / cols, (j + 0.5) * h / rows)
            if s and all(math.isfinite(x) for x in s):
                big.append(max(s))
                small.append(min(s))
    return {"centre": centre, "larger": [pct(big, p) for p in (10, 50, 90)],
            "smaller": [pct(small, p) for p in (10, 50, 90)], "samples": len(big)}


def get(url):
    with urllib.request.urlopen(url, timeout=30) as r:
        return json.load(r)


def png_of(out, row):
    r = row["renderer"]
    name = f"cesium-{row['view']}" if r.startswith("cesium") else f"tellus-{r.split()[1]}-{row['view']}"
    return os.path.join(out, name + ".png")


def table(rows):
    fmt = lambda x: "-" if x is None or not math.isfinite(x) else f"{x:.2f}"  # noqa: E731
    print("| view | renderer | requests | texels / screen px | centre texel px N-S/E-W | "
          "larger side p10/p50/p90 | smaller side p10/p50/p90 | seconds |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        m = r["measure"] or {"centre": None, "larger": [None] * 3, "smaller": [None] * 3}
        c = "/".join(fmt(x) for x in m["centre"]) if m["centre"] else "-"
        print(f"| {r['view']} | {r['renderer']}{'' if r['rc'] == 0 else ' (failed)'} | "
              f"{r['requests']} | {r['texels'] / r.get('pixels', W * H):.2f} | {c} | "
              f"{'/'.join(fmt(x) for x in m['larger'])} | "
              f"{'/'.join(fmt(x) for x in m['smaller'])} | {r['seconds']:.1f} |")


def metrics(url):
    """The samples of a Prometheus exposition at url, by name with labels."""
    with urllib.request.urlopen(url, timeout=30) as r:
        text = r.read().decode()
    out = {}
    for line in text.splitlines():
        if line and not line.startswith("#"):
            name, _, value = line.rpartition(" ")
            out[name] = float(value)
    return out


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def through_serve(tellus, url, config, views, out, node_modules):
    """CesiumJS through a fresh `tellus serve` per view (PROXY=1): rows of what it cost upstream."""
    rows = []
    for v in views:
        port = free_port()
        cache = tempfile.mkdtemp(prefix=f"serve-{v[0]}-", dir=out)
        log = open(os.path.join(out, f"serve-{v[0]}.log"), "w")
        server = subprocess.Popen([tellus, "serve", "--config", config, "--cache", cache,
                                   "--listen", f"127.0.0.1:{port}"], stdout=log, stderr=log)
        base = f"http://127.0.0.1:{port}"
        try:
            for _ in range(100):
                try:
                    metrics(base + "/metrics")
                    break
                except OSError:
                    time.sleep(0.1)
            vfile = os.path.join(out, f"views-{v[0]}.json")
            with open(vfile, "w") as f:
                json.dump([{"name": v[0], "lat": v[1], "lon": v[2], "alt": v[3], "heading": v[4],
                            "tilt": v[5], "width": W, "height": H}], f)
            env = dict(os.environ, WMS_URL=base + "/wms", WMS_LAYER="synthetic-imagery")
            run = subprocess.run(["node", os.path.join(HERE, "cesium_views.mjs"), node_modules, url,
                                  vfile, out], stdout=subprocess.PIPE, text=True, env=env)
            m = metrics(base + "/metrics")
        finally:
            server.terminate()
            server.wait()
            log.close()
        for line in run.stdout.splitlines():
            c = json.loads(line)
            maps = sum(x for k, x in m.items() if k.startswith(
                'tellus_http_requests_total{protocol="wms",code="200"'))
            # CesiumJS's maps are 256 x 256, composed or served as tiles (the compose counter
            # counts the former only).
            served = maps * 256 * 256
            row = {"view": c["name"], "settled": c["settled"], "seconds": c["seconds"],
                   "maps": int(maps), "served_texels": served,
                   "upstream_requests": c["requests"], "upstream_texels": c["texels"],
                   "counted_upstream_texels": m.get(
                       'tellus_compose_source_texels_total{origin="upstream"}', float("nan")),
                   "tile_errors": c.get("tileErrors", 0)}
            row["ratio"] = row["upstream_texels"] / served if served else float("nan")
            rows.append(row)
            print(json.dumps(row), flush=True)
    return rows


def serve_table(rows):
    print("| view | GetMaps answered | texels answered | upstream GetMaps | upstream texels "
          "(server's count) | upstream / answered | seconds |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['view']}{'' if r['settled'] else ' (not settled)'} | {r['maps']} | "
              f"{r['served_texels']:.0f} | {r['upstream_requests']} | {r['upstream_texels']} "
              f"({r['counted_upstream_texels']:.0f}) | **{r['ratio']:.2f}** | "
              f"{r['seconds']:.1f} |")


def remeasure(out):
    """Measures the images of an earlier run again (run.py --remeasure OUT)."""
    with open(os.path.join(out, "results.json")) as f:
        rows = json.load(f)
    for r in rows:
        v = next(x for x in VIEWS + DOMES if x[0] == r["view"])
        if r["rc"] == 0:
            r["measure"] = measure(v, png_of(out, r))
    table(rows)


def main():
    if len(sys.argv) == 3 and sys.argv[1] == "--remeasure":
        return remeasure(sys.argv[2])
    tellus = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else
                             os.path.join(ROOT, "build/tools/tellus/tellus"))
    out = os.environ.get("OUT") or tempfile.mkdtemp(prefix="tellus-fetch.")
    os.makedirs(out, exist_ok=True)
    thresholds = os.environ.get("THRESHOLDS", "1 2").split()
    names = os.environ.get("VIEWS", "").split()
    views = [v for v in VIEWS + DOMES if not names or v[0] in names]
    portfile = os.path.join(out, "port")
    upstream = subprocess.Popen([sys.executable, os.path.join(HERE, "upstream.py"), portfile,
                                 os.path.join(out, "upstream.log")])
    try:
        for _ in range(100):
            if os.path.exists(portfile):
                break
            time.sleep(0.1)
        url = f"http://127.0.0.1:{open(portfile).read().strip()}"
        with open(os.environ.get("CONFIG") or os.path.join(HERE, "fetch.yaml")) as f:
            config = f.read().replace("@URL@", url + "/wms")
        cfgs = {}
        for ov in ("0", "1"):
            cfgs[ov] = os.path.join(out, f"fetch-{ov}.yaml")
            with open(cfgs[ov], "w") as f:
                f.write(config.replace("@OVERVIEW@", "overview: synthetic-overview" if ov == "1"
                                       else "# no overview"))
        nm = os.environ.get("NODE_MODULES", os.path.join(ROOT, "build/tests/web-npm/node_modules"))
        if os.environ.get("PROXY"):
            flat = [v for v in views if not is_dome(v)]
            rows = through_serve(tellus, url, cfgs["0"], flat, out, nm)
            with open(os.path.join(out, "results.json"), "w") as f:
                json.dump(rows, f, indent=1)
            print(f"\n{out}\n")
            serve_table(rows)
            return
        overviews = os.environ.get("OVERVIEW", "0 1").split()
        rows = []
        for v in views:
            for t, ov in [(t, ov) for ov in overviews for t in thresholds]:
                cfg = cfgs[ov]
                tag = f"t{t}" + ("-ov" if ov == "1" else "")
                cache = tempfile.mkdtemp(prefix=f"cache-{v[0]}-", dir=out)
                png = os.path.join(out, f"tellus-{tag}-{v[0]}.png")
                stats = os.path.join(out, f"tellus-{tag}-{v[0]}.json")
                get(url + "/reset")
                shape = (["--size", str(v[7]), "--dome", "180", "--dome-tilt", str(v[6])]
                         if is_dome(v) else ["--size", f"{W}x{H}"])
                cmd = [tellus, "render", "--config", cfg, "--cache", cache, "--data", out,
                       "--camera", ",".join(str(x) for x in v[1:6]), *shape,
                       "--threshold", t, "--no-terrain", "--no-sun", "--background", "0,0,0",
                       "--wait-complete=600", "--out", png, "--stats", stats]
                started = time.monotonic()
                rc = subprocess.run(cmd).returncode
                seconds = time.monotonic() - started
                counts = get(url + "/stats")
                m = measure(v, png) if rc == 0 else None
                rows.append({"view": v[0], "renderer": f"tellus {tag}", "rc": rc,
                             "seconds": seconds, **counts, "pixels": pixels(v), "measure": m})
                print(json.dumps(rows[-1]), flush=True)
        if not os.environ.get("NO_CESIUM"):
            vfile = os.path.join(out, "views.json")
            with open(vfile, "w") as f:
                json.dump([{"name": v[0], "lat": v[1], "lon": v[2], "alt": v[3], "heading": v[4],
                            "tilt": v[5], "width": W, "height": H}
                           for v in views if not is_dome(v)], f)
            run = subprocess.run(["node", os.path.join(HERE, "cesium_views.mjs"), nm, url, vfile, out],
                                 stdout=subprocess.PIPE, text=True)
            for line in run.stdout.splitlines():
                c = json.loads(line)
                v = next(x for x in views if x[0] == c["name"])
                rows.append({"view": c["name"], "rc": 0,
                             "renderer": "cesium" + ("" if c["settled"] else " (not settled)"),
                             "seconds": c["seconds"], "requests": c["requests"],
                             "texels": c["texels"],
                             "measure": measure(v, os.path.join(out, f"cesium-{c['name']}.png"))})
                print(json.dumps(rows[-1]), flush=True)
        with open(os.path.join(out, "results.json"), "w") as f:
            json.dump(rows, f, indent=1)
        print(f"\n{out}\n")
        table(rows)
    finally:
        upstream.terminate()
        upstream.wait()


if __name__ == "__main__":
    main()
