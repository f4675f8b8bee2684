"""A NumPy-only reader of prt-bake's coefficient files (.prt), for notebooks.

    from prt import read_prt
    f = read_prt("out/torus.prt")
    f.transfer          # (V, channels, n²) float32: T[v, c, j], j = l(l+1)+m; for a
                        # transfer-matrix bake (f.header["transfer"] == "matrix") the
                        # (V, channels, n², n²) matrices M[v, c, i, j] (export's transfer_matrix)
    f.ao, f.bent_normal # (V,) and (V, 3) where the bake stored them (--aux), else None
    f.rays              # adaptive bakes (--target-error): (V,) uint32 rays cast, else None
    f.error_estimate    # adaptive bakes: (V,) float32 estimated RMS coefficient error, else None
    f.lightmap          # texel bakes (--lightmap): a Lightmap (below), else None
    f.receivers         # files of some objects (--receivers): {"object_count": N, "objects":
                        # [their indices]}, the arrays holding their vertices only; else None
    f.probes            # probe bakes (--probes): a dict (below), else None
    f.header            # dict: order, channels, vertex_count, mode, transfer ("vector" or
                        # "matrix"), up, ..., and for
                        # adaptive bakes "adaptive": {target_error, replicates, rays_cast,
                        # after_denoise}

A texel (lightmap) bake of a W×H lightmap stores its texels as the vertices, row-major; this
reader shapes its arrays as `prt-bake export --npz` does: transfer (H, W, channels, n²), ao
(H, W), bent_normal (H, W, 3) (and rays, error_estimate (H, W)), with f.lightmap.width,
.height, .scene_vertex_count, .scene_triangle_count, .texel_size, .source ("generated",
"scene-uvs" or "per-object", with .objects: per object its scale, offset and UVs), .uv1
(triangles, 3, 2) float32 lightmap UVs per triangle corner, and .valid,
.dilated (H, W) bool texel states (baked; padding dilated from baked neighbours).

A probe bake (--probes) stores P transfer probes as the vertices: f.transfer is their (P,
channels, n², n²) matrices (export's probe_transfer), and f.probes holds "positions" (P, 3)
float32, "backface_fraction" (P,) float32 (above 0.25 the probe is inside geometry) and
"grid": {"counts": (NX, NY, NZ), "lo": (x, y, z), "hi": (x, y, z)} for a grid: bake (probe
(i, j, k) at index i + NX·(j + NY·k)), None for a list of points.

Every variant of version 1 is read: grey or RGB transfer, vectors or matrices (`bake
--transfer matrix`), any order 1..45, the auxiliary arrays, z- or y-up, adaptive bakes and
texel bakes, probe bakes; and compressed files (version 2, `prt-bake compress`), whose transfer is
reconstructed exactly as `prt-bake export --npz` reconstructs it (f.header["compression"]
holds what `inspect` prints, f.cpca the stored means (K, D), bases (K, M, D), cluster
indices (V,) and weights (V, M), D = channels × n² floats per receiver, n⁴ for matrices).
A shard part (`prt-bake bake --shard`)
is refused: combine the parts with `prt-bake merge` first. The checks are
docs/reference/coefficient-format.md's ("What a reader must check"), in the reference reader's
order (baker/src/coefficient_file.rs); a file that fails one raises PrtError with the
reason. Copy this file anywhere: it needs only NumPy.
"""

import zlib
from dataclasses import dataclass

import numpy as np

