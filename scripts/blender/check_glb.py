"""Checks that Blender's fresh export of the courtyard is the committed asset and that the
asset has what a production asset needs: cut-out cards, a normal-mapped wall,
linked-duplicate crates.

    python check_glb.py FRESH.glb COMMITTED.glb

Equal means: the binary chunks byte for byte and the JSON equal but for asset.generator (a
later Blender 4.5.x names itself there). Then, in the committed GLB: a material with alphaMode
MASK and a base colour texture with alpha (the foliage cards), one with normalTexture on a
mesh with TANGENT (the wall), and one mesh that several nodes place (the crates). Exits 1,
saying what differs or is missing; 3 (a warning) where the two differ but were written by
different Blender versions, so the difference may be Blender's, not the script's.
"""

import json
import struct
import sys


def chunks(path):
    b = open(path, "rb").read()
    n = struct.unpack("<I", b[12:16])[0]
    doc = json.loads(b[20:20 + n])
    return doc, b[20 + n:]


def main():
    fresh, committed = sys.argv[1:3]
    (a, abin), (b, bbin) = chunks(fresh), chunks(committed)
    generators = a["asset"].pop("generator", None), b["asset"].pop("generator", None)
    if (a != b or abin != bbin) and generators[0] != generators[1]:
        # Another Blender 4.5.x (pip takes the newest) may unwrap or export a little
        # differently: production.sh then checks the fresh export against Cycles instead.
        print(f"check_glb: warning: {fresh} (by {generators[0]}) differs from {committed} "
              f"(by {generators[1]}); checking the fresh export", file=sys.stderr)
        sys.exit(3)
    if a != b or abin != bbin:
        sys.exit(f"check_glb: {fresh} (by {generators[0]}) differs from {committed} (by {generators[1]}): "
                 "make_production.py or Blender changed the asset; rerun make_production.py OUT --no-bake "
                 "and commit OUT/courtyard.glb if the change is meant")
    masked = [m["name"] for m in b["materials"] if m.get("alphaMode") == "MASK"
              and "baseColorTexture" in m.get("pbrMetallicRoughness", {})]
    mapped = {i for i, m in enumerate(b["materials"]) if "normalTexture" in m}
    tangent_mapped = [mesh["name"] for mesh in b["meshes"] for p in mesh["primitives"]
                      if p.get("material") in mapped and "TANGENT" in p["attributes"]]
    uses = {}
    for node in b["nodes"]:
        if "mesh" in node:
            uses[node["mesh"]] = uses.get(node["mesh"], 0) + 1
    shared = {b["meshes"][m]["name"]: k for m, k in uses.items() if k > 1}
    missing = [what for what, found in (("an alphaMode MASK material with a texture", masked),
                                        ("a normal-mapped primitive with TANGENT", tangent_mapped),
                                        ("a mesh placed by several nodes", shared)) if not found]
    if missing:
        sys.exit(f"check_glb: {committed} lacks {'; '.join(missing)}")
    print(f"check_glb: {committed} is Blender's export ({generators[0]}); cut-out materials {masked}, "
          f"normal-mapped meshes {tangent_mapped}, shared meshes {shared} (nodes each)")


main()
