#!/usr/bin/env python3
"""Tables from scripts/bench/lightmap_scale.sh's results.tsv: per cell the runs' wall, CPU and
peak memory, their ray rates per CPU-second against the vertex bake and raw Embree, the staged
pipelines' summed CPU against the whole bake (and apart their user time, system time and page
faults), and the per-texel figures that docs/guides/clusters.md's 16-node plan multiplies out.

    scale_report.py RESULTS.tsv [--cell QUADS:RES] [--threads T]
    scale_report.py RESULTS.tsv --plan RES [--nodes N] [--cores T] [--triangles M] [--fill F]
                    [--samples S] [--gbps G]

--plan multiplies the per-texel figures of the largest measured cell's staged pipelines out to
a RES² lightmap on N nodes of T cores (docs/guides/clusters.md, "Plan: 8192² on 16 nodes"): each
array stage's per-task CPU is fitted as a + b/N over the measured shard counts (a: what every
task repeats, per lightmap texel; b: what divides, per baked texel), the merges per lightmap
texel, scene loading per triangle; wall = CPU / T for the array stages (ray casting and
gathers scale near-linearly with cores), CPU for the merges (one thread: reading, checksums,
adding), plus each task's bytes read and written / G GB/s (the shared file system's aggregate
is assumed to carry N tasks at once).

Rates are rays per CPU-second (user + system), not per wall second: the machine is shared, and
CPU time is what a loaded machine does not inflate (much). Standard library only.
"""
import argparse
import csv
import re
from collections import OrderedDict


def number(text):
    return float(text) if text not in ("", None) else None


def load(path):
    cells = OrderedDict()
    with open(path, newline="") as f:
        for row in csv.DictReader(f, delimiter="\t"):
            cells.setdefault(row["cell"], OrderedDict())[row["run"]] = {
                k: number(row.get(k)) for k in ("wall_s", "cpu_s", "rss_mb", "rays", "texels", "seam_points", "bytes",
                                               "system_s", "faults")
            }
    return cells


def rate(run):
    """Mrays per CPU-second."""
    if not run or not run["rays"] or not run["cpu_s"]:
        return None
    return run["rays"] / run["cpu_s"] / 1e6


def fmt(x, spec="{:.2f}"):
    return "—" if x is None else spec.format(x)


def stage_groups(runs):
    """The staged pipelines of a cell: {"interreflected-N2": {stage: run}}."""
    groups = OrderedDict()
    for name, run in runs.items():
        # A --verbose run's stage sum ("shard-0:stages") is inside its process's CPU.
        if ":" in name and not name.endswith(":stages") and re.match(r"^(shadowed|interreflected)-N\d+:", name):
            tag, stage = name.split(":", 1)
            groups.setdefault(tag, OrderedDict())[stage] = run
    return groups


def kind(stage):
    """A stage's kind: prepare, factor, shard, merge, gather, stitch, file-…, identical. The seam
    factor (`factor-seams`) is not a merge: it is the whole bake's own factorisation, done once
    for the last merge (which solves with it) or every stitch shard, like the preparation."""
    if stage.startswith("file-") or stage == "identical":
        return stage
    if stage.startswith("merge") or stage == "join":
        return "merge"
    return stage.split("-")[0]


def summarise_stages(stages):
    by_kind = OrderedDict()
    for stage, run in stages.items():
        if run["cpu_s"] is not None:
            by_kind.setdefault(kind(stage), []).append((stage, run))
    cpu = {k: sum(r["cpu_s"] for _, r in v) for k, v in by_kind.items()}
    total = sum(cpu.values())
    # The critical path on N machines in CPU-seconds: the slowest task of each array.
    path = 0.0
    arrays = OrderedDict()
    for stage, run in stages.items():
        if run["cpu_s"] is None:
            continue
        key = re.sub(r"-\d+$", "", stage) if kind(stage) in ("shard", "gather", "stitch") else stage
        # The seam factor runs beside the shards (it casts no rays): not after them.
        key = "shard" if stage == "factor" else key
        arrays[key] = max(arrays.get(key, 0.0), run["cpu_s"])
    path = sum(arrays.values())
    rss = max((r["rss_mb"] or 0) for r in stages.values())
    return cpu, total, path, rss


