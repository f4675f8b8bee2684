"""Tests prt.py against `prt-bake export --npz` and `prt-bake inspect` on every variant:
grey and RGB transfer, orders 1, 3, 4 and 5, with and without the aux arrays, z- and y-up,
transfer matrices (orders 2 and 3, shadowed and unshadowed, y-up),
an adaptive bake (rays cast, estimated errors), texel (lightmap) bakes, a file of some
objects (--receivers) and probe bakes (a grid, and a list of points); that a shard part
is refused; and that corrupted or truncated files of each kind are refused with the reason.
Usage: test_prt.py PRT_BAKE OUT_DIR."""

import json
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from prt import PrtError, parse_prt, read_prt  # noqa: E402

bake_bin, out = sys.argv[1], Path(sys.argv[2])
out.mkdir(parents=True, exist_ok=True)
root = Path(__file__).resolve().parents[2]
cornell = str(root / "scenes/cornell/cornell.scene")
torus = str(root / "scenes/torus/torus.scene")

# name: (scene, bake options); --samples 32 unless given.
VARIANTS = {
    "grey-order3-aux": (torus, ["--order", "3", "--aux", "ao,bent-normal"]),
    "rgb-order5-ao": (cornell, ["--order", "5", "--mode", "interreflected", "--aux", "ao"]),
    "grey-order1-unshadowed": (cornell, ["--order", "1", "--mode", "unshadowed"]),
    "grey-order4-y-up": (cornell, ["--up", "y"]),
    # Adaptive bakes are shadowed; --target-error needs --samples >= 256. 3e-3 spreads the
    # per-vertex rays cast over 256 and more on the Cornell box.
    "adaptive-aux": (cornell, ["--samples", "4096", "--target-error", "3e-3", "--aux", "ao,bent-normal"]),
    "adaptive-lightmap16": (cornell, ["--lightmap", "16", "--samples", "4096", "--target-error", "3e-3"]),
    "lightmap16-aux": (cornell, ["--lightmap", "16", "--samples", "16", "--aux", "ao,bent-normal"]),
    # 21² = 441 state bytes: the payload is not a whole number of floats.
    "lightmap21-texel-size-unshadowed": (cornell, ["--lightmap", "21", "--texel-size", "1", "--order", "3",
                                                   "--mode", "unshadowed"]),
    "matrix-order3-aux": (torus, ["--transfer", "matrix", "--order", "3", "--aux", "ao"]),
    "matrix-order2-unshadowed-y-up": (cornell, ["--transfer", "matrix", "--order", "2", "--mode", "unshadowed",
                                                "--up", "y"]),
    "probes-grid-rgb": (cornell, ["--probes", "grid:3,2,2", "--order", "3", "--mode", "interreflected"]),
    "probes-list": (cornell, ["--probes", str(out / "probe-points.txt"), "--order", "2"]),
}
(out / "probe-points.txt").write_text("# three probes\n0 0 0.5\n0.25 -0.3 1.2\n\n-0.5 0.5 1.9\n")
# What export writes from the scene rather than from the file.
SCENE_ARRAYS = {"positions", "normals", "albedo", "uv", "triangles", "texel_positions", "texel_normals"}


def run(*args):
    return subprocess.run([bake_bin, *args], check=True, capture_output=True, text=True).stdout


def arrays_of(f):
    """prt.py's arrays under the names export --npz gives them."""
    if f.probes is not None:
        # A probe file has no aux arrays; export names its arrays apart.
        return {"probe_transfer": f.transfer, "probe_positions": f.probes["positions"],
                "probe_backface_fraction": f.probes["backface_fraction"]}
    ours = {"transfer_matrix" if f.header["transfer"] == "matrix" else "transfer": f.transfer, "ao": f.ao, "bent_normal": f.bent_normal, "rays": f.rays,
            "error_estimate": f.error_estimate}
    if f.lightmap is not None:
        ours.update(uv1=f.lightmap.uv1, texel_valid=f.lightmap.valid, texel_dilated=f.lightmap.dilated)
    return {name: array for name, array in ours.items() if array is not None}


