"""A NumPy-only reader of prt-bake's coefficient files (.prt), for notebooks.

    from prt import read_prt
    f = read_prt("out/torus.prt")
    f.transfer          # (V, channels, n²) float32: T[v, c, j], j = l(l+1)+m
    f.ao, f.bent_normal # (V,) and (V, 3) where the bake stored them (--aux), else None
    f.header            # dict: order, channels, vertex_count, mode, up, ...

Every variant of version 1 is read: grey or RGB transfer, any order 1..45, the auxiliary
arrays. The checks are docs/coefficient-format.md's ("What a reader must check"); a file
that fails one raises PrtError with the reason. Copy this file anywhere: it needs only NumPy.
"""

import zlib
from dataclasses import dataclass

import numpy as np

MAGIC = b"\x89PRT\r\n\x1a\n"
HEADER_SIZE = 128
MODES = {0: "unshadowed", 1: "shadowed", 2: "interreflected"}
BACKENDS = {0: "none", 1: "embree", 2: "obvhs"}
SAMPLINGS = {0: "owen-sobol", 1: "thesis-random"}
UP_AXES = {0: "z", 1: "y"}
AUX_AO, AUX_BENT_NORMAL = 1, 2


class PrtError(ValueError):
    """A file that is not a valid version-1 coefficient file."""


@dataclass
class PrtFile:
    header: dict
    transfer: np.ndarray
    ao: "np.ndarray | None"
    bent_normal: "np.ndarray | None"


def read_prt(path):
    with open(path, "rb") as f:
        return parse_prt(f.read())


def parse_prt(b):
    if b[:8] != MAGIC:
        raise PrtError("not a PRT coefficient file (wrong magic bytes)")
    if len(b) < HEADER_SIZE:
        raise PrtError(f"truncated: {len(b)} bytes, the header alone is {HEADER_SIZE}")

    def u32(offset):
        return int(np.frombuffer(b, "<u4", 1, offset)[0])

    def u64(offset):
        return int(np.frombuffer(b, "<u8", 1, offset)[0])

    if u32(8) != 1:
        raise PrtError(f"unsupported format version {u32(8)}")
    if u32(12) != HEADER_SIZE:
        raise PrtError(f"header size {u32(12)}")
    payload = u64(72)
    if len(b) - HEADER_SIZE != payload:
        raise PrtError(f"the header announces {payload} bytes of coefficients, the file holds {len(b) - HEADER_SIZE}")
    if zlib.crc32(b[:124] + bytes(4) + b[HEADER_SIZE:]) != u32(124):
        raise PrtError("checksum mismatch: the file is corrupted")
    order, channels, vertices = u32(16), u32(20), u64(24)
    if not 1 <= order <= 45:
        raise PrtError(f"SH order {order} is outside 1..=45")
    if channels not in (1, 3):
        raise PrtError(f"{channels} channels (1 or 3 are defined)")
    for value, table, what in ((u32(36), MODES, "mode"), (u32(44), BACKENDS, "backend"),
                               (u32(64), SAMPLINGS, "sampling method"), (u32(84), UP_AXES, "up axis")):
        if value not in table:
            raise PrtError(f"unknown {what} {value}")
    aux = u32(68)
    # Bits 0 and 1 are defined by version 1; later bits name arrays this reader does not know.
    if aux & ~(AUX_AO | AUX_BENT_NORMAL):
        raise PrtError(f"unknown auxiliary-array flags {aux:#x}")
    n2 = order * order
    aux_floats = (1 if aux & AUX_AO else 0) + (3 if aux & AUX_BENT_NORMAL else 0)
    if vertices * (channels * n2 + aux_floats) * 4 != payload:
        raise PrtError("the payload size does not match the vertex count, order, channels and aux arrays")

    header = {
        "version": 1, "order": order, "channels": channels, "vertex_count": vertices,
        "samples_per_vertex": u32(32), "mode": MODES[u32(36)], "bounces": u32(40),
        "backend": BACKENDS[u32(44)], "seed": u64(48), "scene_fingerprint": f"{u64(56):016x}",
        "sampling": SAMPLINGS[u32(64)], "bounce_samples": u32(80), "up": UP_AXES[u32(84)],
        "aux": [name for bit, name in ((AUX_AO, "ao"), (AUX_BENT_NORMAL, "bent-normal")) if aux & bit],
        "checksum": f"{u32(124):08x}",
    }
    floats = np.frombuffer(b, "<f4", offset=HEADER_SIZE)
    count = vertices * channels * n2
    transfer = floats[:count].reshape(vertices, channels, n2)
    rest = floats[count:]
    ao = bent_normal = None
    if aux & AUX_AO:
        ao, rest = rest[:vertices], rest[vertices:]
        if np.any((ao < 0) | (ao > 1)):
            raise PrtError("an ambient accessibility is outside [0, 1]")
    if aux & AUX_BENT_NORMAL:
        bent_normal, rest = rest[: 3 * vertices].reshape(vertices, 3), rest[3 * vertices:]
        if np.any(np.abs(np.linalg.norm(bent_normal, axis=1) - 1) > 1e-3):
            raise PrtError("a bent normal is not a unit vector")
    if not np.all(np.isfinite(transfer)):
        raise PrtError("a coefficient is not finite")
    return PrtFile(header, transfer, ao, bent_normal)
