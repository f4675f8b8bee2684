#!/usr/bin/env python3
"""Intel Open Image Denoise as the peer of our transfer denoiser: the relit error of OIDN's
lightmap filter run on the lit lightmap of a raw bake, next to the raw bake's and (given) our
denoised bake's, against a converged reference, under the rigs of rigs.py.

OIDN denoises an image, not a transfer: for each rig the lit lightmap (H, W, 3) float32 is
built from the raw bake (radiance T·L per texel and channel; texels not baked, valid false,
are 0; dilated padding keeps its dilated value, as a lightmapper would hand it to OIDN) and
handed to `pyoidn.denoise(..., filter_type="RTLightmap")` (see --negative). The error is
measure.py's: the RMS over the texels baked (valid and not dilated) in both files of the
relit difference, relative to the reference's relit RMS.

    oidn.py --bake target/release/prt-bake REF.prt RAW.prt [RAW.prt ...] \
        [--ours DENOISED.prt ...] [--repeat 5]

--ours, where given, pairs one `bake --denoise on` file with each RAW.prt (same rays and
seed) and adds its error. Each OIDN call is timed after a warm-up call (device creation
and the filter's first commit are not counted): wall seconds and the process's CPU seconds
(all of OIDN's threads), the median of --repeat runs per light.

RTLightmap expects non-negative HDR radiance, but a sun projected to a low SH order lights
the texels facing away from it negatively (in the Cornell room at order 3 about a third of
the texels under the sun rigs, in the reference too, so the measure compares signed
radiance). --negative split (the default) denoises the positive part max(x, 0) and the
negative part max(-x, 0) as two images and subtracts them: two OIDN calls per light where
the image has negative texels, both counted in the time. --negative clamp sets them to 0
and denoises once; its error then includes what clamping the reference would cost (about
4 % under sun-and-sky, 17 % under low-sun), which is no fault of the denoiser.

Needs NumPy and pyoidn (`pip install pyoidn`, which brings OIDN's CPU device). Prints a
markdown table on stdout, the warm-up time and the negative texels on stderr."""

import argparse
import os
import statistics
import sys
import time

import numpy as np
import pyoidn

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "python"))
from measure import errors as measured_errors, light, receivers, relit  # noqa: E402
from prt import read_prt  # noqa: E402
from rigs import RIGS  # noqa: E402


def lit_image(f, coefficients):
    """(H, W, 3) float32 radiance of lightmap bake f under SH light (3, n²); unbaked texels 0."""
    lm = f.lightmap
    t, _ = receivers(f)
    image = relit(t, coefficients).reshape(lm.height, lm.width, 3)
    image[~np.asarray(lm.valid)] = 0.0
    return image.astype(np.float32)


def compared(f):
    """(H, W) bool: the texels measure.py compares (baked, not dilated)."""
    return np.asarray(f.lightmap.valid) & ~np.asarray(f.lightmap.dilated)


def relative_rms(image, reference, mask):
    a = reference[mask].astype(np.float64)
    b = image[mask].astype(np.float64)
    return float(np.sqrt(np.mean((b - a) ** 2)) / np.sqrt(np.mean(a ** 2)))


def oidn(image):
    return pyoidn.denoise(np.ascontiguousarray(image, np.float32), hdr=True,
                          filter_type="RTLightmap")


def denoised(image, negative):
    """OIDN's RTLightmap output for a signed image, negative texels handled as --negative says."""
    if negative == "clamp" or not (image < 0).any():
        return oidn(np.maximum(image, 0.0))
    return oidn(np.maximum(image, 0.0)) - oidn(np.maximum(-image, 0.0))


def run_oidn(image, negative, repeat):
    """denoised(image), and the median wall and CPU seconds of the --repeat runs."""
    walls, cpus, out = [], [], None
    for _ in range(repeat):
        wall, cpu = time.perf_counter(), time.process_time()
        out = denoised(image, negative)
        walls.append(time.perf_counter() - wall)
        cpus.append(time.process_time() - cpu)
    return out, statistics.median(walls), statistics.median(cpus)


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bake", default="target/release/prt-bake")
    parser.add_argument("--ours", nargs="+", default=[],
                        help="our denoised bakes, one per raw file, in the same order")
    parser.add_argument("--repeat", type=int, default=5, help="timed OIDN runs per light")
    parser.add_argument("--negative", choices=["split", "clamp"], default="split",
                        help="how negative radiance reaches OIDN (see above)")
    parser.add_argument("reference")
    parser.add_argument("raw", nargs="+")
    args = parser.parse_args()
    if args.ours and len(args.ours) != len(args.raw):
        parser.error("--ours takes one denoised file per raw file")

    ref = read_prt(args.reference)
    if ref.lightmap is None:
        parser.error(f"{args.reference} is not a lightmap bake")
    order, up = ref.header["order"], ref.header["up"].lstrip("+")
    lights = {name: light(args.bake, toml, order, up) for name, toml in RIGS.items()}
    references = {name: lit_image(ref, c) for name, c in lights.items()}
    ours = measured_errors(args.bake, args.reference, args.ours) if args.ours else {}

    # Warm-up: the CPU device and the RTLightmap filter (its weights) are made on the first call.
    warm = time.perf_counter()
    pyoidn.denoise(np.zeros((ref.lightmap.height, ref.lightmap.width, 3), np.float32),
                   hdr=True, filter_type="RTLightmap")
    print(f"OIDN warm-up (device and filter creation): {time.perf_counter() - warm:.2f} s wall",
          file=sys.stderr)

    rows = []
    for i, path in enumerate(args.raw):
        f = read_prt(path)
        if f.lightmap is None or f.transfer.shape != ref.transfer.shape:
            parser.error(f"{path} is not a lightmap bake of the reference's shape")
        mask = compared(ref) & compared(f)
        for name, coefficients in lights.items():
            image = lit_image(f, coefficients)
            negative = int((image < 0).any(axis=-1).sum())
            result, wall, cpu = run_oidn(image, args.negative, args.repeat)
            row = {
                "file": os.path.basename(path),
                "rays": f.header["samples_per_vertex"],
                "rig": name,
                "raw": relative_rms(image, references[name], mask),
                "oidn": relative_rms(result, references[name], mask),
                "calls": 1 if args.negative == "clamp" or not negative else 2,
                "ours": ours[args.ours[i]][name] if args.ours else None,
                "wall": wall,
                "cpu": cpu,
                "negative": negative,
            }
            rows.append(row)
            print(f"{row['file']} {name}: {negative} texels with negative radiance "
                  f"({args.negative}: {row['calls']} OIDN call(s))", file=sys.stderr)

    header = ["file", "rays", "rig", "raw", f"OIDN ({args.negative})", "ours", "OIDN calls",
              "OIDN wall s/light", "OIDN CPU s/light"]
    print("| " + " | ".join(header) + " |")
    print("|" + "|".join(["---"] * 3 + ["---:"] * (len(header) - 3)) + "|")
    for r in rows:
        ours_cell = f"{100 * r['ours']:.2f}%" if r["ours"] is not None else "–"
        print(f"| {r['file']} | {r['rays']} | {r['rig']} | {100 * r['raw']:.2f}% "
              f"| {100 * r['oidn']:.2f}% | {ours_cell} | {r['calls']} "
              f"| {r['wall']:.3f} | {r['cpu']:.3f} |")


if __name__ == "__main__":
    main()