def nearest_rank_summary(values):
    """adaptive::Distribution: min, nearest-rank median and p95, max, mean."""
    s = np.sort(values.ravel().astype(np.float64))
    rank = lambda q: s[min(max(int(np.ceil(q * len(s))), 1), len(s)) - 1]  # noqa: E731
    return {"min": s[0], "median": rank(0.5), "p95": rank(0.95), "max": s[-1], "mean": s.mean()}


def same_summary(ours, theirs):
    return all(np.isclose(ours[k], theirs[k], rtol=1e-12, atol=0) for k in ours) and ours.keys() == theirs.keys()


for name, (scene, extra) in VARIANTS.items():
    prt, npz = out / f"{name}.prt", out / f"{name}.npz"
    samples = [] if "--samples" in extra else ["--samples", "32"]
    run("bake", scene, "-o", str(prt), "--quiet", *samples, *extra)
    run("export", str(prt), "--scene", scene, "--npz", str(npz))
    f, arrays = read_prt(prt), np.load(npz)
    inspected = json.loads(run("inspect", str(prt)))
    # inspect names the transfer kind of matrix files only.
    assert all(inspected.get(key, "vector" if key == "transfer" else None) == value
               for key, value in f.header.items()), (name, f.header, inspected)
    assert ("adaptive" in f.header) == ("adaptive" in inspected), name
    # Every array of the file, and only those, equal to the export's, shape and values.
    ours = arrays_of(f)
    assert set(ours) == set(arrays.files) - SCENE_ARRAYS, (name, set(ours), arrays.files)
    for key, array in ours.items():
        theirs = arrays[key]
        assert array.shape == theirs.shape, (name, key, array.shape, theirs.shape)
        # rays: uint32 in the file, float32 (exact below 2^24) in the npz.
        assert np.array_equal(array.astype(theirs.dtype), theirs), (name, key)
    if "triangles" in arrays:
        assert arrays["triangles"].dtype == np.uint32 and arrays["triangles"].max() < f.header["vertex_count"]
    if f.rays is not None:
        assert f.rays.dtype == np.uint32 and len(np.unique(f.rays)) > 1, (name, "rays do not vary")
        # Texel bakes summarise the baked texels only.
        baked = np.ones(f.rays.shape, bool) if f.lightmap is None else f.lightmap.valid
        per_vertex = inspected["per_vertex" if f.lightmap is None else "per_texel"]
        assert same_summary(nearest_rank_summary(f.rays[baked]), per_vertex["rays_per_vertex"]), name
        assert same_summary(nearest_rank_summary(f.error_estimate[baked]), per_vertex["estimated_error"]), name
        above = int(np.sum(f.error_estimate[baked] > np.float32(f.header["adaptive"]["target_error"])))
        assert above == per_vertex["vertices_above_target"], name
    assert (f.probes is None) == ("probes" not in inspected), name
    if f.probes is not None:
        block, grid, at = inspected["probes"], f.probes["grid"], f.probes["positions"]
        assert block["count"] == len(at) == f.header["vertex_count"], name
        assert np.array_equal(np.float32(block["min"]), at.min(0)) and np.array_equal(np.float32(block["max"]), at.max(0))
        assert (grid is None) == ("grid" not in block), name
        if grid is not None:
            assert list(grid["counts"]) == block["grid"]["counts"], name
            assert all(np.float32(block["grid"][k]).tolist() == list(grid[k]) for k in ("lo", "hi")), name
            assert np.prod(grid["counts"]) == len(at)
    lightmap = f.lightmap
    assert (lightmap is None) == ("lightmap" not in inspected), name
    if lightmap is not None:
        block = inspected["lightmap"]
        ours = {"width": lightmap.width, "height": lightmap.height, "texel_size": lightmap.texel_size,
                "scene_vertex_count": lightmap.scene_vertex_count,
                "scene_triangle_count": lightmap.scene_triangle_count,
                "baked_texels": int(lightmap.valid.sum()), "dilated_texels": int(lightmap.dilated.sum()),
                "atlas": lightmap.source}
        assert ours == block, (name, ours, block)
        assert lightmap.source == "generated" and lightmap.width * lightmap.height == f.header["vertex_count"]
        assert f.transfer.shape[:2] == (lightmap.height, lightmap.width)
    print(f"test_prt.py: {name}: transfer {f.transfer.shape}, aux {f.header['aux']}, up {f.header['up']}"
          + (f", adaptive {f.header['adaptive']}" if f.rays is not None else "")
          + (f", {lightmap.width}×{lightmap.height} lightmap, {len(lightmap.uv1)} UV triples"
             if lightmap is not None else "")
          + ": equal to the npz export and inspect")


