#!/usr/bin/env python3
"""Interreflected transfer probes against Mitsuba 3.

At a few points in the Cornell room (scenes/cornell: open at the front and the top) under a
constant white sky of radiance 1, the probe bake's incident radiance L_in = M·L (L = the sky's
SH, √(4π) in coefficient 0) against a path tracer on Mitsuba's rays (variant llvm_ad_rgb; its
own BVH), through the quantity both sides hold exactly: the **order-n band-limited irradiance**
at the six axis normals ±x, ±y, ±z,

    Ẽ(n)/π = (1/π) Σ_{l<n} A_l Σ_m L_in,lm y_lm(n)
           = (1/π) ∫_{S²} L(ω) K_n(n·ω) dω,   K_n(t) = Σ_{l<n} A_l (2l+1)/(4π) P_l(t)

(A_0 = π, A_1 = 2π/3, A_2 = π/4: the cosine lobe's zonal coefficients; the second line is the
addition theorem). A probe holds L_in's projection on the first n² functions, nothing else, so
its Ẽ is exact up to Monte Carlo noise, while the true irradiance E(n) (the full clamped
cosine) differs by the lobe's bands l ≥ n, a bias of its own: printed, not checked
(docs/guides/probes.md). Raw radiance along a direction would carry every band the probe lacks.

The reference: from the probe, directions ω uniform over the sphere; a ray that escapes sees
the sky (radiance 1); one that hits a front face continues from the hit with the throughput
times its albedo and cosine-weighted directions about its normal, as the vertex reference of
mitsuba_reference.py does; a back face ends the path (the baker's convention). A path cut
after B reflections is the light of a `--bounces B` probe (the probe's hit reads the
interreflected transfer of B − 1 bounces, times the albedo: B reflections in all), so one path
loop gives every B. Per path the estimate is 4π·L_B(ω)·K_n(n·ω)/π; the reference's standard
error is over its independent paths.

Criterion, per B, over the probes p, axes a and channels c: d = bake − ref,
σ² = SE² + s², s² the bake's own Monte Carlo variance (half the mean square difference of two
bakes with different seeds, per probe over its axes and channels):
  * every |d| < 5σ;
  * per channel, |mean(d)| ≤ 3·√(Σσ²)/count.
Exit status 1 if any check fails. With `--mode shadowed` (no interreflection) it must fail.

Usage: probe_reference.py --prt-bake target/release/prt-bake [--paths N] [--samples N]
       [--bounces 1,3] [--mode interreflected|shadowed] [--out DIR]
"""

import argparse
import math
import os
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
SQRT_4PI = math.sqrt(4.0 * math.pi)
ORDER = 3
LOBE = [math.pi, 2.0 * math.pi / 3.0, math.pi / 4.0]  # A_l, l < ORDER

# The probes (the room is [-1, 1]² × [0, 2], the red wall at x = −1, the green one at x = 1,
# the short box at (0.35, −0.3), the tall one at (−0.35, 0.35)).
PROBES = [
    ("red wall", (-0.85, -0.3, 0.6)),
    ("back corner, low", (-0.8, 0.85, 0.15)),  # the tall box and two walls shade it
    ("between the boxes, low", (0.1, 0.2, 0.1)),
    ("open, above the short box", (0.3, -0.5, 1.3)),
]
AXES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
AXIS_NAMES = ["+x", "-x", "+y", "-y", "+z", "-z"]


def sh_order3(d):
    """The baker's real SH (Condon–Shortley, index l(l+1)+m) for l ≤ 2, per row of d."""
    x, y, z = d.T
    return np.stack([0.2820948 + 0 * x, -0.4886025 * y, 0.4886025 * z, -0.4886025 * x,
                     1.0925484 * x * y, -1.0925484 * y * z, 0.31539157 * (3 * z * z - 1),
                     -1.0925484 * x * z, 0.5462742 * (x * x - y * y)], axis=1)


def band_limited_irradiance(coeffs):
    """Ẽ/π at AXES from incident-radiance coefficients (..., 9): (..., 6)."""
    y = sh_order3(AXES)  # (6, 9)
    lobe = np.array([LOBE[0]] + [LOBE[1]] * 3 + [LOBE[2]] * 5)
    return np.einsum("...i,ai->...a", coeffs * lobe, y) / math.pi


def kernel(t):
    """K_n(t) = Σ_{l<n} A_l (2l+1)/(4π) P_l(t)."""
    p = [1.0, t, 0.5 * (3 * t * t - 1)]
    return sum(a * (2 * l + 1) / (4 * math.pi) * p[l] for l, a in enumerate(LOBE))


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"probe_reference: {' '.join(cmd)} failed ({r.returncode}):\n{r.stderr}")
    return r


