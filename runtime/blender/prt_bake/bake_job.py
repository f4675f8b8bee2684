"""One bake as a background process: the scene (Blender's glTF export, export.py),
`prt-bake bake`, its progress, and the transfer read back: per face corner (corner_map.py),
or (lightmaps) per object's tile.

Where every mesh node receives and no mesh is shared, a vertex bake runs with `--checkpoint DIR`:
prt-bake writes each finished block of vertices into DIR, and the number of blocks there is
the progress (prt-bake draws its own progress bar only on a terminal). The checkpointed file
is byte-identical to an uninterrupted bake's. Otherwise (occluders, instances) it runs whole,
as receivers and instancing need, and so do lightmap bakes (`--denoise auto` denoises whole
lightmap bakes only): the progress then shows only the end.

Driving it: `start()`, then `poll()` until it returns True (the modal operator polls on a
timer; a script may call `run()`, which polls until done); `cancel()` stops it. Every
failure raises PrtError; the temporary folder is removed in every case by `close()`.
"""

import contextlib
import math
import os
import shutil
import subprocess
import time
from dataclasses import dataclass

import numpy as np

from . import corner_map, gltf_scene, ldprt
from .errors import PrtError
from .process import failure, run_prt_bake
from .sh_frame import gltf_to_blender

PROGRESS_BLOCKS = 40  # checkpoint blocks per bake at most: the progress bar's steps
# Vertices (texels) per block at least: smaller blocks cost time (a 2,953-vertex bake at
# 4,096 rays took 1.2–1.4 times as long in blocks of 74 as in one, and the same, within
# the noise, in blocks of 512).
MIN_BLOCK = 512


@dataclass
class BakeSettings:
    order: int = 4
    samples: int = 256
    mode: str = "shadowed"  # or "interreflected"
    seed: int = 0
    threads: int = 0  # 0: all cores
    lightmap: int = 0  # texels per side of each object's lightmap; 0: a per-vertex bake
    lightmap_uv: str = ""  # the UV map (empty: the second, else the only one)
    double_sided: str = "off"  # prt-bake --double-sided: auto or off
    denoise: str = "auto"  # prt-bake --denoise: auto, on or off
    transfer: str = "sh"  # or "ldprt": zonal lobes that follow an armature (ldprt.py)
    lobes: int = 3  # LDPRT lobes per vertex (--lobes)
    pose: str = "REST"  # LDPRT: bake the armatures' rest pose, or "CURRENT"
    pose_argument: str = "rest"  # LDPRT: prt-bake's --pose (export.pose_argument)