MAGIC = b"\x89PRT\r\n\x1a\n"
HEADER_SIZE = 128
LIGHTMAP_HEADER_SIZE = 160  # the 128-byte header, then the 32-byte texel block
PROBE_HEADER_SIZE = 176  # the 128-byte header, then the 48-byte probe block
CHECKSUM_OFFSET = 124
MODES = {0: "unshadowed", 1: "shadowed", 2: "interreflected"}
BACKENDS = {0: "none", 1: "embree", 2: "obvhs"}
SAMPLINGS = {0: "owen-sobol", 1: "thesis-random"}
UP_AXES = {0: "z", 1: "y"}
TRANSFER_KINDS = {0: "vector", 1: "matrix"}
ATLAS_SOURCES = {0: "generated", 1: "scene-uvs", 2: "per-object"}
AUX_AO, AUX_BENT_NORMAL, AUX_RAYS, AUX_ERROR = 1, 2, 4, 8
AUX_ADAPTIVE = AUX_RAYS | AUX_ERROR  # adaptive bakes: both or neither
AUX_RECEIVERS = 16  # a file of some objects (bake --receivers): the payload ends with their indices
AUX_DENOISED = 32  # the transfer was denoised (bake --denoise); no array goes with it


class _Cursor:
    """Reads arrays one after another from the bytes of a file."""

    def __init__(self, b, offset):
        self.b, self.offset = b, offset

    def take(self, dtype, count):
        array = np.frombuffer(self.b, dtype, count, self.offset)
        self.offset += array.nbytes
        return array


class PrtError(ValueError):
    """A file that is not a valid version-1 coefficient file (or is a shard part)."""


@dataclass
class Lightmap:
    width: int
    height: int
    scene_vertex_count: int
    scene_triangle_count: int
    texel_size: float  # --texel-size, or 0.0 where the charts were scaled to fill the atlas
    source: str
    uv1: np.ndarray  # (triangles, 3, 2) float32; (-1, -1) at the corners of a left-out triangle
    valid: np.ndarray  # (H, W) bool: baked
    dilated: np.ndarray  # (H, W) bool: padding dilated from baked neighbours
    # source "per-object" only: per scene object {"scale": (sx, sy), "offset": (ox, oy), "uvs":
    # "own" | "generated-overlapping" | "generated-missing"}: atlas uv = own uv * scale + offset
    objects: "list | None" = None


@dataclass
class PrtFile:
    header: dict
    transfer: np.ndarray
    ao: "np.ndarray | None"
    bent_normal: "np.ndarray | None"
    rays: "np.ndarray | None" = None
    error_estimate: "np.ndarray | None" = None
    lightmap: "Lightmap | None" = None
    # Compressed (version 2) files: {"means", "bases", "cluster", "weights"} as stored.
    cpca: "dict | None" = None
    # Files of some objects (bake --receivers): {"object_count": N, "objects": [indices]}; the
    # arrays hold those objects' vertices only, in scene order.
    receivers: "dict | None" = None
    # Probe bakes (--probes): {"positions", "backface_fraction", "grid"} (see the module's doc).
    probes: "dict | None" = None


def read_prt(path):
    with open(path, "rb") as f:
        return parse_prt(f.read())


