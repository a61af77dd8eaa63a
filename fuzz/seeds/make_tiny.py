#!/usr/bin/env python3
"""Writes the small hand-made seeds of the `gltf` fuzz target into seeds/gltf/ (committed;
rerun only to change them). Each seed is one input of the target: a .glb, or a .gltf JSON
document + NUL + the bytes of its external buffer `b.bin` (see fuzz/src/lib.rs). Together
they reach what the real scenes rarely do: strips and fans, u8/u16/u32 indices, normals,
texture coordinates, textures from a file, from a buffer view and from a data URI, the
texture transform, alpha masks, sparse accessors, matrices and TRS, mirroring, cameras,
emissive rectangles, several scenes."""

import base64
import json
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "gltf")

FLOAT, U8, U16, U32 = 5126, 5121, 5123, 5125


def png_rgba(w, h):
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)

    raw = b"".join(b"\x00" + b"".join(bytes([x * 60, y * 60, 128, 255 if (x + y) % 2 else 0])
                                      for x in range(w)) for y in range(h))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


class Doc:
    def __init__(self):
        self.bin = bytearray()
        self.d = {"asset": {"version": "2.0"}, "bufferViews": [], "accessors": [], "meshes": [],
                  "nodes": [], "scenes": []}

    def view(self, data, target=None):
        while len(self.bin) % 4:
            self.bin.append(0)
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target:
            v["target"] = target
        self.bin += data
        self.d["bufferViews"].append(v)
        return len(self.d["bufferViews"]) - 1

    def accessor(self, values, ctype, typ, ncomp, target=34962, minmax=False, normalized=False):
        fmt = {FLOAT: "f", U8: "B", U16: "H", U32: "I"}[ctype]
        flat = [c for v in values for c in (v if isinstance(v, (list, tuple)) else [v])]
        data = struct.pack("<%d%s" % (len(flat), fmt), *flat)
        a = {"bufferView": self.view(data, target), "componentType": ctype, "count": len(values), "type": typ}
        if normalized:
            a["normalized"] = True
        if minmax:
            a["min"] = [min(v[i] for v in values) for i in range(ncomp)]
            a["max"] = [max(v[i] for v in values) for i in range(ncomp)]
        self.d["accessors"].append(a)
        return len(self.d["accessors"]) - 1

    def positions(self, ps):
        return self.accessor(ps, FLOAT, "VEC3", 3, minmax=True)

    def mesh(self, prims):
        self.d["meshes"].append({"primitives": prims})
        return len(self.d["meshes"]) - 1

    def node(self, **kw):
        self.d["nodes"].append(kw)
        return len(self.d["nodes"]) - 1

    def add(self, key, value):
        self.d.setdefault(key, []).append(value)
        return len(self.d[key]) - 1

    def finish(self, glb):
        self.d["buffers"] = [{"byteLength": len(self.bin)}]
        if not glb:
            self.d["buffers"][0]["uri"] = "b.bin"
        return self.d, bytes(self.bin)


def write(name, doc, glb):
    d, b = doc.finish(glb)
    js = json.dumps(d, separators=(",", ":")).encode()
    if glb:
        js += b" " * (-len(js) % 4)
        b += b"\x00" * (-len(b) % 4)
        body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(b), 0x004E4942) + b
        data = b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body
    else:
        data = js + b"\x00" + b
    with open(os.path.join(OUT, name), "wb") as f:
        f.write(data)


QUAD = [[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]]


