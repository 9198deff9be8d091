#!/usr/bin/env python3
"""Writes synthetic highlight-RTI photos with two mirror spheres and near lamps (16-bit linear
PNG, x right / y down) and the lamps' true positions (frame of light_positions.txt: x right, y up,
origin at the image centre, pixels). Usage: near_sphere_photos.py OUT_DIR"""
import math, os, struct, sys, zlib

W, H = 400, 300
BALLS = [(70.3, 64.2, 60.0), (327.7, 233.4, 56.5)]  # cx, cy (pixel centres at integers), r
DIST = 600.0


def lights():
    out = []
    for theta, k in [(30, k) for k in range(4)] + [(60, k) for k in range(4)]:
        t, p = math.radians(theta), math.radians(k * 90 + (45 if theta > 40 else 0))
        out.append((DIST * math.sin(t) * math.cos(p), DIST * math.sin(t) * math.sin(p),
                    DIST * math.cos(t)))
    return out


def norm(v):
    n = math.sqrt(sum(c * c for c in v))
    return tuple(c / n for c in v)


def pixel(px, py, lamp):
    for cx, cy, r in BALLS:
        nx, ny = (px - cx) / r, -(py - cy) / r
        q = nx * nx + ny * ny
        if q >= 1:
            continue
        nz = math.sqrt(1 - q)
        rd = (2 * nz * nx, 2 * nz * ny, 2 * nz * nz - 1)
        x = (cx + 0.5 - W / 2 + r * nx, H / 2 - cy - 0.5 + r * ny, r + r * nz)
        l = norm(tuple(lamp[i] - x[i] for i in range(3)))
        c = sum(rd[i] * l[i] for i in range(3))
        return 0.02 + 0.03 * nz + 3.0 * math.exp(-(1 - c) / 4e-3)
    x = (px + 0.5 - W / 2, H / 2 - py - 0.5, 0.0)
    l = norm(tuple(lamp[i] - x[i] for i in range(3)))
    return (0.45 + 0.15 * math.sin(px * 0.21) * math.cos(py * 0.17)) * max(0.0, l[2])


def png16(path, rows):
    raw = b"".join(b"\0" + b"".join(struct.pack(">HHH", v, v, v) for v in row) for row in rows)
    chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
    data = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", W, H, 16, 2, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))
    with open(path, "wb") as f:
        f.write(data)


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    lamps = lights()
    for i, lamp in enumerate(lamps):
        rows = []
        for y in range(H):
            row = []
            for x in range(W):
                # 4 × 4 samples on the spheres (the highlight is a few pixels), 2 × 2 elsewhere.
                m = 4 if any(abs(x - cx) < r + 2 and abs(y - cy) < r + 2
                             for cx, cy, r in BALLS) else 2
                acc = sum(pixel(x - 0.5 + (sx + 0.5) / m, y - 0.5 + (sy + 0.5) / m, lamp)
                          for sy in range(m) for sx in range(m)) / (m * m)
                row.append(int(round(min(1.0, acc) * 65535)))
            rows.append(row)
        png16(os.path.join(out, "img_%02d.png" % i), rows)
    with open(os.path.join(out, "truth_positions.txt"), "w") as f:
        for p in lamps:
            f.write("%.6f %.6f %.6f\n" % p)


main()
