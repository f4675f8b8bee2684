#!/usr/bin/env python3
"""Would a filter over neighbouring probes help? The relit error of probe bakes (npz exports)
against a converged reference, raw and filtered over a probe grid's neighbours, and what the
filter does to the reference itself (its bias).

    probes.py --bake target/release/prt-bake REF.npz RAW.npz [RAW.npz ...]

The filter is the best a denoiser of probes could do: a weighted first-order fit in 3D over the
probes within `radius` grid spacings (Gaussian weights, σ one spacing), and the same with a
range term whose noise is each probe's *true* error against the reference, which no bake
knows. Relit error: the RMS of M·L over every probe and output coefficient, relative to the
reference's, under each rig (measure.py's)."""

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from measure import light  # noqa: E402
from rigs import RIGS  # noqa: E402


def relit(t, coefficients):
    """(P, 3, n²) incident radiance of probe matrices t (P, C, n², n²) under light (3, n²)."""
    if t.shape[1] == 1:
        return np.einsum("pij,cj->pci", t[:, 0], coefficients)
    return np.einsum("pcij,cj->pci", t, coefficients)


def error(reference, t, lights):
    out = []
    for coefficients in lights.values():
        a, b = relit(reference, coefficients), relit(t, coefficients)
        out.append(100 * np.sqrt(np.mean((a - b) ** 2) / np.mean(a**2)))
    return " / ".join(f"{e:.2f}" for e in out) + " %"


def fit(t, positions, radius, noise=None, kappa=3.0):
    """Each probe's value of a weighted first-order fit over its neighbours within `radius`
    spacings; with `noise`, a range term exp(-max(0, d² - 1)/κ²) on the squared difference."""
    flat = t.reshape(len(t), -1)
    spacing = min(np.diff(np.unique(positions[:, a])).min() for a in range(3))
    out = np.empty_like(flat)
    for i, p in enumerate(positions):
        d = (positions - p) / spacing
        r2 = (d**2).sum(1)
        near = np.flatnonzero(r2 <= radius**2 + 1e-6)
        w = np.exp(-0.5 * r2[near])
        if noise is not None:
            d2 = ((flat[near] - flat[i]) ** 2).sum(1) / ((noise[near] + noise[i]) * flat.shape[1])
            w *= np.exp(-np.maximum(0.0, d2 - 1.0) / kappa**2)
        x = np.c_[np.ones(len(near)), d[near]]
        a = (x * w[:, None]).T @ x + 1e-3 * w.sum() * np.diag([0.0, 1.0, 1.0, 1.0])
        out[i] = (w * (x @ np.linalg.solve(a, [1.0, 0.0, 0.0, 0.0]))) @ flat[near]
    return out.reshape(t.shape)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bake", default="target/release/prt-bake")
    parser.add_argument("--up", default="z", help="the scene's up axis (the bake's --up)")
    parser.add_argument("--radius", type=float, action="append", help="grid spacings (1 and 1.75 if none)")
    parser.add_argument("reference")
    parser.add_argument("raw", nargs="+")
    args = parser.parse_args()
    with np.load(args.reference) as f:
        reference = f["probe_transfer"].astype(np.float64)
        positions = f["probe_positions"].astype(np.float64)
    order = int(round(np.sqrt(reference.shape[-1])))
    lights = {name: light(args.bake, toml, order, args.up) for name, toml in RIGS.items()}
    for radius in args.radius or [1.0, 1.75]:
        print(f"radius {radius}: the filter's bias {error(reference, fit(reference, positions, radius), lights)}")
    for path in args.raw:
        with np.load(path) as f:
            t = f["probe_transfer"].astype(np.float64)
        print(f"{path}: raw {error(reference, t, lights)}")
        noise = np.maximum(((t - reference).reshape(len(t), -1) ** 2).mean(1), 1e-12)
        for radius in args.radius or [1.0, 1.75]:
            plain = error(reference, fit(t, positions, radius), lights)
            oracle = error(reference, fit(t, positions, radius, noise), lights)
            print(f"  radius {radius}: filtered {plain}; with the true noise's range term {oracle}")


if __name__ == "__main__":
    main()