def cell_report(cell, runs, threads):
    quads, res = (int(x) for x in cell.split(":"))
    shadowed, inter, vertex = runs.get("shadowed"), runs.get("interreflected"), runs.get("vertex")
    baked = shadowed["texels"] if shadowed else None
    seams = shadowed["seam_points"] if shadowed else None
    print(f"\ncell {cell}: {2 * quads * quads:,} triangles, {res}² lightmap, "
          f"{fmt(baked, '{:,.0f}')} baked texels, {fmt(seams, '{:,.0f}')} seam points")
    print("| run | wall s | CPU s | peak MB | rays | Mrays/CPU-s | × vertex | × raw Embree |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for name, raw in (("vertex", None), ("shadowed", "raw-shadowed"), ("interreflected", "raw-interreflected"),
                      ("raw-shadowed", None), ("raw-interreflected", None)):
        run = runs.get(name)
        if not run:
            continue
        r = rate(run)
        v = r / rate(vertex) if r and rate(vertex) and name in ("shadowed",) else None
        w = r / rate(runs[raw]) if r and raw in runs and rate(runs[raw]) else None
        print(f"| {name} | {fmt(run['wall_s'])} | {fmt(run['cpu_s'])} | {fmt(run['rss_mb'], '{:.0f}')} | "
              f"{fmt(run['rays'], '{:,.0f}')} | {fmt(r)} | {fmt(v)} | {fmt(w)} |")
    for tag, stages in stage_groups(runs).items():
        mode = tag.split("-N")[0]
        whole = runs.get(mode)
        cpu, total, path, rss = summarise_stages(stages)
        same = stages.get("identical", {}).get("bytes")
        w = whole["cpu_s"] if whole else None
        parts = ", ".join(f"{k} {v:.2f}" for k, v in cpu.items())
        print(f"{tag}: CPU {parts}; total {total:.2f} = {fmt(total / w if w else None)} × the whole bake's "
              f"{fmt(w)}; merges {fmt(cpu.get('merge', 0) / w if w else None, '{:.3f}')} ×; critical path "
              f"{path:.2f} CPU-s on {tag.split('-N')[1]} machines; peak {rss:.0f} MB (whole "
              f"{fmt(whole['rss_mb'] if whole else None, '{:.0f}')}); byte-identical: "
              f"{'yes' if same == 1 else 'NO' if same == 0 else '—'}")
        # The kernel's share apart: on a virtual machine that hands memory back to its host, a
        # page the process touches first costs milliseconds a megabyte of system time, and the
        # stages' files and buffers touch several times the whole bake's memory.
        ran = [r for r in stages.values() if r["cpu_s"] is not None]
        system, faults = [r["system_s"] for r in ran], [r["faults"] for r in ran]
        if whole and whole["system_s"] is not None and None not in system:
            user, whole_user = total - sum(system), whole["cpu_s"] - whole["system_s"]
            touched = (f"; page faults {sum(faults):,.0f} against {whole['faults']:,.0f}"
                       if whole["faults"] is not None and None not in faults else "")
            print(f"  user {user:.2f} = {user / whole_user:.2f} × the whole bake's {whole_user:.2f}; "
                  f"system {sum(system):.2f} against {whole['system_s']:.2f}{touched}")
        per_texel(tag, stages, cpu, res, baked, seams, bytes_of=runs)