def resealed(data):
    """data with its checksum recomputed: a file corrupted past the checksum."""
    data = bytearray(data)
    data[124:128] = bytes(4)
    data[124:128] = zlib.crc32(bytes(data)).to_bytes(4, "little")
    return bytes(data)


def patched(data, offset, value):
    """data with `value` (bytes or a NumPy scalar) written at offset, resealed."""
    value = value.tobytes() if hasattr(value, "tobytes") else value
    return resealed(data[:offset] + value + data[offset + len(value):])


def refused(data, reason, what, by_inspect=True):
    """prt.py refuses data for reason; so does the reference reader (prt-bake inspect, exit 3)
    unless by_inspect is False (inspect shows shard parts)."""
    try:
        parse_prt(data)
    except PrtError as err:
        assert reason in str(err), (what, reason, str(err))
    else:
        raise AssertionError(f"{what}: a file with a bad {reason} was read")
    broken = out / "broken.prt"
    broken.write_bytes(data)
    inspect = subprocess.run([bake_bin, "inspect", str(broken)], capture_output=True, text=True)
    assert inspect.returncode == (3 if by_inspect else 0), (what, reason, inspect.returncode, inspect.stderr)


data = (out / "grey-order3-aux.prt").read_bytes()
assert resealed(data) == data
for broken, reason in ((data[:-4], "announces"), (data[:200] + b"\0" + data[201:], "checksum"),
                       (b"not a prt" + data[9:], "magic"), (patched(data, 84, np.uint32(2)), "up axis"),
                       (patched(data, 40, np.uint32(1)), "bounces")):
    refused(broken, reason, "vertex file")
print("test_prt.py: truncated, corrupted and foreign files are refused by prt.py and by prt-bake inspect")

# A matrix file: the transfer kind is the u16 at 38 (the mode the u16 at 36).
data = (out / "matrix-order3-aux.prt").read_bytes()
f = parse_prt(data)
V = f.header["vertex_count"]
assert f.transfer.shape == (V, 1, 9, 9) and np.array_equal(f.transfer, f.transfer.transpose(0, 1, 3, 2))
for broken, reason in ((patched(data, 38, np.uint16(2)), "unknown transfer kind 2"),
                       (patched(data, 38, np.uint16(0)), "payload size"),
                       (patched(data, 36, np.uint16(3)), "unknown mode 3"),
                       (patched(data, 128 + 4 * 80, np.float32(np.inf)), "coefficient")):
    refused(broken, reason, "matrix file")
print("test_prt.py: corrupted matrix files are refused by prt.py and by prt-bake inspect")

# A probe file: the probe block at 128..176 (count u64, grid counts 3 × u32, box 6 × f32,
# reserved), then P × (channels × n⁴) coefficients, positions (P × 3), back-face fractions (P).
data = (out / "probes-grid-rgb.prt").read_bytes()
P = parse_prt(data).header["vertex_count"]
fractions_at = len(data) - 4 * P
for broken, reason in ((patched(data, 128, np.uint64(P + 1)), "the probe block counts"),
                       (patched(data, 136, np.uint32(5)), "a probe grid of 5×2×2"),
                       (patched(data, 172, np.uint32(1)), "reserved bytes 172..176"),
                       (patched(data, 38, np.uint16(0)), "vector transfer"),
                       (patched(data, fractions_at - 4, np.float32(np.nan)), "position of probe"),
                       (patched(data, fractions_at + 4, np.float32(1.5)), "back-face fraction of probe 1"),
                       (data[:-4], "announces")):
    refused(broken, reason, "probe file")
