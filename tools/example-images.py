#!/usr/bin/env python3
"""Writes the example programs' images (examples/*.png), procedurally, so
that every example checks and renders without stand-ins:

    python3 tools/example-images.py examples
"""
import math, struct, zlib, sys, os

def png(path, w, h, px):
    raw = b"".join(b"\x00" + bytes(px[y*w*4:(y+1)*w*4]) for y in range(h))
    def chunk(t, d):
        c = struct.pack(">I", len(d)) + t + d
        return c + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)) \
        + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    open(path, "wb").write(data)

def clamp(v): return max(0, min(255, int(round(v * 255))))

def noise(x, y, seed):
    # value noise on a 8x8 lattice, smooth, tileable over 128
    def h(i, j):
        i %= 8; j %= 8
        n = (i * 374761393 + j * 668265263 + seed * 982451653) & 0xffffffff
        n = (n ^ (n >> 13)) * 1274126177 & 0xffffffff
        return (n & 0xffff) / 65535.0
    fx, fy = x / 16.0, y / 16.0
    i, j = int(math.floor(fx)), int(math.floor(fy))
    tx, ty = fx - i, fy - j
    sx, sy = tx * tx * (3 - 2 * tx), ty * ty * (3 - 2 * ty)
    a = h(i, j) * (1 - sx) + h(i + 1, j) * sx
    b = h(i, j + 1) * (1 - sx) + h(i + 1, j + 1) * sx
    return a * (1 - sy) + b * sy

def image(fn, w=128, h=128):
    px = []
    for y in range(h):
        for x in range(w):
            r, g, b, a = fn(x, y, w, h)
            px += [clamp(r), clamp(g), clamp(b), clamp(a)]
    return px

def brick(x, y, w, h):
    row = y // 16
    off = 16 if row % 2 else 0
    mortar = (y % 16) < 2 or ((x + off) % 32) < 2
    n = noise(x, y, 1) * 0.15
    return (0.8, 0.78, 0.72, 1) if mortar else (0.62 + n, 0.26 + n / 2, 0.18, 1)

def wood(x, y, w, h):
    d = math.hypot(x - 40, (y - 200) * 0.35) + noise(x, y, 2) * 6
    ring = 0.5 + 0.5 * math.sin(d * 0.9)
    return (0.55 + 0.2 * ring, 0.35 + 0.12 * ring, 0.18 + 0.05 * ring, 1)

def paper(x, y, w, h):
    n = 0.9 + 0.08 * noise(x * 4 % 128, y * 4 % 128, 3)
    return (n, n * 0.98, n * 0.92, 1)

def layer(x, y, w, h):
    c = ((x // 16) + (y // 16)) % 2
    return (0.9, 0.85, 0.3, 1) if c else (0.2, 0.4, 0.8, 1)

def base(x, y, w, h):
    n = noise(x, y, 4)
    return (0.45 + 0.3 * n, 0.45 + 0.25 * n, 0.4 + 0.2 * n, 1)

def lightmap(x, y, w, h):
    v = 0.25
    for cx, cy in ((32, 40), (96, 88)):
        v += 0.75 * math.exp(-((x - cx) ** 2 + (y - cy) ** 2) / 500.0)
    return (v, v * 0.95, v * 0.85, 1)

def detail(x, y, w, h):
    n = 0.75 + 0.25 * noise(x * 2 % 128, y * 2 % 128, 5)
    return (n, n, n, 1)

def decal(x, y, w, h):
    d = math.hypot(x - 63.5, y - 63.5)
    inside = d < 40
    star = 0.5 + 0.5 * math.cos(5 * math.atan2(y - 63.5, x - 63.5))
    if not inside:
        return (0, 0, 0, 0)
    return (0.9, 0.2 + 0.6 * star, 0.1, 1)

def sky(dx, dy, dz):
    # y up: sky above, ground below, a sun
    if dy > 0:
        c = (0.35 + 0.4 * (1 - dy), 0.55 + 0.35 * (1 - dy), 0.95)
    else:
        c = (0.35, 0.3 + 0.1 * dy, 0.2)
    s = max(0.0, dx * 0.48 + dy * 0.6 + dz * 0.64) ** 64
    return tuple(min(1.0, v + s) for v in c) + (1,)

def environment(x, y, w, h):
    # EMBM's environment: a view of the sky as a plain 2-D image.
    u, v = (x + 0.5) / w * 2 - 1, 1 - (y + 0.5) / h * 2
    return sky(u * 0.8, v, 0.6)

def mirror_ball(x, y, w, h):
    # A sphere map (GL's texgen SPHERE_MAP): the reflection on a mirror ball.
    u, v = (x + 0.5) / w * 2 - 1, 1 - (y + 0.5) / h * 2
    r2 = u * u + v * v
    if r2 > 1:
        return (0, 0, 0, 1)
    nz = math.sqrt(1 - r2)
    # reflect the view (0, 0, -1) about n = (u, v, nz)
    rx, ry, rz = 2 * nz * u, 2 * nz * v, 2 * nz * nz - 1
    return sky(rx, ry, rz)

def bumps(x, y, w, h):
    # A height field of golf-ball dimples on a 4×4 lattice (Kilgard's torus).
    cx, cy = (x % 32) - 15.5, (y % 32) - 15.5
    r2 = (cx * cx + cy * cy) / (12.0 * 12.0)
    v = 1.0 - 0.8 * max(0.0, 1.0 - r2) ** 1.5
    return (v, v, v, 1)

out = sys.argv[1]
for name, fn in [("brick", brick), ("wood", wood), ("paper", paper), ("layer", layer), ("base", base),
                 ("lightmap", lightmap), ("detail", detail), ("decal", decal), ("environment", environment),
                 ("mirror_ball", mirror_ball), ("bumps", bumps)]:
    png(os.path.join(out, name + ".png"), 128, 128, image(fn))