def tri():
    """One triangle under a camera node (TRS), .gltf + b.bin."""
    doc = Doc()
    p = doc.positions([[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    m = doc.mesh([{"attributes": {"POSITION": p}}])
    cam = doc.add("cameras", {"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}})
    child = doc.node(mesh=m, translation=[0, 0, -3])
    root = doc.node(camera=cam, children=[child], rotation=[0, 0.3826834, 0, 0.9238795], scale=[2, 2, 2])
    doc.d["scenes"].append({"nodes": [root]})
    doc.d["scene"] = 0
    write("tri.gltf", doc, glb=False)


def emissive_quad():
    """An emissive rectangle (u16 indices, emissive strength) and a perspective camera, .glb."""
    doc = Doc()
    p = doc.positions(QUAD)
    i = doc.accessor([0, 1, 2, 0, 2, 3], U16, "SCALAR", 1, target=34963)
    lamp = doc.add("materials", {"emissiveFactor": [1, 0.9, 0.8],
                                 "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 5}}})
    floor = doc.add("materials", {"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.6, 0.7, 1]},
                                  "doubleSided": True})
    lm = doc.mesh([{"attributes": {"POSITION": p}, "indices": i, "material": lamp}])
    fm = doc.mesh([{"attributes": {"POSITION": p}, "indices": i, "material": floor}])
    cam = doc.add("cameras", {"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.1, "zfar": 100}})
    lamp_node = doc.node(mesh=lm, matrix=[1, 0, 0, 0, 0, -1, 0, 0, 0, 0, -1, 0, 0, 3, 0, 1])
    floor_node = doc.node(mesh=fm, scale=[5, 1, 5])
    cam_node = doc.node(camera=cam, translation=[0, 1, 6])
    doc.d["scenes"].append({"nodes": [cam_node, lamp_node, floor_node]})
    doc.d["extensionsUsed"] = ["KHR_materials_emissive_strength"]
    write("emissive-quad.glb", doc, glb=True)


def strip_fan_textured():
    """A strip (u8 indices) and a fan (none) with normals, u16 normalized texture
    coordinates, a masked material textured from t.png with a sampler and a transform."""
    doc = Doc()
    p = doc.positions(QUAD)
    n = doc.accessor([[0, 1, 0]] * 4, FLOAT, "VEC3", 3)
    uv = doc.accessor([[0, 0], [65535, 0], [65535, 65535], [0, 65535]], U16, "VEC2", 2, normalized=True)
    uv1 = doc.accessor([[0, 0], [1, 0], [1, 1], [0, 1]], FLOAT, "VEC2", 2)
    si = doc.accessor([0, 1, 3, 2], U8, "SCALAR", 1, target=34963)
    img = doc.add("images", {"uri": "t.png"})
    smp = doc.add("samplers", {"wrapS": 33648, "wrapT": 33071, "magFilter": 9728})
    tex = doc.add("textures", {"source": img, "sampler": smp})
    mat = doc.add("materials", {
        "alphaMode": "MASK", "alphaCutoff": 0.4,
        "pbrMetallicRoughness": {"baseColorTexture": {"index": tex, "texCoord": 0, "extensions": {
            "KHR_texture_transform": {"offset": [0.5, 0], "rotation": 0.5, "scale": [2, 2], "texCoord": 1}}}}})
    blend = doc.add("materials", {"alphaMode": "BLEND"})
    m = doc.mesh([
        {"attributes": {"POSITION": p, "NORMAL": n, "TEXCOORD_0": uv, "TEXCOORD_1": uv1}, "indices": si,
         "mode": 5, "material": mat},
        {"attributes": {"POSITION": p, "NORMAL": n}, "mode": 6, "material": blend},
        {"attributes": {"POSITION": p}, "mode": 1},
    ])
    a = doc.node(mesh=m, scale=[1, 1, -1])
    b = doc.node(mesh=m, translation=[0, 1, 0])
    doc.d["scenes"].append({"nodes": [a, b]})
    doc.d["extensionsUsed"] = ["KHR_texture_transform"]
    write("strip-fan-textured.gltf", doc, glb=False)


def png_in_view():
    """A PNG in a buffer view and one in a data URI, u32 indices, float texture coordinates, .glb."""
    doc = Doc()
    p = doc.positions(QUAD)
    uv = doc.accessor([[0, 0], [1, 0], [1, 1], [0, 1]], FLOAT, "VEC2", 2)
    i = doc.accessor([0, 1, 2, 2, 3, 0], U32, "SCALAR", 1, target=34963)
    png = png_rgba(3, 2)
    img_view = doc.add("images", {"bufferView": doc.view(png), "mimeType": "image/png"})
    img_uri = doc.add("images", {"uri": "data:image/png;base64," + base64.b64encode(png_rgba(1, 1)).decode()})
    t0 = doc.add("textures", {"source": img_view})
    t1 = doc.add("textures", {"source": img_uri})
    m0 = doc.add("materials", {"pbrMetallicRoughness": {"baseColorTexture": {"index": t0}}})
    m1 = doc.add("materials", {"pbrMetallicRoughness": {"baseColorTexture": {"index": t1}}})
    m = doc.mesh([{"attributes": {"POSITION": p, "TEXCOORD_0": uv}, "indices": i, "material": m0},
                  {"attributes": {"POSITION": p, "TEXCOORD_0": uv}, "indices": i, "material": m1}])
    doc.d["scenes"].append({"nodes": [doc.node(mesh=m)]})
    write("png-in-view.glb", doc, glb=True)


def sparse_and_data_uri():
    """A sparse accessor (substituting one vertex) and a second buffer given as a data URI."""
    doc = Doc()
    p = doc.positions([[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    idx = doc.view(struct.pack("<H", 2))
    val = doc.view(struct.pack("<3f", 0, 2, 0))
    doc.d["accessors"][p]["sparse"] = {"count": 1, "indices": {"bufferView": idx, "componentType": U16},
                                       "values": {"bufferView": val}}
    doc.d["accessors"][p]["max"] = [1, 2, 0]
    extra = struct.pack("<9f", 0, 0, 1, 1, 0, 1, 0, 1, 1)
    doc.d["bufferViews"].append({"buffer": 1, "byteOffset": 0, "byteLength": len(extra)})
    q = len(doc.d["accessors"])
    doc.d["accessors"].append({"bufferView": len(doc.d["bufferViews"]) - 1, "componentType": FLOAT,
                               "count": 3, "type": "VEC3", "min": [0, 0, 1], "max": [1, 1, 1]})
    m = doc.mesh([{"attributes": {"POSITION": p}}, {"attributes": {"POSITION": q}}])
    doc.d["scenes"].append({"nodes": [doc.node(mesh=m)]})
    d, b = doc.finish(glb=False)
    d["buffers"].append({"byteLength": len(extra),
                         "uri": "data:application/octet-stream;base64," + base64.b64encode(extra).decode()})
    with open(os.path.join(OUT, "sparse-data-uri.gltf"), "wb") as f:
        f.write(json.dumps(d, separators=(",", ":")).encode() + b"\x00" + b)


def hierarchy():
    """Nested nodes (matrix, TRS, a mirror), one mesh used by several nodes, two scenes with
    the second the default, .glb."""
    doc = Doc()
    p = doc.positions([[0, 0, 0], [1, 0, 0], [0, 0, -1]])
    m = doc.mesh([{"attributes": {"POSITION": p}}])
    leaf1 = doc.node(mesh=m, scale=[-1, 1, 1])
    leaf2 = doc.node(mesh=m, rotation=[0.7071068, 0, 0, 0.7071068])
    mid = doc.node(children=[leaf1, leaf2], matrix=[2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 1, 2, 3, 1])
    top = doc.node(children=[mid], translation=[0, 1, 0], mesh=m)
    other = doc.node(mesh=m)
    doc.d["scenes"] += [{"nodes": [other]}, {"nodes": [top]}]
    doc.d["scene"] = 1
    write("hierarchy.glb", doc, glb=True)


if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    for f in (tri, emissive_quad, strip_fan_textured, png_in_view, sparse_and_data_uri, hierarchy):
        f()
