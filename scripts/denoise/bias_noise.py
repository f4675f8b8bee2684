#!/usr/bin/env python3
"""Where a denoised bake's error lies, and of what kind: its relit error against a converged
reference split into the filter's bias and its noise, over the whole lightmap and over
regions of the atlas. The bakes are of one setting with different seeds: their spread is the
noise, and their mean's error, less the noise's share, is the bias (the reference's own
noise counts as bias).

    bias_noise.py REF.prt SEED1.prt SEED2.prt [...] [--versus RAW.prt ...] \
        [--region NAME=X0,X1,Y0,Y1 ...] [--rigs sky,low-sun]

Figures are percent of the reference's relit RMS over all its baked texels, so that the
regions' squares add up to the whole's. `--versus` adds a line for each single bake (the
raw bake a denoised one is held to, say) with its error over the same regions. A region is
a rectangle of atlas texels, X0 ≤ x < X1 and Y0 ≤ y < Y1, rows from the top as the atlas
is stored; texels of no region count in `rest`."""

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "python"))
from prt import read_prt  # noqa: E402
from measure import light, receivers, relit  # noqa: E402
from rigs import RIGS  # noqa: E402


def region(text):
    name, _, box = text.partition("=")
    try:
        x0, x1, y0, y1 = (int(v) for v in box.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--region {text!r}: expected NAME=X0,X1,Y0,Y1")
    return name, (x0, x1, y0, y1)


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bake", default="target/release/prt-bake")
    parser.add_argument("--region", type=region, action="append", default=[])
    parser.add_argument("--versus", action="append", default=[])
    parser.add_argument("--rigs", default=",".join(RIGS))
    parser.add_argument("reference")
    parser.add_argument("seeds", nargs="+")
    args = parser.parse_args()
    if len(args.seeds) < 2:
        parser.error("the noise needs at least two bakes of different seeds")
    ref = read_prt(args.reference)
    if ref.lightmap is None:
        parser.error(f"{args.reference}: not a lightmap bake")
    height, width = ref.lightmap.height, ref.lightmap.width
    ref_t, baked = receivers(ref)
    ys, xs = np.mgrid[0:height, 0:width]
    masks = {}
    rest = np.ones(height * width, dtype=bool)
    for name, (x0, x1, y0, y1) in args.region:
        inside = ((xs >= x0) & (xs < x1) & (ys >= y0) & (ys < y1)).reshape(-1) & rest
        masks[name] = inside
        rest &= ~inside
    if args.region:
        masks["rest"] = rest
    names = ["all"] + list(masks)
    masks["all"] = np.ones(height * width, dtype=bool)

    def same_atlas_receivers(path):
        """Its transfer and baked-texel mask, refused where its atlas is not the reference's."""
        t, mask = receivers(read_prt(path))
        if t.shape[0] != ref_t.shape[0]:
            sys.exit(f"{path}: {t.shape[0]} texels, the reference {args.reference} has {ref_t.shape[0]}")
        return t, mask

    seeds = [same_atlas_receivers(p) for p in args.seeds]
    both = baked.copy()
    for _, mask in seeds:
        both &= mask
    order, up = ref.header["order"], ref.header["up"].lstrip("+")
    for rig in args.rigs.split(","):
        if rig not in RIGS:
            sys.exit(f"--rigs: no rig {rig!r} (there are {', '.join(RIGS)})")
        coefficients = light(args.bake, RIGS[rig], order, up)
        a = relit(ref_t, coefficients)
        scale = np.mean(a[baked] ** 2) * baked.sum() * 3
        errors = np.array([relit(t, coefficients) - a for t, _ in seeds])
        mean = errors.mean(axis=0)
        spread = ((errors - mean) ** 2).sum(axis=0) / (len(seeds) - 1)

        def part(values, mask):
            return float(np.sum(values[mask & both])) / scale

        print(f"{rig}".ljust(30) + "".join(n.rjust(24) for n in names))
        total = [part((errors ** 2).mean(axis=0), masks[n]) for n in names]
        noise = [part(spread, masks[n]) for n in names]
        bias = [max(0.0, part(mean ** 2, masks[n]) - v / len(seeds)) for n, v in zip(names, noise)]
        cells = [f"{100 * t ** 0.5:.3f} ({100 * b ** 0.5:.3f} / {100 * v ** 0.5:.3f})"
                 for t, b, v in zip(total, bias, noise)]
        print(f"  {len(seeds)} seeds, total (bias / noise)".ljust(30) + "".join(c.rjust(24) for c in cells))
        for path in args.versus:
            t, mask = same_atlas_receivers(path)
            e2 = (relit(t, coefficients) - a) ** 2
            cells = [f"{100 * part(e2, masks[n] & mask) ** 0.5:.3f}" for n in names]
            print(f"  {os.path.basename(path)}".ljust(30) + "".join(c.rjust(24) for c in cells))


if __name__ == "__main__":
    main()
