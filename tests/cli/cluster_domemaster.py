"""The channels of `tellus cluster` (issue 28) put back into a domemaster and compared with one:

    cluster_domemaster.py CONFIG.json DIR FRAME REFERENCE.png [OUT.ppm]

For every pixel of an N x N angular fisheye of 180 degrees (REFERENCE's size), its direction in
dome coordinates (x right, y up, z back: the axis is -z; docs/design/cluster.md), then every
channel of CONFIG that sees it (the pinhole map of planet/Channels.hpp, mirrored here), the
channel's image DIR/channel-NAME-FRAME.png sampled bilinearly, and the samples blended where the
channels overlap (each weighted by its distance from its image's edge: soft edges). Prints the
PSNR against REFERENCE over the circle, the worst PSNR of one channel's part (the pixels where it
weighs most: one channel off shows there, not diluted by the others), and the share of the circle
no channel saw. Python's
standard library only (png_pixels.py)."""
import json
import math
import sys

from png_pixels import pixels


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def dot(a, b):
    return sum(a[i] * b[i] for i in range(3))


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def norm(a):
    n = math.sqrt(dot(a, a))
    return [v / n for v in a]


def frame(c):
    az, el, roll = (math.radians(c[k]) for k in ("azimuth", "elevation", "roll"))
    forward = [math.cos(el) * math.sin(az), math.cos(el) * math.cos(az), -math.sin(el)]
    up0 = [-math.sin(el) * math.sin(az), -math.sin(el) * math.cos(az), -math.cos(el)]
    right0 = cross(forward, up0)
    up = norm([math.cos(roll) * up0[i] + math.sin(roll) * right0[i] for i in range(3)])
    return forward, up, norm(cross(forward, up))


class Channel:
    def __init__(self, c, directory, frame_no):
        c.setdefault("roll", 0.0)
        self.name = c["name"]
        self.w, self.h = c["width"], c["height"]
        self.forward, self.up, self.right = frame(c)
        self.tx = math.tan(math.radians(c["hfov"]) / 2)
        self.ty = math.tan(math.radians(c["vfov"]) / 2)
        w, h, rows, n = pixels(f"{directory}/channel-{c['name']}-{frame_no:05d}.png")
        assert (w, h) == (self.w, self.h), (c["name"], w, h)
        self.rows, self.n = rows, n

    def texel(self, x, y, k):
        x = min(max(x, 0), self.w - 1)
        y = min(max(y, 0), self.h - 1)
        return self.rows[y][self.n * x + k]

    def sample(self, d):
        """(weight, rgb) of a dome direction; weight 0 where the channel does not see it."""
        z = dot(d, self.forward)
        if z <= 1e-9:
            return 0.0, None
        px = (1 + dot(d, self.right) / z / self.tx) * self.w / 2
        py = (1 - dot(d, self.up) / z / self.ty) * self.h / 2
        edge = min(px, self.w - px, py, self.h - py)
        if edge <= 0:
            return 0.0, None
        weight = min(1.0, edge / (0.1 * min(self.w, self.h)))
        x, y = px - 0.5, py - 0.5
        x0, y0 = math.floor(x), math.floor(y)
        fx, fy = x - x0, y - y0
        rgb = []
        for k in range(3):
            top = self.texel(x0, y0, k) * (1 - fx) + self.texel(x0 + 1, y0, k) * fx
            bottom = self.texel(x0, y0 + 1, k) * (1 - fx) + self.texel(x0 + 1, y0 + 1, k) * fx
            rgb.append(top * (1 - fy) + bottom * fy)
        return weight, rgb


def main():
    config, directory, frame_no, reference = sys.argv[1:5]
    channels = [Channel(c, directory, int(frame_no)) for c in json.load(open(config))["channels"]]
    size, _, ref, rn = pixels(reference)
    out = bytearray(size * size * 3)
    se, count, unseen = 0.0, 0, 0
    own = [[0.0, 0] for _ in channels]  # per channel: squared error and count where it weighs most
    for y in range(size):
        for x in range(size):
            dx = (x + 0.5 - size / 2) / (size / 2)
            dy = (size / 2 - (y + 0.5)) / (size / 2)
            r = math.hypot(dx, dy)
            if r > 1 - 1.0 / size:  # the circle, less the rim's half-covered pixels
                continue
            theta = r * math.pi / 2
            s = math.sin(theta) / r if r > 0 else 0.0
            d = [dx * s, dy * s, -math.cos(theta)]
            total, rgb, best = 0.0, [0.0, 0.0, 0.0], (0.0, 0)
            for i, c in enumerate(channels):
                w, v = c.sample(d)
                if w > 0:
                    total += w
                    rgb = [rgb[k] + w * v[k] for k in range(3)]
                    best = max(best, (w, i))
            if total == 0:
                unseen += 1
                continue
            for k in range(3):
                v = rgb[k] / total
                out[3 * (y * size + x) + k] = int(round(v))
                e = (v - ref[y][rn * x + k]) ** 2
                se += e
                own[best[1]][0] += e
            own[best[1]][1] += 3
            count += 1
    def psnr(e, n):
        return 99.0 if e == 0 else 10 * math.log10(255 ** 2 * n / e)

    worst = min(psnr(e, n) for e, n in own if n > 0)
    parts = " ".join(f"{c.name} {psnr(e, n):.2f}" for c, (e, n) in zip(channels, own) if n > 0)
    print(f"psnr {psnr(se, 3 * count):.2f} worst {worst:.2f} unseen {unseen / (count + unseen):.4f}"
          f" {parts}")
    if len(sys.argv) > 5:
        with open(sys.argv[5], "wb") as f:
            f.write(b"P6 %d %d 255\n" % (size, size) + bytes(out))


main()
