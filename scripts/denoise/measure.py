#!/usr/bin/env python3
"""Relit error of bakes against a converged reference: for each rig, the RMS over the texels
(or vertices) baked in both files of the relit difference, relative to the reference's relit
RMS. Texel bakes compare baked texels only (dilated padding is not a surface).

    measure.py --bake target/release/prt-bake REF.prt FILE.prt [FILE.prt ...]

Prints one line per file: its name, then the error under each rig (percent)."""

import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "python"))
from prt import read_prt  # noqa: E402
from rigs import RIGS  # noqa: E402


def light(bake, rig_toml, order, up):
    with tempfile.TemporaryDirectory() as tmp:
        rig = os.path.join(tmp, "rig.toml")
        with open(rig, "w") as f:
            f.write(rig_toml)
        out = subprocess.run([bake, "light", rig, "--order", str(order), "--up", up, "-o", "-"],
                             check=True, capture_output=True, text=True).stdout
    return np.array(json.loads(out)["coefficients"], dtype=np.float64)  # (3, n²)


def receivers(f):
    """(R, channels, n²) transfer of the baked receivers, and their mask."""
    t = np.asarray(f.transfer, dtype=np.float64)
    if f.lightmap is not None:
        mask = np.asarray(f.lightmap.valid) & ~np.asarray(f.lightmap.dilated)
        return t.reshape(-1, t.shape[-2], t.shape[-1]), mask.reshape(-1)
    return t, np.ones(t.shape[0], dtype=bool)


def relit(t, coefficients):
    """(R, 3) radiance of transfer t (R, channels, n²) under SH light (3, n²)."""
    if t.shape[1] == 1:
        return t[:, 0, :] @ coefficients.T
    return np.einsum("rcj,cj->rc", t, coefficients)


def errors(bake, reference, files, rigs=RIGS):
    ref = read_prt(reference)
    order = ref.header["order"]
    up = ref.header["up"].lstrip("+")
    lights = {name: light(bake, toml, order, up) for name, toml in rigs.items()}
    ref_t, ref_mask = receivers(ref)
    out = {}
    for path in files:
        f = read_prt(path)
        t, mask = receivers(f)
        both = ref_mask & mask
        row = {}
        for name, coefficients in lights.items():
            a = relit(ref_t[both], coefficients)
            b = relit(t[both], coefficients)
            row[name] = float(np.sqrt(np.mean((b - a) ** 2)) / np.sqrt(np.mean(a ** 2)))
        out[path] = row
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--bake", default="target/release/prt-bake")
    parser.add_argument("reference")
    parser.add_argument("files", nargs="+")
    args = parser.parse_args()
    result = errors(args.bake, args.reference, args.files)
    names = list(RIGS)
    print("file".ljust(40) + "".join(n.rjust(14) for n in names))
    for path, row in result.items():
        print(os.path.basename(path).ljust(40) + "".join(f"{100 * row[n]:13.2f}%" for n in names))


if __name__ == "__main__":
    main()
