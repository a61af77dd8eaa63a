#!/usr/bin/env python3
"""Write a stress scene of loose tiny triangles: N triangles (default 1,000,000) of about
4 mm a side, no two sharing a vertex, randomly oriented, filling a 1 x 0.5 x 1 m box 0.2 m
above the floor, all in one mesh of one node (.glb).

With no shared edges every edge of every triangle is a silhouette edge: the case where
`silhouette` (and `analytic`) must walk more edges than `traced` spends on its rays
(scenes/stress/triangle-soup.toml). A fixed seed: the same bytes on every run.

    python3 scripts/triangle-soup.py N OUT.glb
"""
import array
import math
import random
import sys

from glb import write_glb


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
    out = sys.argv[2] if len(sys.argv) > 2 else "out/triangle-soup-%d.glb" % n
    rng = random.Random(20261206)
    edge = 0.004
    pos = array.array("f")
    for _ in range(n):
        cx, cy, cz = rng.uniform(-0.5, 0.5), rng.uniform(0.2, 0.7), rng.uniform(-0.5, 0.5)
        # two random orthonormal in-plane axes from a random normal
        z = rng.uniform(-1.0, 1.0)
        a = rng.uniform(0.0, 2.0 * math.pi)
        r = math.sqrt(1.0 - z * z)
        nx, ny, nz = r * math.cos(a), r * math.sin(a), z
        hx, hy, hz = (1.0, 0.0, 0.0) if abs(nx) < 0.9 else (0.0, 1.0, 0.0)
        ux, uy, uz = hy * nz - hz * ny, hz * nx - hx * nz, hx * ny - hy * nx
        ul = math.sqrt(ux * ux + uy * uy + uz * uz)
        ux, uy, uz = ux / ul, uy / ul, uz / ul
        vx, vy, vz = ny * uz - nz * uy, nz * ux - nx * uz, nx * uy - ny * ux
        s = edge / math.sqrt(3.0)  # circumradius of an equilateral triangle of side `edge`
        for k in range(3):
            t = 2.0 * math.pi * k / 3.0
            c, d = s * math.cos(t), s * math.sin(t)
            pos.extend((cx + c * ux + d * vx, cy + c * uy + d * vy, cz + c * uz + d * vz))
    nv = 3 * n
    lo = [min(pos[k::3]) for k in range(3)]
    hi = [max(pos[k::3]) for k in range(3)]
    bin_ = bytearray(pos.tobytes())
    while len(bin_) % 4:
        bin_ += b"\0"
    doc = {
        "asset": {"version": "2.0", "generator": "scripts/triangle-soup.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "soup", "mesh": 0}],
        "meshes": [{"name": "soup", "primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
        "materials": [{"name": "grey", "doubleSided": True, "pbrMetallicRoughness": {
            "baseColorFactor": [0.6, 0.6, 0.6, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}],
        "buffers": [{"byteLength": len(bin_)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 12 * nv, "target": 34962}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": nv, "type": "VEC3",
                       "min": lo, "max": hi}],
    }
    total = write_glb(out, doc, bin_)
    print("%s: %d loose triangles (%d vertices), %d bytes" % (out, n, nv, total))


if __name__ == "__main__":
    main()