def parse_prt(b):
    b = bytes(b)
    if b[:8] != MAGIC:
        raise PrtError("not a PRT coefficient file (wrong magic bytes)")
    if len(b) < HEADER_SIZE:
        raise PrtError(f"truncated: {len(b)} bytes, the header alone is {HEADER_SIZE}")

    def u32(offset):
        return int(np.frombuffer(b, "<u4", 1, offset)[0])

    def u64(offset):
        return int(np.frombuffer(b, "<u8", 1, offset)[0])

    def f32(offset):
        return np.frombuffer(b, "<f4", 1, offset)[0]

    if u32(8) == 2:
        return _parse_compressed(b)
    if u32(8) != 1:
        raise PrtError(f"unsupported format version {u32(8)}")
    header_size, payload, order, channels, vertices = _checked_frame(
        b, (HEADER_SIZE, LIGHTMAP_HEADER_SIZE, PROBE_HEADER_SIZE),
        "128 bytes, 160 for lightmap bakes, 176 for probe bakes", "coefficients")
    # Bytes 36..40: the mode (u16) and the transfer kind (u16; 0 in every vector file, so a
    # reader of the old u32 mode refuses a matrix file).
    mode_code, kind = int(np.frombuffer(b, "<u2", 1, 36)[0]), int(np.frombuffer(b, "<u2", 1, 38)[0])
    if kind not in TRANSFER_KINDS:
        raise PrtError(f"unknown transfer kind {kind} (0 = vector, 1 = matrix)")
    transfer_kind = TRANSFER_KINDS[kind]
    for value, table, what in ((mode_code, MODES, "mode"), (u32(44), BACKENDS, "backend"),
                               (u32(64), SAMPLINGS, "sampling method"), (u32(84), UP_AXES, "up axis")):
        if value not in table:
            raise PrtError(f"unknown {what} {value}")
    mode, samples, bounces, bounce_samples = MODES[mode_code], u32(32), u32(40), u32(80)
    if (mode == "interreflected") != (bounces > 0):
        raise PrtError(f"{bounces} bounces in a {mode} file")
    if not (1 <= bounce_samples <= samples if mode == "interreflected" else bounce_samples == 0):
        raise PrtError(f"{bounce_samples} bounce samples in a {mode} file of {samples} samples")
    aux = u32(68)
    # Bits 0..4 are defined by version 1; later bits name arrays this reader does not know.
    if aux & ~(AUX_AO | AUX_BENT_NORMAL | AUX_ADAPTIVE | AUX_RECEIVERS | AUX_DENOISED):
        raise PrtError(f"unknown auxiliary-array flags {aux:#x}")
    adaptive = _read_adaptive(b, aux, mode, SAMPLINGS[u32(64)])
    if adaptive and transfer_kind == "matrix":
        raise PrtError("a target error in a transfer-matrix file (matrix bakes are not adaptive)")
    shard = b[88:108]
    if any(shard):
        count, index, first, part_vertices = u32(88), u32(92), u64(96), u32(104)
        if index >= count:
            raise PrtError(f"shard identity {index} of {count}: the index must be below the count")
        raise PrtError(f"a shard part (shard {index} of {count}, vertices {first}..{first + part_vertices}) "
                       "of a bake, not a whole bake: combine the parts with `prt-bake merge`")

    probe_grid = None
    if header_size == PROBE_HEADER_SIZE:
        probe_grid = _read_probe_block(b, vertices, transfer_kind, aux, adaptive)
    lightmap = None
    if header_size == LIGHTMAP_HEADER_SIZE:
        width, height = u32(128), u32(132)
        if width * height != vertices:
            raise PrtError(f"a {width}×{height} lightmap in a file of {vertices} texels")
        if u32(156) not in ATLAS_SOURCES:
            raise PrtError(f"unknown atlas source {u32(156)}")
        texel_size = f32(152)
        if not (np.isfinite(texel_size) and texel_size >= 0):
            raise PrtError(f"texel size {texel_size} is not a size")
        lightmap = Lightmap(width, height, u64(136), u64(144), float(texel_size),
                            ATLAS_SOURCES[u32(156)], None, None, None)
    n2 = order * order
    # Floats per vertex and channel, and their shape: a vector of n², or an n² × n² matrix.
    per_channel, shape_of_channel = (n2, (n2,)) if transfer_kind == "vector" else (n2 * n2, (n2, n2))
    aux_floats = ((1 if aux & AUX_AO else 0) + (3 if aux & AUX_BENT_NORMAL else 0)
                  + (2 if adaptive else 0))
    needed = vertices * (channels * per_channel + aux_floats) * 4
    object_section = 0
    if lightmap is not None:
        needed += lightmap.scene_triangle_count * 6 * 4 + vertices
        # A per-object atlas ends with a u32 count and 20 bytes per object.
        if lightmap.source == "per-object":
            if not (payload >= needed + 4 and (payload - needed - 4) % 20 == 0):
                raise PrtError("a per-object atlas without its per-object section: the payload size "
                               "does not match")
            object_section = payload - needed
            needed = payload
    if header_size == PROBE_HEADER_SIZE:
        needed += vertices * 4 * 4  # each probe's position and back-face fraction
    receiver_section = 0
    if aux & AUX_RECEIVERS:
        if lightmap is not None:
            raise PrtError("a receiver section (aux bit 4) in a texel bake (only vertex bakes have one)")
        # The section: u32 object count, u32 K, K u32 indices (docs/reference/coefficient-format.md).
        receiver_section = payload - needed
        if receiver_section < 8 or receiver_section % 4:
            raise PrtError(f"the receiver section has {receiver_section} bytes (8 + 4 per receiving object)")
        needed = payload
    if needed != payload:
        raise PrtError("the payload size does not match the vertex count, order, channels, aux arrays"
                       + (" and lightmap" if lightmap is not None else ""))

    header = {
        "version": 1, "order": order, "channels": channels, "vertex_count": vertices,
        "samples_per_vertex": samples, "mode": mode, "bounces": bounces,
        "backend": BACKENDS[u32(44)], "seed": u64(48), "scene_fingerprint": f"{u64(56):016x}",
        "sampling": SAMPLINGS[u32(64)], "bounce_samples": bounce_samples, "up": UP_AXES[u32(84)],
        "aux": [name for bit, name in ((AUX_AO, "ao"), (AUX_BENT_NORMAL, "bent-normal")) if aux & bit],
        "checksum": f"{u32(CHECKSUM_OFFSET):08x}", "transfer": transfer_kind,
    }
    if adaptive:
        # A denoised adaptive bake sampled until its denoised estimate met the target: the
        # recorded errors are after denoising.
        adaptive["after_denoise"] = bool(aux & AUX_DENOISED)
        header["adaptive"] = adaptive
    if aux & AUX_DENOISED:
        header["denoised"] = True

    cursor = _Cursor(b, header_size)
    take = cursor.take

    transfer = take("<f4", vertices * channels * per_channel).reshape(vertices, channels, *shape_of_channel)
    ao = take("<f4", vertices) if aux & AUX_AO else None
    bent_normal = take("<f4", 3 * vertices).reshape(vertices, 3) if aux & AUX_BENT_NORMAL else None
    rays = error_estimate = None
    if adaptive:
        rays, error_estimate = take("<u4", vertices), take("<f4", vertices)
        # Texel bakes: the texels not baked cast none (checked against the mask below).
        least, what = (0, "texel") if lightmap is not None else (1, "vertex")
        if np.any((rays < least) | (rays > samples)):
            v = int(np.argmax((rays < least) | (rays > samples)))
            raise PrtError(f"{what} {v} cast {rays[v]} rays, outside {least}..={samples} (the samples per {what})")
        total = int(rays.sum(dtype=np.uint64))
        if total != adaptive["rays_cast"]:
            raise PrtError(f"the per-vertex rays add up to {total}, the header says {adaptive['rays_cast']} were cast")
        # Written as `not (finite and >= 0)` so that NaN fails too.
        if not np.all(np.isfinite(error_estimate) & (error_estimate >= 0)):
            raise PrtError("an estimated error is not a non-negative number")
    if ao is not None and not np.all((ao >= 0) & (ao <= 1)):
        raise PrtError("an ambient accessibility is outside [0, 1]")
    if bent_normal is not None and not np.all(np.abs(np.linalg.norm(bent_normal, axis=1) - 1) <= 1e-3):
        raise PrtError("a bent normal is not a unit vector")
    if not np.all(np.isfinite(transfer)):
        raise PrtError("a coefficient is not finite")

    if lightmap is not None:
        uv1 = take("<f4", lightmap.scene_triangle_count * 6).reshape(-1, 3, 2)
        if not np.all(np.isfinite(uv1)):
            raise PrtError("a lightmap UV is not finite")
        states = take(np.uint8, vertices)
        if np.any(states > 2):
            raise PrtError(f"state of texel {int(np.argmax(states > 2))} is {states.max()} (0, 1 or 2)")
        shape = (lightmap.height, lightmap.width)
        lightmap.uv1 = uv1
        lightmap.valid, lightmap.dilated = (states == 1).reshape(shape), (states == 2).reshape(shape)
        if rays is not None and np.any((rays > 0) != (states == 1)):
            t = int(np.argmax((rays > 0) != (states == 1)))
            raise PrtError(f"texel {t} cast {rays[t]} rays but is {'' if states[t] == 1 else 'not '}baked")
        if object_section:
            count = int(take("<u4", 1)[0])
            if count != (object_section - 4) // 20:
                raise PrtError(f"the per-object section's count {count} does not match its size")
            lightmap.objects = []
            for i in range(count):
                floats, kind = take("<f4", 4), int(take("<u4", 1)[0])
                # Scale 0 at (-1, -1): an object left out of the atlas (bake --receivers).
                left_out = np.all(floats == np.array([0, 0, -1, -1], dtype="<f4"))
                if kind > 2 or not (left_out or (np.all(np.isfinite(floats)) and np.all(floats[:2] > 0))):
                    raise PrtError(f"object {i}: not a lightmap placement")
                lightmap.objects.append({"scale": tuple(map(float, floats[:2])),
                                         "offset": tuple(map(float, floats[2:])),
                                         "uvs": ("own", "generated-overlapping", "generated-missing")[kind]})
        transfer = transfer.reshape(*shape, channels, *shape_of_channel)
        ao = None if ao is None else ao.reshape(shape)
        bent_normal = None if bent_normal is None else bent_normal.reshape(*shape, 3)
        rays = None if rays is None else rays.reshape(shape)
        error_estimate = None if error_estimate is None else error_estimate.reshape(shape)
    probes = None
    if header_size == PROBE_HEADER_SIZE:
        positions, backface = take("<f4", 3 * vertices).reshape(vertices, 3), take("<f4", vertices)
        if not np.all(np.isfinite(positions)):
            raise PrtError(f"position of probe {int(np.argmax(~np.isfinite(positions).all(1)))} is not finite")
        if not np.all((backface >= 0) & (backface <= 1)):
            raise PrtError(f"back-face fraction of probe {int(np.argmax(~((backface >= 0) & (backface <= 1))))} "
                           "is outside [0, 1]")
        probes = {"positions": positions, "backface_fraction": backface, "grid": probe_grid}
    receivers = None
    if receiver_section:
        words = take("<u4", receiver_section // 4)
        object_count, stored, objects = int(words[0]), int(words[1]), [int(o) for o in words[2:]]
        if stored != len(objects):
            raise PrtError(f"the receiver section holds {len(objects)} objects, its count says {stored}")
        if not objects:
            raise PrtError("the receiver section names no object")
        if any(o >= object_count for o in objects):
            raise PrtError(f"receiving object {max(objects)}, but the scene has {object_count} objects")
        if any(a >= b for a, b in zip(objects, objects[1:])):
            raise PrtError("the receiving objects are not in ascending order")
        receivers = {"object_count": object_count, "objects": objects}
        header["receivers"] = receivers
    assert cursor.offset == len(b)
    return PrtFile(header, transfer, ao, bent_normal, rays, error_estimate, lightmap, receivers=receivers,
                   probes=probes)


def _read_probe_block(b, vertices, transfer_kind, aux, adaptive):
    """Header bytes 128..176 of a probe file, checked against the header: the grid, or None for
    a list of points."""
    count = int(np.frombuffer(b, "<u8", 1, 128)[0])
    counts = tuple(int(n) for n in np.frombuffer(b, "<u4", 3, 136))
    box = np.frombuffer(b, "<f4", 6, 148)
    if count != vertices:
        raise PrtError(f"the probe block counts {count} probes, the header {vertices}")
    if transfer_kind != "matrix":
        raise PrtError("a probe file of vector transfer (probes hold matrices)")
    if aux or adaptive:
        raise PrtError("auxiliary arrays or a target error in a probe file")
    if any(b[172:176]):
        raise PrtError("reserved bytes 172..176 of the probe block are not zero")
    if not any(counts) and not np.any(box):
        return None
    lo, hi = box[:3], box[3:]
    if int(np.prod(counts, dtype=np.uint64)) != count or not np.all(np.isfinite(box)) or np.any(lo > hi):
        raise PrtError(f"a probe grid of {counts[0]}×{counts[1]}×{counts[2]} over [{lo}, {hi}] for {count} probes")
    return {"counts": counts, "lo": tuple(map(float, lo)), "hi": tuple(map(float, hi))}


def _read_adaptive(b, aux, mode, sampling):
    """Header bytes 108..124 and aux bits 2-3: all zero (None), or a consistent adaptive bake."""
    target_error = np.frombuffer(b, "<f4", 1, 108)[0]
    replicates = int(np.frombuffer(b, "<u4", 1, 112)[0])
    rays_cast = int(np.frombuffer(b, "<u8", 1, 116)[0])
    flags = aux & AUX_ADAPTIVE
    if not any(b[108:112]):
        if replicates or rays_cast or flags:
            raise PrtError("adaptive-sampling fields (bytes 112..124, aux bits 2-3) set without a target error")
        return None
    if not (np.isfinite(target_error) and target_error > 0):
        raise PrtError(f"target error {target_error} is not a positive number")
    if replicates < 2:
        raise PrtError(f"{replicates} replicates cannot estimate an error (at least 2)")
    if flags != AUX_ADAPTIVE:
        raise PrtError("an adaptive bake without its per-vertex rays and errors (aux bits 2 and 3)")
    if mode != "shadowed" or sampling != "owen-sobol":
        raise PrtError(f"a target error in a file of mode {mode}, sampling {sampling} "
                       "(adaptive bakes are shadowed, owen-sobol)")
    return {"target_error": float(target_error), "replicates": replicates, "rays_cast": rays_cast}


CPCA_BLOCK_SIZE = 32


def _checksum(b):
    """The CRC-32 of every byte of a file but the checksum's own 4 (counted as zeros; the texel
    and CPCA blocks included)."""
    return zlib.crc32(b[HEADER_SIZE:], zlib.crc32(bytes(4), zlib.crc32(b[:CHECKSUM_OFFSET])))


def _checked_frame(b, header_sizes, sizes_said, payload_said):
    """The checks every version shares: the header size, the payload size, the checksum, the
    order and the channels. Returns (header size, payload, order, channels, vertices)."""

    def u32(offset):
        return int(np.frombuffer(b, "<u4", 1, offset)[0])

    header_size, payload = u32(12), int(np.frombuffer(b, "<u8", 1, 72)[0])
    if header_size not in header_sizes:
        raise PrtError(f"header size {header_size} ({sizes_said})")
    if len(b) < header_size:
        raise PrtError(f"truncated: {len(b)} bytes, the header alone is {header_size}")
    if len(b) - header_size != payload:
        raise PrtError(f"the header announces {payload} bytes of {payload_said}, the file holds {len(b) - header_size}")
    if _checksum(b) != u32(CHECKSUM_OFFSET):
        raise PrtError("checksum mismatch: the file is corrupted")
    order, channels = u32(16), u32(20)
    if not 1 <= order <= 45:
        raise PrtError(f"SH order {order} is outside 1..=45")
    if channels not in (1, 3):
        raise PrtError(f"{channels} channels (1 or 3 are defined)")
    return header_size, payload, order, channels, int(np.frombuffer(b, "<u8", 1, 24)[0])


def _parse_compressed(b):
    """A version-2 file: the CPCA block and arrays checked, the transfer reconstructed (in float64,
    each component's term added in order and skipped where its weight is 0, then rounded to float32,
    as baker/src/math/cpca.rs does) and the version-1 file it stands for read by parse_prt."""

    def u32(offset):
        return int(np.frombuffer(b, "<u4", 1, offset)[0])

    def u64(offset):
        return int(np.frombuffer(b, "<u8", 1, offset)[0])

    header_size, payload, order, channels, vertices = _checked_frame(
        b, (HEADER_SIZE + CPCA_BLOCK_SIZE, LIGHTMAP_HEADER_SIZE + CPCA_BLOCK_SIZE,
            PROBE_HEADER_SIZE + CPCA_BLOCK_SIZE),
        "version 2 headers are 160 bytes, 192 for lightmap bakes, 208 for probe bakes", "compressed coefficients")
    base = header_size - CPCA_BLOCK_SIZE
    n2 = order * order
    dim = channels * (n2 * n2 if int(np.frombuffer(b, "<u2", 1, 38)[0]) == 1 else n2)
    clusters, pcs, layout, iterations, seed = u32(base), u32(base + 4), u32(base + 8), u32(base + 12), u64(base + 16)
    rms_error = np.frombuffer(b, "<f4", 1, base + 24)[0]
    if layout != 0:
        raise PrtError(f"unknown CPCA layout {layout}")
    if u32(base + 28) != 0:
        raise PrtError("reserved CPCA bytes are not zero")
    if not (np.isfinite(rms_error) and rms_error >= 0):
        raise PrtError(f"CPCA error {rms_error} is not a non-negative number")
    if not 1 <= clusters <= vertices:
        raise PrtError(f"{clusters} clusters for {vertices} receivers (1 to one per receiver)")
    if pcs > dim:
        raise PrtError(f"{pcs} principal components of {dim}-float transfer vectors (at most {dim})")
    arrays = 4 * (clusters * dim * (pcs + 1) + vertices * (pcs + 1))
    if arrays > payload:
        raise PrtError(f"{clusters} clusters of {pcs} components for {vertices} receivers need more than "
                       f"the {payload} bytes the header announces")
    cursor = _Cursor(b, header_size)
    take = cursor.take

    means = take("<f4", clusters * dim).reshape(clusters, dim)
    bases = take("<f4", clusters * pcs * dim).reshape(clusters, pcs, dim)
    cluster = take("<u4", vertices)
    weights = take("<f4", vertices * pcs).reshape(vertices, pcs)
    for array, what in ((means, "a cluster mean"), (bases, "a principal component"), (weights, "a weight")):
        if not np.all(np.isfinite(array)):
            raise PrtError(f"{what} is not finite")
    if np.any(cluster >= clusters):
        v = int(np.argmax(cluster >= clusters))
        raise PrtError(f"receiver {v} is in cluster {cluster[v]}, of {clusters}")
    acc = means[cluster].astype(np.float64)
    for i in range(pcs):
        w = weights[:, i].astype(np.float64)[:, None]
        acc = np.where(w != 0, acc + w * bases[cluster, i].astype(np.float64), acc)
    # The version-1 file these arrays stand for, resealed, read by the version-1 reader.
    v1 = bytearray(b[:base])
    v1[8:12] = np.uint32(1).tobytes()
    v1[12:16] = np.uint32(base).tobytes()
    v1[72:80] = np.uint64(vertices * dim * 4 + payload - arrays).tobytes()
    v1 += acc.astype("<f4").tobytes() + b[cursor.offset:]
    v1[CHECKSUM_OFFSET:HEADER_SIZE] = np.uint32(_checksum(bytes(v1))).tobytes()
    f = parse_prt(bytes(v1))
    f.header.update(version=2, checksum=f"{u32(CHECKSUM_OFFSET):08x}", compression={
        "method": "cpca", "layout": "concatenated-channels", "clusters": clusters, "pcs": pcs,
        "floats_per_vertex": (pcs + 1) + clusters * (pcs + 1) * dim / vertices,
        "uncompressed_floats_per_vertex": dim, "rms_error": float(rms_error),
        "iterations": iterations, "seed": f"{seed:016x}"})
    f.cpca = {"means": means, "bases": bases, "cluster": cluster, "weights": weights}
    return f