print("test_prt.py: corrupted probe files are refused by prt.py and by prt-bake inspect")

# Adaptive: payload after 128 + V*(16 + 1 + 3)*4 bytes: rays (V u32), then errors (V f32).
data = (out / "adaptive-aux.prt").read_bytes()
f = parse_prt(data)
V = f.header["vertex_count"]
rays_at = 128 + V * (16 + 1 + 3) * 4
errors_at = rays_at + 4 * V
for broken, reason in (
        (data[:-1], "announces"),
        (data[:rays_at] + b"\1" + data[rays_at + 1:], "checksum"),
        (patched(data, rays_at + 8, np.uint32(0)), "rays, outside 1..=4096"),
        (patched(data, rays_at + 8, np.uint32(4097)), "rays, outside 1..=4096"),
        (patched(data, 116, np.uint64(f.header["adaptive"]["rays_cast"] + 1)), "add up"),
        (patched(data, errors_at + 4, np.float32(np.nan)), "estimated error"),
        (patched(data, errors_at + 4, np.float32(-1)), "estimated error"),
        (patched(data, 112, np.uint32(1)), "replicates"),
        (patched(data, 108, np.float32(-1e-3)), "target error"),
        (patched(data, 108, np.float32(0)), "without a target error"),
        (patched(data, 68, np.uint32(1 | 2 | 4)), "aux bits 2 and 3"),
        (patched(data, 36, np.uint32(0)), "mode unshadowed"),
        (patched(data, 68, np.uint32(1 | 2 | 4 | 8 | 64)), "unknown auxiliary-array flags"),
        (patched(data, 128 + 4 * (V * 16), np.float32(np.nan)), "accessibility")):
    refused(broken, reason, "adaptive file")
print("test_prt.py: corrupted adaptive files are refused by prt.py and by prt-bake inspect")

# Texel: 160-byte header; the states are the last W*H bytes, the UVs the 24*T bytes before.
data = (out / "lightmap21-texel-size-unshadowed.prt").read_bytes()
f = parse_prt(data)
W, T = f.lightmap.width, f.lightmap.scene_triangle_count
states_at, uv_at = len(data) - W * W, len(data) - W * W - 24 * T
for broken, reason in (
        (data[:-1], "announces"),
        (data[:150], "truncated"),
        (data[:states_at] + b"\7" + data[states_at + 1:], "checksum"),
        (data[:130] + b"\7" + data[131:], "checksum"),  # the texel block is checksummed
        (patched(data, states_at + 5, b"\3"), "state of texel 5 is 3"),
        (patched(data, uv_at + 12, np.float32(np.inf)), "lightmap UV"),
        (patched(data, 128, np.uint32(W + 1)), "lightmap in a file"),
        (patched(data, 144, np.uint64(T - 1)), "payload size"),
        (patched(data, 152, np.float32(-1)), "texel size"),
        (patched(data, 156, np.uint32(3)), "atlas source"),
        # Source 2 (per object) needs its trailing per-object section, which this file lacks.
        (patched(data, 156, np.uint32(2)), "per-object section"),
        (patched(data, 12, np.uint32(128)), "announces"),
        (patched(data, 12, np.uint32(144)), "header size"),
        (patched(data, 160, np.float32(np.nan)), "coefficient")):
    refused(broken, reason, "texel file")
print("test_prt.py: corrupted texel files are refused by prt.py and by prt-bake inspect")