def bake(args, points, out, bounces, seed):
    """Ẽ/π per probe, axis and channel (P, 6, 3) of a probe bake under the white sky."""
    prt = f"{out}.prt"
    extra = ["--bounces", str(bounces)] if args.mode == "interreflected" else []
    run([args.prt_bake, "bake", args.scene, "-o", prt, "--probes", points, "--order",
         str(ORDER), "--mode", args.mode, "--samples", str(args.samples), "--seed", str(seed),
         "--quiet"] + extra)
    run([args.prt_bake, "export", prt, "--scene", args.scene, "--npz", f"{out}.npz"])
    m = np.load(f"{out}.npz")["probe_transfer"]  # (P, C, 9, 9)
    incident = m[:, :, :, 0] * SQRT_4PI  # the sky's L: √(4π) in coefficient 0
    e = band_limited_irradiance(incident)  # (P, C, 6)
    e = np.transpose(e, (0, 2, 1))
    return np.repeat(e, 3, axis=2) if e.shape[2] == 1 else e


def reference(mi, dr, geometry, points, paths, max_bounces, seed):
    """Per probe, axis, B = 0..max_bounces and channel: mean and standard error of Ẽ/π
    (band-limited) and of E/π (the full cosine): arrays (P, 6, B + 1, 3)."""
    positions = geometry["positions"].astype(np.float32)
    triangles = geometry["triangles"].astype(np.uint32)
    tri_albedo = geometry["albedo"].astype(np.float32)[triangles[:, 0]]
    mesh = mi.Mesh("scene", vertex_count=len(positions), face_count=len(triangles),
                   has_vertex_normals=False, has_vertex_texcoords=False)
    params = mi.traverse(mesh)
    params["vertex_positions"] = dr.ravel(mi.Point3f(positions.T))
    params["faces"] = dr.ravel(mi.Vector3u(triangles.T))
    params.update()
    scene = mi.load_dict({"type": "scene", "boards": mesh})
    rho = [mi.Float(tri_albedo[:, c].copy()) for c in range(3)]

    count = len(points)
    lanes = count * paths
    rng = mi.PCG32(size=lanes, initstate=seed)
    # Uniform directions over the sphere from the probe.
    u1, u2 = rng.next_float32(), rng.next_float32()
    z = 1.0 - 2.0 * u1
    # √(1 − z²) without max(), which this LLVM cannot select.
    r = dr.sqrt(4.0 * u1 * (1.0 - u1))
    s, c = dr.sincos(2.0 * math.pi * u2)
    first = mi.Vector3f(r * c, r * s, z)
    origin = mi.Point3f(np.repeat(points, paths, axis=0).astype(np.float32).T)
    d = first
    throughput = [mi.Float(1.0) for _ in range(3)]
    alive = mi.Bool(True)
    escaped = []
    for depth in range(max_bounces + 1):
        if depth > 0:
            u1, u2 = rng.next_float32(), rng.next_float32()
            rr = dr.sqrt(u1)
            s, c = dr.sincos(2.0 * math.pi * u2)
            d = mi.Frame3f(normal).to_world(mi.Vector3f(rr * c, rr * s, dr.sqrt(1.0 - u1)))
        si = scene.ray_intersect(mi.Ray3f(origin, d))
        hit = si.is_valid()
        sky = alive & ~hit
        escaped.append([dr.select(sky, t, 0.0) for t in throughput])
        front = alive & hit & (dr.dot(si.n, d) < 0)
        alive = front
        tri = dr.select(front, si.prim_index, 0)
        throughput = [dr.select(front, t * dr.gather(mi.Float, q, tri), 0.0)
                      for t, q in zip(throughput, rho)]
        origin = si.p + si.n * 1e-4
        normal = si.n
        dr.eval(alive, origin, normal, *throughput, *escaped[-1])
    w = np.array(first).T.reshape(count, paths, 3)  # the first directions
    cos = np.einsum("pqk,ak->pqa", w, AXES)
    weights = {"band": 4.0 * kernel(cos), "full": 4.0 * np.maximum(cos, 0.0)}  # 4π·K/π
    out = {k: (np.zeros((count, 6, max_bounces + 1, 3)), np.zeros((count, 6, max_bounces + 1, 3)))
           for k in weights}
    total = np.zeros((count, paths, 3))
    for depth, e in enumerate(escaped):
        total += np.stack([np.array(ch) for ch in e], axis=1).reshape(count, paths, 3)
        for k, wt in weights.items():
            v = wt[:, :, :, None] * total[:, :, None, :]  # (P, paths, 6, 3)
            mean = v.mean(axis=1)
            var = v.var(axis=1, ddof=1)
            out[k][0][:, :, depth] = mean
            out[k][1][:, :, depth] = np.sqrt(var / paths)
    return out


