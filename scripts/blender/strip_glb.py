"""Writes a copy of a GLB with one feature taken out of every material, so a bake of it is
prt-bake ignoring that feature (the production check's "must fail" cases).

    python strip_glb.py IN.glb OUT.glb alpha|normal

alpha: alphaMode and alphaCutoff removed (every card opaque); normal: normalTexture removed
(the wall flat). The binary chunk is kept byte for byte; only the JSON chunk changes.
"""

import json
import struct
import sys


def main():
    src, dst, what = sys.argv[1:4]
    b = open(src, "rb").read()
    n = struct.unpack("<I", b[12:16])[0]
    doc = json.loads(b[20:20 + n])
    keys = {"alpha": ("alphaMode", "alphaCutoff"), "normal": ("normalTexture",)}[what]
    removed = 0
    for mat in doc.get("materials", []):
        for k in keys:
            removed += mat.pop(k, None) is not None
    if not removed:
        sys.exit(f"strip_glb: {src}: no material has {' or '.join(keys)}")
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    rest = b[20 + n:]
    total = 12 + 8 + len(text) + len(rest)
    out = b[:8] + struct.pack("<I", total) + struct.pack("<I", len(text)) + b"JSON" + text + rest
    open(dst, "wb").write(out)


main()