# A shard part: a bake's header with a non-zero identity and a payload of its own.
part = out / "shard-1-of-2.prt"
run("bake", cornell, "-o", str(part), "--quiet", "--samples", "16", "--shard", "1/2")
data = part.read_bytes()
assert any(data[88:108])
refused(data, "combine the parts with `prt-bake merge`", "shard part", by_inspect=False)
refused(data, "shard 1 of 2", "shard part", by_inspect=False)
refused(patched(data, 92, np.uint32(2)), "the index must be below the count", "shard part")
print("test_prt.py: a shard part is refused (merge it first)")

# A file of some objects (bake --receivers): the receivers' rows, equal to the whole bake's rows
# of those objects (the same rays), and the section as inspect prints it; a corrupted section
# is refused by both readers.
whole, part = out / "receivers-whole.prt", out / "receivers-part.prt"
run("bake", cornell, "-o", str(whole), "--quiet", "--samples", "32", "--aux", "ao")
run("bake", cornell, "-o", str(part), "--quiet", "--samples", "32", "--aux", "ao", "--receivers", "tall_box*")
f, everything = read_prt(part), read_prt(whole)
inspected = json.loads(run("inspect", str(part)))
assert f.receivers == inspected["receivers"] == f.header["receivers"], (f.receivers, inspected["receivers"])
assert len(f.receivers["objects"]) >= 1 and f.header["vertex_count"] < everything.header["vertex_count"]
# The receiving objects' vertices are one run of the scene's vertex order here (one object).
rows = len(f.transfer)
starts = [v for v in range(len(everything.transfer) - rows + 1)
          if np.array_equal(everything.transfer[v], f.transfer[0])]
assert any(np.array_equal(everything.transfer[v:v + rows], f.transfer)
           and np.array_equal(everything.ao[v:v + rows], f.ao) for v in starts), "receivers' rows"
data = part.read_bytes()
refused(patched(data, len(data) - 4, np.uint32(10**6)), "but the scene has", "receiver section")
refused(data[:-4], "announces", "receiver section")
print(f"test_prt.py: a file of {len(f.receivers['objects'])} of {f.receivers['object_count']} objects "
      f"({rows} vertices): the whole bake's rows, its section as inspect prints it")

# Compressed (version 2) files: vertex and texel, grey and RGB, a matrix file; prt.py's
# reconstruction equal to the npz export's (which reconstructs), its header to inspect's.
for name in ("grey-order3-aux", "rgb-order5-ao", "adaptive-aux", "lightmap16-aux", "matrix-order3-aux",
             "probes-grid-rgb"):
    scene = VARIANTS[name][0]
    packed, npz = out / f"{name}-cpca.prt", out / f"{name}-cpca.npz"
    run("compress", str(out / f"{name}.prt"), "-o", str(packed), "--clusters", "8", "--pcs", "3")
    run("export", str(packed), "--scene", scene, "--npz", str(npz))
    f, arrays = read_prt(packed), np.load(npz)
    inspected = json.loads(run("inspect", str(packed)))
    assert f.header["version"] == 2 and f.cpca["weights"].shape[1] == 3, name
    compression, theirs = f.header.pop("compression"), inspected.pop("compression")
    assert set(compression) == set(theirs), (name, compression, theirs)
    for key, value in compression.items():
        ok = np.isclose(value, theirs[key], rtol=1e-6) if isinstance(value, float) else value == theirs[key]
        assert ok, (name, key, value, theirs[key])
    assert all(inspected.get(key, "vector" if key == "transfer" else None) == value
               for key, value in f.header.items()), (name, f.header, inspected)
    ours = arrays_of(f)
    assert set(ours) == set(arrays.files) - SCENE_ARRAYS, (name, set(ours), arrays.files)
    for key, array in ours.items():
        assert np.array_equal(array.astype(arrays[key].dtype), arrays[key]), (name, key)
    uncompressed = read_prt(out / f"{name}.prt").transfer
    assert f.transfer.shape == uncompressed.shape and not np.array_equal(f.transfer, uncompressed), name
