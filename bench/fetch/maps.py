#!/usr/bin/env python3
"""bench/fetch/maps.py (issue 29): what composed GetMaps of `tellus serve` cost upstream against
what they return, on the synthetic WMS of upstream.py (detail at every level) and fetch.yaml's
layer synthetic-imagery (World Wind's grid: 36-degree level zero, 512-px tiles).

Two sets, each group on a fresh server and cache:
  - tiles: a client's block of 4 x 4 adjacent 256-px EPSG:4326 tiles (CesiumJS's geographic tiling,
    levels 3-16, around 7 E 45 N), one group per level;
  - maps: 1024 x 768 maps at assorted scales (pixels of 2^-k level zero's texel times 1, 1.19,
    1.41 and 1.68, k = 0-14), each alone on its server, at a place drawn per map;
  - mercator: GoogleMapsCompatible's 256-px tiles as EPSG:3857 GetMaps, every tile of zooms 0-2
    and a 4 x 4 block around 7 E 45 N at zooms 3-8, one group per zoom.
Per group: GetMaps answered, texels answered (the client's sum of WIDTH x HEIGHT; the server's
tellus_compose_output_texels_total in maps.json), upstream
texels (the upstream's own count, and the server's tellus_compose_source_texels_total
{origin="upstream"}) and their ratio (goal: at most 2).
Usage: bench/fetch/maps.py [TELLUS] (default build/tools/tellus/tellus); env OUT (default a new
temporary directory), SETS (default "tiles maps"), CONFIG (another template than fetch.yaml). Prints Markdown tables, writes OUT/maps.json."""
import json
import os
import random
import subprocess
import sys
import tempfile
import time
import urllib.request

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
from run import free_port, metrics  # noqa: E402

TEXEL0 = 36.0 / 512


def fetch(url):
    with urllib.request.urlopen(url, timeout=120) as r:
        return r.status, r.read()


class Server:
    """A fresh `tellus serve` on a new cache."""

    def __init__(self, tellus, config, out, tag):
        self.port = free_port()
        self.log = open(os.path.join(out, f"serve-{tag}.log"), "w")
        cache = tempfile.mkdtemp(prefix=f"cache-{tag}-", dir=out)
        self.proc = subprocess.Popen([tellus, "serve", "--config", config, "--cache", cache,
                                      "--listen", f"127.0.0.1:{self.port}"],
                                     stdout=self.log, stderr=self.log)
        self.base = f"http://127.0.0.1:{self.port}"
        for _ in range(100):
            try:
                metrics(self.base + "/metrics")
                return
            except OSError:
                time.sleep(0.1)

    def getmap(self, west, south, east, north, width, height, srs="EPSG:4326"):
        q = (f"/wms?SERVICE=WMS&VERSION=1.1.1&REQUEST=GetMap&LAYERS=synthetic-imagery&STYLES="
             f"&SRS={srs}&BBOX={west!r},{south!r},{east!r},{north!r}&WIDTH={width}"
             f"&HEIGHT={height}&FORMAT=image/png")
        status, _ = fetch(self.base + q)
        return status

    def close(self):
        m = metrics(self.base + "/metrics")
        self.proc.terminate()
        self.proc.wait()
        self.log.close()
        return m


def group(tellus, config, upstream, out, tag, maps):
    fetch(upstream + "/reset")
    server = Server(tellus, config, out, tag)
    ok = [m for m in maps if server.getmap(*m) == 200]
    m = server.close()
    _, body = fetch(upstream + "/stats")
    counts = json.loads(body)
    served = sum(x[4] * x[5] for x in ok)  # the client's count (a binary before the counters)
    row = {"group": tag, "maps": len(ok), "asked": len(maps), "served_texels": served,
           "counted_served_texels": m.get("tellus_compose_output_texels_total", float("nan")),
           "upstream_requests": counts["requests"], "upstream_texels": counts["texels"],
           "counted_upstream_texels": m.get(
               'tellus_compose_source_texels_total{origin="upstream"}', float("nan"))}
    row["ratio"] = counts["texels"] / served if served else float("nan")
    print(json.dumps(row), flush=True)
    return row