def per_texel(tag, stages, cpu, res, baked, seams, bytes_of):
    """The per-texel figures of one staged pipeline (µs of CPU, bytes)."""
    if not baked:
        return
    pixels = res * res
    mode = tag.split("-N")[0]
    n = int(tag.split("-N")[1])
    bounces = sum(1 for s in stages if s.startswith("merge-lower-"))
    out = [f"prepare {cpu.get('prepare', 0) / pixels * 1e6:.3f} µs/lightmap texel",
           f"shards {cpu.get('shard', 0) / baked * 1e6:.2f} µs/baked texel"]
    if bounces:
        out.append(f"gathers {cpu.get('gather', 0) / baked / bounces * 1e6:.3f} µs/baked texel/bounce")
    out.append(f"merges {cpu.get('merge', 0) / pixels * 1e6:.3f} µs/lightmap texel")
    if "factor" in cpu:
        out.append(f"seam factor {cpu['factor'] / pixels * 1e6:.3f} µs/lightmap texel"
                   + (f" ({cpu['factor'] / seams * 1e6:.2f} µs/seam point)" if seams else ""))
    out.append(f"stitch {cpu.get('stitch', 0) / pixels * 1e6:.3f} µs/lightmap texel"
               + (f" ({cpu.get('stitch', 0) / seams * 1e6:.2f} µs/seam point)" if seams else ""))
    files = []
    for name, per, unit in (("file-prepared", pixels, "lightmap texel"), ("file-parts", baked, "baked texel"),
                            ("file-bounce", pixels, "lightmap texel"), ("file-gathers", baked, "baked texel"),
                            ("file-columns", pixels, "lightmap texel"), ("file-factor", pixels, "lightmap texel")):
        run = stages.get(name)
        if run and run["bytes"]:
            files.append(f"{name[5:]} {run['bytes'] / per:.1f} B/{unit}")
    final = bytes_of.get(f"{mode}:file")
    if final and final["bytes"]:
        files.append(f"final {final['bytes'] / pixels:.1f} B/lightmap texel")
    print(f"  per texel ({n} shards): " + "; ".join(out))
    print("  files: " + "; ".join(files))


def summary(cells):
    print("\nsummary (rates: Mrays per CPU-second; × whole: the staged pipeline's summed CPU over the whole bake's)")
    tags = sorted({t for runs in cells.values() for t in stage_groups(runs)})
    head = "| triangles | lightmap | baked texels | vertex | shadowed | × vertex | × raw | interrefl. | × raw | peak MB sh./ir."
    head += "".join(f" | {t} × whole (merges)" for t in tags) + " |"
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for cell, runs in cells.items():
        quads, res = (int(x) for x in cell.split(":"))
        v, s, i = rate(runs.get("vertex")), rate(runs.get("shadowed")), rate(runs.get("interreflected"))
        rs, ri = rate(runs.get("raw-shadowed")), rate(runs.get("raw-interreflected"))
        sh, ir = runs.get("shadowed") or {}, runs.get("interreflected") or {}
        row = (f"| {2 * quads * quads / 1e6:.2f} M | {res}² | {fmt(sh.get('texels'), '{:,.0f}')} | {fmt(v)} | {fmt(s)} | "
               f"{fmt(s / v if s and v else None)} | {fmt(s / rs if s and rs else None)} | {fmt(i)} | "
               f"{fmt(i / ri if i and ri else None)} | {fmt(sh.get('rss_mb'), '{:.0f}')}/{fmt(ir.get('rss_mb'), '{:.0f}')}")
        groups = stage_groups(runs)
        for t in tags:
            stages = groups.get(t)
            whole = runs.get(t.split("-N")[0])
            if not stages or not whole or not whole["cpu_s"]:
                row += " | —"
                continue
            cpu, total, _, _ = summarise_stages(stages)
            same = stages.get("identical", {}).get("bytes")
            row += (f" | {total / whole['cpu_s']:.2f} ({cpu.get('merge', 0) / whole['cpu_s']:.3f})"
                    + ("" if same == 1 else " differs!"))
        print(row + " |")