data = (out / "grey-order3-aux-cpca.prt").read_bytes()
K, M, D = 8, 3, 9  # grey order 3
cluster_at = 160 + 4 * (K * D + K * M * D)
for broken, reason in ((patched(data, 8, np.uint32(3)), "unsupported format version 3"),
                       (patched(data, 128 + 8, np.uint32(1)), "unknown CPCA layout"),
                       (patched(data, 160, np.float32(np.nan)), "cluster mean"),
                       (patched(data, cluster_at + 4 * 5, np.uint32(K)), "receiver 5 is in cluster 8"),
                       (data[:-4], "announces")):
    refused(broken, reason, "compressed file")
print("test_prt.py: compressed files (vertex, texel, RGB, matrix, probes) reconstructed as the npz export "
      "does; corrupted ones are refused by prt.py and by prt-bake inspect")

# The EXR export of texel bakes (prt-bake export --exr) read with OpenEXR's own Python
# bindings, against the npz export: f32 images equal the transfer, f16 ones its rounding
# (NumPy's float16 cast), the mask and aux images the npz arrays, rows flipped (image row r
# is texel row H-1-r, as the manifest says).
try:
    import OpenEXR
except ImportError:
    OpenEXR = None
    print("test_prt.py: the OpenEXR module is not installed: the EXR export is not checked")
if OpenEXR is not None:
    for name in ("lightmap16-aux", "lightmap21-texel-size-unshadowed"):
        scene = VARIANTS[name][0]
        arrays = np.load(out / f"{name}.npz")
        transfer = arrays["transfer"]
        H, W, C, n = transfer.shape
        for pixel_type, dtype in (("f32", np.float32), ("f16", np.float16)):
            d = out / f"{name}-exr-{pixel_type}"
            run("export", str(out / f"{name}.prt"), "--scene", scene, "--exr", str(d),
                "--exr-type", pixel_type)
            manifest = json.loads((d / "manifest.json").read_text())
            assert (manifest["width"], manifest["height"], manifest["channels"]) == (W, H, C), manifest
            assert manifest["pixel_type"] == pixel_type and manifest["coefficients_per_channel"] == n

            def texels(file):
                """The image's channels in texel order (row 0 is v = 0)."""
                part = OpenEXR.File(str(d / file), separate_channels=True).parts[0]
                channels = {k: c.pixels[::-1] for k, c in part.channels.items()}
                assert all(x.dtype == dtype and x.shape == (H, W) for x in channels.values()), file
                return channels

            rebuilt = np.full((H, W, C, n), np.nan, dtype)
            files = {"manifest.json", "texel_state.exr"}
            for entry in manifest["transfer"]:
                files.add(entry["file"])
                c = 0 if entry["colour_channel"] == "grey" else "rgb".index(entry["colour_channel"])
                image = texels(entry["file"])
                for channel, j in zip("RGBA", entry["rgba"]):
                    if j is None:
                        assert not image[channel].any(), (name, entry["file"], channel, "padding")
                    else:
                        rebuilt[:, :, c, j] = image[channel]
            assert np.array_equal(rebuilt, transfer.astype(dtype)), (name, pixel_type)
            state = texels("texel_state.exr")["Y"]
            expected = np.where(arrays["texel_valid"], 1.0, np.where(arrays["texel_dilated"], 0.5, 0.0))
            assert np.array_equal(state, expected.astype(dtype)), (name, "texel_state")
            if "ao" in arrays.files:
                files.add("ao.exr")
                assert np.array_equal(texels("ao.exr")["Y"], arrays["ao"].astype(dtype)), name
            if "bent_normal" in arrays.files:
                files.add("bent_normal.exr")
                bent = texels("bent_normal.exr")
                for axis, channel in enumerate("RGB"):
                    assert np.array_equal(bent[channel], arrays["bent_normal"][..., axis].astype(dtype))
            assert {p.name for p in d.iterdir()} == files, (name, files)
        print(f"test_prt.py: {name}: EXR export (f32, f16) equal to the npz export, read by OpenEXR")