def tiles_set(tellus, config, upstream, out):
    rows = []
    for n in range(3, 17):
        size = 180.0 / 2 ** n
        x0, y0 = int((7.0 + 180) / size) - 1, int((90 - 45.0) / size) - 1
        maps = [(-180 + (x0 + i) * size, 90 - (y0 + j + 1) * size, -180 + (x0 + i + 1) * size,
                 90 - (y0 + j) * size, 256, 256) for j in range(4) for i in range(4)]
        rows.append(group(tellus, config, upstream, out, f"tiles-L{n}", maps))
    return rows


def maps_set(tellus, config, upstream, out):
    rng = random.Random(29)
    rows = []
    for k in range(0, 15):
        for f in (1.0, 1.19, 1.41, 1.68):
            pixel = TEXEL0 / 2 ** k * f
            w, h = 1024 * pixel, 768 * pixel
            west = rng.uniform(-180, 180 - w)
            south = rng.uniform(-80, 80 - h)
            rows.append(group(tellus, config, upstream, out, f"map-k{k}-x{f}",
                              [(west, south, west + w, south + h, 1024, 768)]))
    return rows


MERCATOR_MAX = 20037508.342789244  # the Web Mercator square's half side, metres


def mercator_set(tellus, config, upstream, out):
    """GoogleMapsCompatible's 256-px tiles as EPSG:3857 GetMaps (OpenLayers', Leaflet's tiling):
    every tile of zooms 0-2 (a world view), then a 4 x 4 block around 7 E 45 N at zooms 3-8."""
    import math
    rows = []
    for z in range(0, 9):
        n = 2 ** z
        size = 2 * MERCATOR_MAX / n
        if z <= 2:
            cells = [(i, j) for j in range(n) for i in range(n)]
        else:
            x = (7.0 + 180.0) / 360.0 * n
            y = (1 - math.log(math.tan(math.radians(45.0)) + 1 / math.cos(math.radians(45.0)))
                 / math.pi) / 2 * n
            cells = [(int(x) - 1 + i, int(y) - 1 + j) for j in range(4) for i in range(4)]
        maps = [(-MERCATOR_MAX + i * size, MERCATOR_MAX - (j + 1) * size,
                 -MERCATOR_MAX + (i + 1) * size, MERCATOR_MAX - j * size, 256, 256, "EPSG:3857")
                for i, j in cells]
        rows.append(group(tellus, config, upstream, out, f"mercator-z{z}", maps))
    return rows


def table(rows):
    print("| group | GetMaps | texels answered | upstream GetMaps | upstream texels (server's "
          "count) | upstream / answered |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['group']} | {r['maps']}/{r['asked']} | {r['served_texels']:.0f} | "
              f"{r['upstream_requests']} | {r['upstream_texels']} "
              f"({r['counted_upstream_texels']:.0f}) | **{r['ratio']:.2f}** |")
    served = sum(r["served_texels"] for r in rows)
    fetched = sum(r["upstream_texels"] for r in rows)
    print(f"| all | | {served:.0f} | | {fetched} | **{fetched / served:.2f}** |")


def main():
    tellus = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else
                             os.path.join(ROOT, "build/tools/tellus/tellus"))
    out = os.environ.get("OUT") or tempfile.mkdtemp(prefix="tellus-maps.")
    os.makedirs(out, exist_ok=True)
    portfile = os.path.join(out, "port")
    upstream = subprocess.Popen([sys.executable, os.path.join(HERE, "upstream.py"), portfile])
    try:
        for _ in range(100):
            if os.path.exists(portfile):
                break
            time.sleep(0.1)
        url = f"http://127.0.0.1:{open(portfile).read().strip()}"
        config = os.path.join(out, "fetch.yaml")
        with open(os.environ.get("CONFIG", os.path.join(HERE, "fetch.yaml"))) as f:
            text = f.read().replace("@URL@", url + "/wms").replace(
                "@OVERVIEW@", os.environ.get("RENDERER_OVERVIEW", "# no overview"))
        with open(config, "w") as f:
            f.write(text)
        results = {}
        for name in os.environ.get("SETS", "tiles maps").split():
            sets = {"tiles": tiles_set, "maps": maps_set, "mercator": mercator_set}
            results[name] = sets[name](tellus, config, url, out)
        with open(os.path.join(out, "maps.json"), "w") as f:
            json.dump(results, f, indent=1)
        print(f"\n{out}\n")
        for name, rows in results.items():
            print(f"\n{name}:\n")
            table(rows)
    finally:
        upstream.terminate()
        upstream.wait()


if __name__ == "__main__":
    main()
