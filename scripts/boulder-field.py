#!/usr/bin/env python3
"""Write a stress scene for instanced, dense, smooth meshes: a field of N boulders (.glb).

The file holds ONE mesh, a boulder: an icosphere subdivided 6 times (81,920 triangles,
40,962 vertices, indexed, per-vertex normals), radius about 0.5 m, its vertices moved
radially by a smooth low-frequency noise (three sines of the direction, up to +-15%) so it
is not a sphere. N nodes (default 100) all reference that mesh, each with its own
translation (a jittered grid on the XZ plane, y so the boulder rests on y = 0), rotation
about Y and uniform scale in 0.6..1.4. Everything comes from a fixed seed: the same bytes
on every run. It exercises a renderer that flattens instances into world triangles
(N x 81,920 of them) and shadow methods whose cost grows with smooth-mesh edges.

    python3 scripts/boulder-field.py N OUT.glb [LEVELS]   (scenes/stress/boulder-field.toml)

LEVELS (default 6) sets the icosphere's subdivisions: 4 gives 5,120 triangles a boulder
(scenes/models/boulder-field-400.glb, the bench's instanced scene, is `400 ... 4`).
"""
import math
import random
import struct
import sys

from glb import write_glb


def boulder(levels=6, radius=0.5, amp=0.15):
    t = (1 + 5 ** 0.5) / 2
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
             (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    verts = [tuple(c / math.sqrt(sum(x * x for x in v)) for c in v) for v in verts]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(levels):
        cache, out = {}, []

        def mid(a, b):
            key = (a, b) if a < b else (b, a)
            if key not in cache:
                m = [(p + q) / 2 for p, q in zip(verts[a], verts[b])]
                n = math.sqrt(sum(x * x for x in m))
                verts.append(tuple(x / n for x in m))
                cache[key] = len(verts) - 1
            return cache[key]

        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            out += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = out

    def noise(x, y, z):  # smooth, low frequency, in [-1, 1]
        return (0.5 * math.sin(2.1 * x + 1.3 * y + 0.7) + 0.3 * math.sin(3.3 * y - 1.7 * z + 2.1)
                + 0.2 * math.sin(2.7 * z + 2.9 * x + 4.0))

    pos = [tuple(radius * (1 + amp * noise(*d)) * c for c in d) for d in verts]
    nrm = [[0.0, 0.0, 0.0] for _ in pos]
    for f in faces:  # area-weighted face normals, summed at the vertices
        p, q, r = (pos[i] for i in f)
        e1 = [q[k] - p[k] for k in range(3)]
        e2 = [r[k] - p[k] for k in range(3)]
        n = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0])
        for i in f:
            for k in range(3):
                nrm[i][k] += n[k]
    nrm = [tuple(c / math.sqrt(sum(x * x for x in n)) for c in n) for n in nrm]
    return pos, nrm, faces


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 100
    out = sys.argv[2] if len(sys.argv) > 2 else "out/boulder-field-%d.glb" % n
    levels = int(sys.argv[3]) if len(sys.argv) > 3 else 6
    pos, nrm, faces = boulder(levels)
    # float32 round trip so min/max match the stored bytes exactly
    pos = [struct.unpack("<3f", struct.pack("<3f", *p)) for p in pos]
    idx_fmt, idx_type = ("<H", 5123) if len(pos) < 65536 else ("<I", 5125)
    bin_ = bytearray()
    for p in pos:
        bin_ += struct.pack("<3f", *p)
    for v in nrm:
        bin_ += struct.pack("<3f", *v)
    for f in faces:
        for i in f:
            bin_ += struct.pack(idx_fmt, i)
    while len(bin_) % 4:
        bin_ += b"\0"
    nv, vb = len(pos), 12 * len(pos)
    ymin = min(p[1] for p in pos)

    rng = random.Random(20261128)
    side = math.ceil(math.sqrt(n))
    spacing = 1.25
    nodes = []
    for i in range(n):
        gx, gz = i % side, i // side
        s = 0.6 + 0.8 * rng.random()
        a = 2 * math.pi * rng.random()
        x = (gx - (side - 1) / 2) * spacing + rng.uniform(-0.2, 0.2)
        z = (gz - (side - 1) / 2) * spacing + rng.uniform(-0.2, 0.2)
        nodes.append({"name": "boulder-%d" % i, "mesh": 0,
                      "translation": [round(x, 6), round(-ymin * s, 6), round(z, 6)],
                      "rotation": [0.0, round(math.sin(a / 2), 8), 0.0, round(math.cos(a / 2), 8)],
                      "scale": [round(s, 6)] * 3})
    doc = {
        "asset": {"version": "2.0", "generator": "scripts/boulder-field.py"},
        "scene": 0,
        "scenes": [{"nodes": list(range(n))}],
        "nodes": nodes,
        "meshes": [{"name": "boulder", "primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}],
        "materials": [{"name": "stone", "pbrMetallicRoughness": {
            "baseColorFactor": [0.55, 0.5, 0.45, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}],
        "buffers": [{"byteLength": len(bin_)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": vb, "target": 34962},
            {"buffer": 0, "byteOffset": vb, "byteLength": vb, "target": 34962},
            {"buffer": 0, "byteOffset": 2 * vb, "byteLength": 3 * len(faces) * struct.calcsize(idx_fmt),
             "target": 34963}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": nv, "type": "VEC3",
             "min": [min(p[k] for p in pos) for k in range(3)],
             "max": [max(p[k] for p in pos) for k in range(3)]},
            {"bufferView": 1, "componentType": 5126, "count": nv, "type": "VEC3"},
            {"bufferView": 2, "componentType": idx_type, "count": 3 * len(faces), "type": "SCALAR"}],
    }
    total = write_glb(out, doc, bin_)
    print("%s: %d nodes x %d triangles (%d vertices), %d bytes" % (out, n, len(faces), nv, total))


if __name__ == "__main__":
    main()
