"""Writes a binary glTF (.glb): the JSON document and one BIN chunk, each padded to 4 bytes
(JSON with spaces, BIN with zeros). Shared by the scripts that generate stress scenes."""
import json
import struct


def write_glb(path, doc, bin_):
    """Writes `doc` (a dict whose buffers[0].byteLength is len(bin_)) and `bin_`; returns the
    file's size in bytes."""
    js = json.dumps(doc, separators=(",", ":"), sort_keys=True).encode()
    js += b" " * (-len(js) % 4)
    bin_ = bytes(bin_) + b"\0" * (-len(bin_) % 4)
    total = 12 + 8 + len(js) + 8 + len(bin_)
    with open(path, "wb") as fh:
        fh.write(struct.pack("<III", 0x46546C67, 2, total))
        fh.write(struct.pack("<II", len(js), 0x4E4F534A) + js)
        fh.write(struct.pack("<II", len(bin_), 0x004E4942) + bin_)
    return total