class BakeJob:
    def __init__(self, executable, settings, plan, folder):
        """`plan` (export.Plan): the scene already exported into `folder`/scene.glb (for
        lightmaps with its receivers' UVs tiled, export.tile_lightmaps)."""
        self.executable, self.settings = executable, settings
        self.plan, self.folder, self.receivers = plan, folder, plan.receivers
        self.summary = ""
        self.warnings = []
        self.process = None
        self.progress = 0.0
        self.transfer = None  # per receiver: (loops, channels, n²) float32, once done

    def _path(self, name):
        return os.path.join(self.folder, name)

    def tiles(self):
        """Lightmap bakes: objects side by side in a g × g grid of RES² tiles, each object's
        own [0, 1] UVs in its tile, so prt-bake's atlas is the tiles and each object's image
        is its tile. Returns g."""
        return math.ceil(math.sqrt(len(self.receivers)))

    def _work(self):
        """Vertices, or (lightmaps) about how many texels the UVs cover."""
        if not self.settings.lightmap:
            return max(1, sum(len(r.obj.data.loops) for r in self.plan.receivers))
        area = 0.0
        for r in self.receivers:
            for p in r.primitives:
                t = p["uv1"][p["triangles"]]
                e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
                area += 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
        return max(1, round(area * self.settings.lightmap ** 2))

    def command(self):
        s = self.settings
        vertices = self._work()
        block = max(MIN_BLOCK, math.ceil(vertices / PROGRESS_BLOCKS))
        self.blocks_total = math.ceil(vertices / block)
        ldprt = s.transfer == "ldprt"
        arguments = [
            "bake", self._path("scene.glb"), "-o", self._path("scene.prt"),
            "--order", str(s.order), "--samples", str(s.samples), "--mode", s.mode,
            "--seed", str(s.seed), "--quiet",
        ]
        if ldprt:  # whole (no checkpoints); the pose is the export's own (export.py)
            arguments += ["--transfer", "ldprt", "--lobes", str(s.lobes), "--pose",
                          s.pose_argument]
        # Lightmaps run whole: `--denoise auto` denoises whole lightmap bakes only.
        if self.plan.flat and not s.lightmap and not ldprt:
            arguments += ["--checkpoint", self._path("blocks"),
                          "--checkpoint-vertices", str(block)]
        arguments += ["--double-sided", s.double_sided, "--denoise", s.denoise]
        if s.mode != "interreflected":
            arguments += ["--instances", "on"]
        if s.threads:
            arguments += ["--threads", str(s.threads)]
        if s.lightmap:
            arguments += ["--lightmap", str(s.lightmap * self.tiles()), "--strict-uvs"]
        return [self.executable, *arguments]

    def start(self):
        try:
            os.mkdir(self._path("blocks"))
            command = self.command()
            self.log = open(self._path("bake.log"), "w+")
            self.process = subprocess.Popen(command, stdout=self.log, stderr=subprocess.STDOUT,
                                            stdin=subprocess.DEVNULL)
        except OSError as err:
            self.close()
            raise PrtError(f"cannot start prt-bake: {err}") from None
        except BaseException:
            self.close()
            raise

    def poll(self):
        """True once the result is read; False while prt-bake runs (self.progress is the
        fraction of blocks done)."""
        code = self.process.poll()
        if code is None:
            try:
                names = os.listdir(self._path("blocks"))
            except OSError:  # prt-bake is finishing; the next poll sees it done
                return False
            done = len([n for n in names if n.startswith("block-") and n.endswith(".prt")])
            self.progress = min(done / max(self.blocks_total, 1), 0.99)
            return False
        if code != 0:
            self.log.seek(0)
            raise failure("bake", code, self.log.read())
        self.log.seek(0)
        lines = self.log.read().splitlines()
        baked = [line for line in lines if line.startswith("baked ")]
        self.summary = baked[-1] if baked else ""
        # prt-bake's own warnings (a skipped primitive, UVs it unwrapped…), for the UI.
        self.warnings = [line.replace(self._path("scene.glb"), "the scene")
                         for line in lines if line.startswith("warning: ")]
        self._read_result()
        self.progress = 1.0
        return True

    def run(self, interval=0.05):
        """Polls to the end (scripts and the operator's non-interactive call)."""
        while not self.poll():
            time.sleep(interval)

    def cancel(self):
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.close()

    def close(self):
        if getattr(self, "log", None) is not None:
            self.log.close()
            self.log = None
        if self.folder is not None:
            shutil.rmtree(self.folder, ignore_errors=True)
            self.folder = None

    def _read_result(self):
        if self.settings.transfer == "ldprt":
            self._read_ldprt()
            return
        npz = self._path("scene.npz")
        run_prt_bake(self.executable, ["export", self._path("scene.prt"),
                                       "--scene", self._path("scene.glb"), "--npz", npz])
        if self.settings.lightmap:
            self._read_lightmaps(npz)
            return
        self._read_corners(npz)

    def _read_lightmaps(self, npz):
        """self.transfer: per receiver its tile, (RES, RES, channels, n²), row 0 at v = 0."""
        with np.load(npz) as f:
            transfer = np.asarray(f["transfer"], np.float32)
            uv1 = np.asarray(f["uv1"], np.float64)
        # Occluders' triangles are outside the atlas, at (-1, -1).
        uv1 = uv1[(uv1 >= 0).all(axis=(1, 2))]
        transfer = transfer @ gltf_to_blender(self.settings.order).astype(np.float32).T
        ours = np.concatenate([p["atlas_uv"][p["triangles"]]
                               for r in self.receivers for p in r.primitives])
        if uv1.shape != ours.shape or not np.allclose(uv1, ours, atol=1e-5):
            raise PrtError("prt-bake did not bake on the add-on's lightmap UVs")
        g, res = self.tiles(), self.settings.lightmap
        self.transfer = []
        for i, _ in enumerate(self.receivers):
            x, y = (i % g) * res, (i // g) * res
            self.transfer.append(transfer[y:y + res, x:x + res])

    def _read_corners(self, npz):
        """self.transfer: per plan receiver (loops, channels, n²) in Blender's frame;
        self.albedo: per receiver (loops, 3), prt-bake's (base colour × texture)."""
        with np.load(npz) as f:
            transfer = np.asarray(f["transfer"], np.float64)
            positions = np.asarray(f["positions"], np.float64)
            normals = np.asarray(f["normals"], np.float64)
            albedo = np.asarray(f["albedo"], np.float32)
            receives = np.asarray(f["receives"]) if "receives" in f.files else None
        if transfer.ndim == 2:
            transfer = transfer[:, None, :]
        turn = gltf_to_blender(self.settings.order)
        glb_ = self.plan.glb
        depsgraph = bpy_depsgraph()
        self.transfer, self.albedo, cursor = [], [], 0
        for r in self.plan.receivers:
            primitives = gltf_scene.triangle_primitives(glb_, r.node)
            count = sum(c for c, _ in primitives)
            if receives is not None:  # skip the flattened occluders' vertices
                ahead = np.flatnonzero(receives[cursor:] > 0)
                cursor += int(ahead[0]) if len(ahead) else 0
                if not (receives[cursor:cursor + count] > 0).all():
                    raise PrtError(f"{r.obj.name}: prt-bake's receivers are not the add-on's")
            corner, position, normal = corner_map.corner_vertices(r.obj, depsgraph,
                                                                  primitives, cursor)
            if corner.max() >= len(transfer):
                raise PrtError(f"{r.obj.name}: prt-bake baked fewer vertices than exported")
            corner_map.check(r.obj, positions[corner], normals[corner], position, normal)
            self.transfer.append((transfer[corner] @ turn.T).astype(np.float32))
            self.albedo.append(albedo[corner])
            cursor += count

    def _read_ldprt(self):
        """self.transfer: per plan receiver ldprt.read's arrays (its face corners' frames in
        the rest pose, lobes, joints and weights), from the LDPRT export's skinned GLB."""
        glb = self._path("scene-ldprt.glb")
        run_prt_bake(self.executable, ["export", self._path("scene.prt"), "--scene",
                                       self._path("scene.glb"), "--glb", glb])
        with rest_pose(self.plan.receivers) as depsgraph:
            self.transfer = ldprt.read(glb, self.plan, depsgraph, self.settings)


@contextlib.contextmanager
def rest_pose(receivers):
    """The evaluated depsgraph with the receivers' armatures in their rest pose (the LDPRT
    export's frames are in the bind space, its joints at rest: the corners are checked there),
    put back as they were afterwards."""
    import bpy

    changed = []
    for r in receivers:
        armature = ldprt.armature_of(r.obj)
        if armature is not None and armature.data.pose_position != "REST":
            changed.append(armature.data)
            armature.data.pose_position = "REST"
    try:
        if changed:
            bpy.context.view_layer.update()
        yield bpy.context.evaluated_depsgraph_get()
    finally:
        for data in changed:
            data.pose_position = "POSE"
        if changed:
            bpy.context.view_layer.update()


def bpy_depsgraph():
    import bpy
    return bpy.context.evaluated_depsgraph_get()