def fmt(v):
    return "(" + ", ".join(f"{x:+.4f}" for x in v) + ")"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--prt-bake", default=os.path.join(ROOT, "target/release/prt-bake"))
    ap.add_argument("--scene", default=os.path.join(ROOT, "scenes/cornell/cornell.scene"))
    ap.add_argument("--out", default=os.path.join(ROOT, "target/probe-mitsuba"))
    ap.add_argument("--paths", type=int, default=1 << 17, help="reference paths per probe")
    ap.add_argument("--samples", type=int, default=4096, help="rays per probe (--samples)")
    ap.add_argument("--bounces", default="1,3")
    ap.add_argument("--mode", default="interreflected", choices=["interreflected", "shadowed"])
    args = ap.parse_args()
    bounces = [int(b) for b in args.bounces.split(",")]

    import drjit as dr
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")  # the path loop is vectorised: no scalar variant
    os.makedirs(args.out, exist_ok=True)
    started = time.time()
    points = os.path.join(args.out, "probes.txt")
    with open(points, "w") as f:
        f.write("# generated by scripts/mitsuba/probe_reference.py\n")
        f.writelines(f"{x} {y} {z}  # {name}\n" for name, (x, y, z) in PROBES)

    baked = {b: bake(args, points, os.path.join(args.out, f"b{b}"), b, 1) for b in bounces}
    other = bake(args, points, os.path.join(args.out, "seed2"), bounces[-1], 2)
    # The scene's triangles and albedos: a 1-sample unshadowed vertex bake's export.
    geo = os.path.join(args.out, "geometry")
    run([args.prt_bake, "bake", args.scene, "-o", f"{geo}.prt", "--order", "1", "--quiet",
         "--mode", "unshadowed", "--samples", "1"])
    run([args.prt_bake, "export", f"{geo}.prt", "--scene", args.scene, "--npz", f"{geo}.npz"])
    t_bake = time.time() - started
    ref = reference(mi, dr, np.load(f"{geo}.npz"), np.array([p for _, p in PROBES]),
                    args.paths, max(bounces), seed=3)
    print(f"probe_reference: {len(PROBES)} probes × 6 axes × RGB, order {ORDER}, "
          f"{args.samples} rays per probe, {args.mode}; reference {args.paths} paths per probe "
          f"(bakes {t_bake:.1f} s, reference {time.time() - started - t_bake:.1f} s)")

    # The bake's own variance, per probe over its axes and channels.
    s2 = 0.5 * np.mean((baked[bounces[-1]] - other) ** 2, axis=(1, 2))[:, None, None]
    band, band_se = ref["band"]
    full, _ = ref["full"]
    ok = True
    for b in bounces:
        d = baked[b] - band[:, :, b]
        sigma = np.sqrt(band_se[:, :, b] ** 2 + s2)
        z = np.abs(d) / sigma
        n = d.shape[0] * d.shape[1]
        mean = d.reshape(n, 3).mean(axis=0)
        se_mean = np.sqrt((sigma ** 2).reshape(n, 3).sum(axis=0)) / n
        rel = np.sqrt(np.mean(d ** 2)) / np.sqrt(np.mean(band[:, :, b] ** 2))
        good = bool(np.all(z < 5) and np.all(np.abs(mean) <= 3 * se_mean))
        ok &= good
        trunc = full[:, :, b] - band[:, :, b]
        print(f"  B={b}: Ẽ/π mean {band[:, :, b].mean():.4f}; mean diff (R,G,B) {fmt(mean)} "
              f"± {fmt(se_mean)}; rms diff {np.sqrt(np.mean(d ** 2)):.4f} "
              f"({100 * rel:.2f} % of rms Ẽ/π); max |d|/σ {z.max():.2f}; "
              f"full E − Ẽ (order-{ORDER} truncation, not checked): rms "
              f"{np.sqrt(np.mean(trunc ** 2)):.4f}, max {np.abs(trunc).max():.4f}  "
              f"{'ok' if good else 'FAIL'}")
        for p, (name, pos) in enumerate(PROBES):
            worst = np.unravel_index(np.argmax(z[p]), z[p].shape)
            print(f"    {name:27s} {pos}: Ẽ/π bake "
                  f"{' '.join(f'{AXIS_NAMES[a]} {fmt(baked[b][p, a])}' for a in (0, 1, 4))} | "
                  f"ref {' '.join(f'{AXIS_NAMES[a]} {fmt(band[p, a, b])}' for a in (0, 1, 4))}; "
                  f"worst {AXIS_NAMES[worst[0]]} ch {worst[1]} {z[p][worst]:.2f} σ")
    print(f"probe_reference: {'all checks pass' if ok else 'FAILED'} "
          f"({time.time() - started:.1f} s)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
