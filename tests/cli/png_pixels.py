"""Pixels of an 8-bit RGB or RGBA PNG without a library (the PNGs `tellus render` writes and the
test inputs): `pixels(path)` gives (width, height, rows of bytes, channels); run as a script,
`png_pixels.py FILE X Y` prints the pixel's R G B."""
import struct
import sys
import zlib


def pixels(path):
    data = open(path, "rb").read()
    w, h, depth, colour = struct.unpack(">IIBB", data[16:26])
    assert depth == 8 and colour in (2, 6), (depth, colour)
    n = 3 if colour == 2 else 4
    i, idat = 8, b""
    while i < len(data):
        size = struct.unpack(">I", data[i:i + 4])[0]
        if data[i + 4:i + 8] == b"IDAT":
            idat += data[i + 8:i + 8 + size]
        i += 12 + size
    raw, stride, rows, prev = zlib.decompress(idat), w * n, [], bytearray(w * n)
    for y in range(h):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for x in range(stride):
            a = line[x - n] if x >= n else 0
            b = prev[x]
            c = prev[x - n] if x >= n else 0
            if f == 1:
                line[x] = (line[x] + a) & 255
            elif f == 2:
                line[x] = (line[x] + b) & 255
            elif f == 3:
                line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(line)
        prev = line
    return w, h, rows, n


def write(path, w, h, values, rgba):
    """An 8-bit PNG from a flat list of channel values (RGB or RGBA), filter 0."""
    n = 4 if rgba else 3
    raw = b"".join(b"\x00" + bytes(values[y * w * n:(y + 1) * w * n]) for y in range(h))

    def chunk(kind, body):
        return (struct.pack(">I", len(body)) + kind + body +
                struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))
    header = struct.pack(">IIBBBBB", w, h, 8, 6 if rgba else 2, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw)) +
                chunk(b"IEND", b""))


if __name__ == "__main__":
    w, h, rows, n = pixels(sys.argv[1])
    x, y = int(sys.argv[2]), int(sys.argv[3])
    print(*rows[y][x * n:x * n + 3])