def fit(points):
    """(a, b) of t(N) = a + b / N through the measured (N, t) (least squares; two points: exact)."""
    if len(points) == 1:
        n, t = points[0]
        return 0.0, t * n
    xs = [1.0 / n for n, _ in points]
    ys = [t for _, t in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    b = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
    a = my - b * mx
    if a < 0:  # noise: nothing repeated per task
        return 0.0, sum(t * n for n, t in points) / len(points)
    if b < 0:  # noise: nothing divided
        return my, 0.0
    return a, b


def plan(cells, args):
    """The staged pipeline of a --plan RES² lightmap on --nodes N, from the largest cell."""
    mode = "interreflected"
    cell = max((c for c, r in cells.items() if any(t.startswith(mode) for t in stage_groups(r))),
               key=lambda c: int(c.split(":")[1]) ** 2 * 10**7 + int(c.split(":")[0]), default=None)
    if cell is None:
        print("plan: no staged interreflected pipeline measured")
        return
    runs = cells[cell]
    quads, res = (int(x) for x in cell.split(":"))
    tris = 2 * quads * quads
    pixels = res * res
    baked = runs["interreflected"]["texels"]
    ir_rays = runs["interreflected"]["rays"] / baked  # rays per texel of the measured bake
    groups = {int(t.split("-N")[1]): g for t, g in stage_groups(runs).items() if t.startswith(mode)}
    bounces = max(sum(1 for s in g if s.startswith("merge-lower-")) for g in groups.values())
    # Scene loading and the BVH, which every ray-casting process pays: the whole bake's CPU
    # less its --verbose stages (whose sum lightmap_scale.sh records as "stages").
    staged = runs.get("interreflected:stages", {}).get("cpu_s")
    load = runs["interreflected"]["cpu_s"] - staged if staged is not None else 0.0
    # The scene's share of a ray-casting process's memory: the vertex bake's peak (scene, BVH
    # and per-vertex arrays), scaled with the triangles rather than the texels.
    base = runs.get("vertex", {}).get("rss_mb") or 0.0

    def per_task(g, prefix):
        tasks = [r for s, r in g.items() if re.match(prefix + r"-\d+$", s) and r["cpu_s"] is not None]
        return (sum(r["cpu_s"] for r in tasks) / len(tasks), max(r["rss_mb"] for r in tasks)) if tasks else None

    def single(g, name):
        r = g.get(name)
        return (r["cpu_s"], r["rss_mb"]) if r and r["cpu_s"] is not None else None

    def file_bytes(g, name):
        r = g.get(name)
        return r["bytes"] if r and r["bytes"] else 0.0

    P = args.plan ** 2
    R = args.fill * P
    N, T = args.nodes, args.cores
    tri_scale = (args.triangles * 1e6 if args.triangles else tris) / tris
    ray_scale = (args.samples / ir_rays) if args.samples else 1.0
    k_p, k_r = P / pixels, R / baked  # how far each kind of figure is extrapolated
    gbps = args.gbps * 1e9
    rows = []

    def array_stage(label, prefix, scene, rays, reads_each, writes_each, note=""):
        pts = [(n, per_task(g, prefix)[0]) for n, g in sorted(groups.items()) if per_task(g, prefix)]
        mem = [(n, per_task(g, prefix)[1]) for n, g in sorted(groups.items()) if per_task(g, prefix)]
        if not pts:
            return
        a, b = fit(pts)
        fixed = load if scene else 0.0
        a_texels = max(a - fixed, 0.0)
        cpu = fixed * tri_scale + a_texels * k_p + b * k_r * (ray_scale if rays else 1.0) / N
        ma, mb = fit(mem)
        scene_mb = min(base, ma) if scene else 0.0
        rss = scene_mb * tri_scale + (ma - scene_mb) * k_p + mb * k_r * (ray_scale if rays else 1.0) / N
        io = (reads_each + writes_each) / gbps
        rows.append((label, f"{N} × 1", cpu, cpu / T + io, rss, reads_each * N + writes_each * N, note))

    def merge_stage(label, name, reads, writes, note=""):  # also one-task stages that are no merge
        vals = [single(g, name) for g in groups.values() if single(g, name)]
        if not vals:
            return
        cpu = sum(v[0] for v in vals) / len(vals) * k_p
        rss = max(v[1] for v in vals) * k_p
        rows.append((label, "1", cpu, cpu + (reads + writes) / gbps, rss, reads + writes, note))

    g_max = groups[max(groups)]
    n_max = max(groups)
    prep_b = file_bytes(g_max, "file-prepared") * k_p
    parts_b = file_bytes(g_max, "file-parts") * k_r * ray_scale  # rows grow with bounce rays
    bounce_b = file_bytes(g_max, "file-bounce") * k_p
    gathers_b = file_bytes(g_max, "file-gathers") * k_r
    columns_b = file_bytes(g_max, "file-columns") * k_p
    factor_b = file_bytes(g_max, "file-factor") * k_p
    final = runs.get("interreflected:file", {}).get("bytes") or 0.0
    final_b = final * k_p
    prep = [single(g, "prepare") for g in groups.values() if single(g, "prepare")]
    if prep:
        cpu = load * tri_scale + max(sum(p[0] for p in prep) / len(prep) - load, 0.0) * k_p
        rss = max(p[1] for p in prep)
        rss = min(base, rss) * tri_scale + max(rss - base, 0.0) * k_p
        rows.append(("prepare-lightmap", "1", cpu, cpu / T + prep_b / gbps, rss, prep_b, "scene + BVH, atlas, leak test"))
    merge_stage("factor-seams (beside the shards)", "factor", prep_b, factor_b, "beside the shards")
    array_stage("bake --prepared --shard", "shard", True, True, prep_b, parts_b / N, "the rays")
    merge_stage("merge --direct", "merge-direct", parts_b, bounce_b)
    for k in range(1, bounces + 1):
        # A gather's divided work and memory are its part's bounce rows: they grow with the rays.
        array_stage(f"gather bounce {k}", f"gather-{k}", False, True, bounce_b + parts_b / N, gathers_b / N)
        # The last merge reads the seam factor too where it stitches (no stitch shards).
        last_reads = 0.0 if k < bounces or "join" in g_max else factor_b
        merge_stage(f"merge --lower {k}", f"merge-lower-{k}", bounce_b + gathers_b + last_reads,
                    bounce_b if k < bounces else final_b)
    stitch_reads = final_b + (factor_b if factor_b else prep_b)
    array_stage("stitch --columns", "stitch", False, False, stitch_reads, columns_b / N)
    merge_stage("stitch --join", "join", final_b + columns_b, final_b)
    print(f"\nplan: {args.plan}² lightmap ({P / 1e6:.1f} M texels, fill {args.fill}: {R / 1e6:.1f} M baked), "
          f"{tris * tri_scale / 1e6:.1f} M triangles, interreflected {bounces} bounces, "
          f"{ir_rays * ray_scale:.0f} rays per texel, {N} nodes × {T} cores, {args.gbps} GB/s per task; "
          f"from cell {cell} ({pixels / 1e6:.2f} M texels, shards {sorted(groups)}): texel figures "
          f"× {k_p:.1f}, rays × {k_r * ray_scale:.1f}, scene × {tri_scale:.1f}")
    print("| stage | tasks | CPU-s per task | wall s | peak GB per task | GB moved |")
    print("|---|---:|---:|---:|---:|---:|")
    total_wall = total_cpu = 0.0
    for label, tasks, cpu, wall, rss, moved, note in rows:
        n = N if tasks != "1" else 1
        total_wall += 0.0 if note.startswith("beside") else wall
        total_cpu += cpu * n
        print(f"| {label} | {tasks} | {cpu:,.0f} | {wall:,.0f} | {rss / 1024:.1f} | {moved / 1e9:,.1f} |")
    print(f"| **total** | | {total_cpu:,.0f} (all tasks) | **{total_wall:,.0f}** | | |")
    # The whole bake: its preparation per texel (as the prepare job's), the rest per ray.
    prep_cpu = sum(p[0] for p in prep) / len(prep) if prep else load
    whole = (load * tri_scale + (prep_cpu - load) * k_p
             + max(runs["interreflected"]["cpu_s"] - prep_cpu, 0.0) * k_r * ray_scale)
    # (Its hit cache, 12 bytes a bounce ray, grows with the rays; not scaled here.)
    whole_mb = min(base, runs["interreflected"]["rss_mb"]) * tri_scale + max(runs["interreflected"]["rss_mb"] - base, 0) * k_p
    print(f"one node alone, the whole bake: ≈ {whole:,.0f} CPU-s = {whole / T:,.0f} s on {T} cores, "
          f"peak ≈ {whole_mb / 1024:.1f} GB (without the hit cache's growth with the rays)")


def main():
    p = argparse.ArgumentParser()
    p.add_argument("results")
    p.add_argument("--cell")
    p.add_argument("--threads", type=int, default=0)
    p.add_argument("--plan", type=int, help="plan a RES² lightmap from the measured figures")
    p.add_argument("--nodes", type=int, default=16)
    p.add_argument("--cores", type=int, default=16)
    p.add_argument("--triangles", type=float, help="millions of triangles (default: the measured scene's)")
    p.add_argument("--fill", type=float, default=1.0, help="baked fraction of the lightmap's texels")
    p.add_argument("--samples", type=float, help="rays per texel (default: the measured bake's)")
    p.add_argument("--gbps", type=float, default=1.0, help="GB/s each task reads and writes (shared file system)")
    a = p.parse_args()
    cells = load(a.results)
    if a.plan:
        plan(cells, a)
    elif a.cell:
        if a.cell in cells:
            cell_report(a.cell, cells[a.cell], a.threads)
    else:
        summary(cells)


if __name__ == "__main__":
    main()
