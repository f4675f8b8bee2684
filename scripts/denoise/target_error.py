#!/usr/bin/env python3
"""Per-receiver RMS coefficient error of bakes against a converged reference, as adaptive
sampling states it (`--target-error E`): for each file, its rays per receiver, the p50, p95,
p99 and max of √((1/n²) Σ_j (T_j − T_ref,j)²) over the receivers baked in both, and for an
adaptive file the share of receivers within E and where its rays went.

    target_error.py REF.prt FILE.prt [FILE.prt ...]

Texel bakes compare baked texels only. "Edges" are the baked texels whose reference DC differs
from a baked 4-neighbour's by more than 10 % of the reference's RMS DC (shadow edges, contact
shadows, creases); the line gives the mean rays there and elsewhere."""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "python"))
from prt import read_prt  # noqa: E402


def receivers(f):
    t = np.asarray(f.transfer, dtype=np.float64)
    if f.lightmap is not None:
        mask = np.asarray(f.lightmap.valid) & ~np.asarray(f.lightmap.dilated)
        return t.reshape(-1, t.shape[-1]), mask.reshape(-1)
    return t.reshape(t.shape[0], -1), np.ones(t.shape[0], dtype=bool)


def edges(ref, mask):
    """Baked texels whose reference DC jumps to a baked 4-neighbour (texel bakes only)."""
    if ref.lightmap is None:
        return None
    h, w = ref.lightmap.height, ref.lightmap.width
    dc = np.asarray(ref.transfer, dtype=np.float64)[..., 0, 0]
    m = mask.reshape(h, w)
    scale = 0.1 * np.sqrt(np.mean(dc[m] ** 2))
    edge = np.zeros((h, w), dtype=bool)
    for dy, dx in ((0, 1), (1, 0)):
        a, b = dc[: h - dy, : w - dx], dc[dy:, dx:]
        both = m[: h - dy, : w - dx] & m[dy:, dx:]
        jump = both & (np.abs(a - b) > scale)
        edge[: h - dy, : w - dx] |= jump
        edge[dy:, dx:] |= jump
    return edge.reshape(-1)


def main():
    ref = read_prt(sys.argv[1])
    ref_t, ref_mask = receivers(ref)
    edge = edges(ref, ref_mask)
    for path in sys.argv[2:]:
        f = read_prt(path)
        t, mask = receivers(f)
        both = ref_mask & mask
        err = np.sqrt(np.mean((t[both] - ref_t[both]) ** 2, axis=1))
        p50, p95, p99 = np.percentile(err, [50, 95, 99])
        line = f"{os.path.basename(path)}: receivers {both.sum()}"
        adaptive = f.header.get("adaptive")
        if f.rays is not None:
            rays = np.asarray(f.rays).reshape(-1)[both].astype(np.float64)
            line += f", rays mean {rays.mean():.0f} (p50 {np.median(rays):.0f}, max {rays.max():.0f})"
        else:
            line += f", rays {f.header['samples_per_vertex']}"
        line += f", error p50 {p50:.3e} p95 {p95:.3e} p99 {p99:.3e} max {err.max():.3e}"
        if adaptive:
            target = adaptive["target_error"]
            line += f", within E {np.mean(err <= target) * 100:.1f} %, p99/E {p99 / target:.2f}"
            est = np.asarray(f.error_estimate).reshape(-1)[both]
            line += f", estimate RMS {np.sqrt(np.mean(est**2)):.3e} vs true RMS {np.sqrt(np.mean(err**2)):.3e}"
            if edge is not None and f.rays is not None:
                e = edge[both]
                line += (f", edges ({e.sum()} texels) {rays[e].mean():.0f} rays vs "
                         f"{rays[~e].mean():.0f} elsewhere, {rays[e].sum() / rays.sum() * 100:.0f} % of rays")
        print(line, flush=True)


if __name__ == "__main__":
    main()
