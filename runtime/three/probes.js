// Transfer probes in the browser (docs/guides/probes.md): a probe bake (`prt-bake bake SCENE
// --probes grid:NX,NY,NZ -o probes.prt`) read as it is, and the light a rigid object moving
// through the scene receives where it stands.
//
//   import { loadProbes, probeLightAt, lightProbeCoefficients } from './prt.js';
//   const probes = await loadProbes('probes.prt');
//   prt.setLight(probeLightAt(probes, position, rotation, light));   // a PRT mesh baked alone
//   prt.setLight(probeLightForObject(probes, mesh, light));       // each frame, as `mesh` moves
//   lightProbe.sh.fromArray(lightProbeCoefficients(probeIncident(probes, position, light)).flat());
//
// Positions and lights are in the probes' scene frame (z up for OBJ scenes); `rotation` is the
// object's row-major 3×3 rotation (object frame to scene frame). The reference is the baker's
// baker/src/export/probe_field.rs; scripts/browser/probe-test.mjs holds the two to each other.
import { coeffCount, rotateLight, GLTF_TO_Z_UP, Z_UP_TO_GLTF } from './sh.js';

const MAGIC = [0x89, 0x50, 0x52, 0x54, 0x0d, 0x0a, 0x1a, 0x0a];
const PROBE_HEADER_SIZE = 176;
/** Above this back-face fraction a probe is inside geometry and left out. */
export const INSIDE_FRACTION = 0.25;

/**
 * A probe file's contents: { order, channels, count, up: 'z'|'y', grid: { counts, lo, hi } or
 * null, positions: Float32Array(3P), backfaces: Float32Array(P), matrices: Float32Array(P·C·n⁴) }.
 */
export function parseProbes(buffer) {
  const view = new DataView(buffer);
  if (buffer.byteLength < PROBE_HEADER_SIZE || MAGIC.some((b, i) => view.getUint8(i) !== b)) {
    throw new Error('prt probes: not a PRT coefficient file');
  }
  if (view.getUint32(12, true) !== PROBE_HEADER_SIZE) {
    throw new Error(`prt probes: header size ${view.getUint32(12, true)}, not a probe bake (bake --probes)`);
  }
  const order = view.getUint32(16, true);
  const channels = view.getUint32(20, true);
  const count = Number(view.getBigUint64(24, true));
  const n = coeffCount(order);
  const floats = count * channels * n * n;
  const expected = PROBE_HEADER_SIZE + 4 * (floats + 4 * count);
  if (buffer.byteLength !== expected) {
    throw new Error(`prt probes: ${buffer.byteLength} bytes, ${count} probes need ${expected}`);
  }
  const counts = [136, 140, 144].map((o) => view.getUint32(o, true));
  const box = [148, 152, 156, 160, 164, 168].map((o) => view.getFloat32(o, true));
  const grid = counts.every((c) => c === 0) ? null : { counts, lo: box.slice(0, 3), hi: box.slice(3) };
  const at = (offset, length) => new Float32Array(buffer.slice(offset, offset + 4 * length));
  const matrices = at(PROBE_HEADER_SIZE, floats);
  const positions = at(PROBE_HEADER_SIZE + 4 * floats, 3 * count);
  const backfaces = at(PROBE_HEADER_SIZE + 4 * (floats + 3 * count), count);
  return { order, channels, count, up: view.getUint32(84, true) === 1 ? 'y' : 'z', grid, positions, backfaces, matrices };
}

/** Fetches and parses a probe file. */
export async function loadProbes(url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`prt probes: ${url}: HTTP ${response.status}`);
  return parseProbes(await response.arrayBuffer());
}

/**
 * The probes' weights at x: trilinear over the grid cell around it (x clamped to the cell
 * centres), probes inside geometry left out and the others renormalised. [[index, weight]…]
 */
export function probeWeights(probes, x) {
  const { counts, lo, hi } = probes.grid ?? (() => { throw new Error('prt probes: interpolation needs a grid bake (--probes grid:…)'); })();
  const axes = [0, 1, 2].map((a) => {
    const n = counts[a];
    const size = Math.max((hi[a] - lo[a]) / n, Number.MIN_VALUE);
    const u = Math.min(Math.max((x[a] - lo[a]) / size - 0.5, 0), n - 1);
    const i = Math.min(Math.floor(u), Math.max(n - 2, 0));
    const t = n === 1 ? 0 : u - i;
    return [[i, 1 - t], [Math.min(i + 1, n - 1), t]];
  });
  const weights = [];
  for (const [k, wz] of axes[2]) for (const [j, wy] of axes[1]) for (const [i, wx] of axes[0]) {
    const p = i + counts[0] * (j + counts[1] * k);
    const w = wx * wy * wz;
    if (w > 0 && probes.backfaces[p] <= INSIDE_FRACTION) weights.push([p, w]);
  }
  const total = weights.reduce((s, [, w]) => s + w, 0);
  return weights.map(([p, w]) => [p, w / total]);
}

/** The incident radiance at x, L_in = Σ w_p M_p·L (a light of the probes' order). */
export function probeIncident(probes, x, light) {
  const n = coeffCount(probes.order);
  if (light.order !== probes.order) throw new Error(`prt probes: a light of order ${light.order}, probes of order ${probes.order}`);
  const rgb = [0, 1, 2].map(() => new Float64Array(n));
  for (const [p, w] of probeWeights(probes, x)) {
    rgb.forEach((out, c) => {
      const channel = probes.channels === 1 ? 0 : c;
      const start = (p * probes.channels + channel) * n * n;
      for (let i = 0; i < n; i++) {
        let dot = 0;
        for (let j = 0; j < n; j++) dot += probes.matrices[start + i * n + j] * light.rgb[c][j];
        out[i] += w * dot;
      }
    });
  }
  return { order: light.order, rgb };
}

/**
 * The light, in its own frame, of a rigid PRT object at `position` turned by `rotation`
 * (row-major 3×3, object to scene): R⁻¹·L_in, for its `setLight`.
 */
export function probeLightAt(probes, position, rotation, light) {
  const m = rotation;
  const inverse = [m[0], m[3], m[6], m[1], m[4], m[7], m[2], m[5], m[8]];
  return rotateLight(probeIncident(probes, position, light), inverse);
}

/**
 * Incident radiance as three.js's LightProbe wants it: the first 9 coefficients, [r, g, b]
 * each, in three.js's basis, which has no Condon–Shortley phase (its y₁⁻¹, y₁¹, y₂⁻¹, y₂¹ are
 * ours negated); LightProbe applies the clamped cosine itself.
 */
export function lightProbeCoefficients(incident) {
  const flip = [1, -1, 1, -1, 1, -1, 1, -1, 1];
  return flip.map((s, j) => incident.rgb.map((c) => (j < c.length ? s * c[j] : 0)));
}

/**
 * The light of a moving PRT mesh (an object baked alone and exported to .glb; `applyPRT`'s
 * handle.setLight takes it) from where three.js has put it: `object` is the THREE.Object3D
 * whose local frame the transfer is in (the glTF mesh), its matrixWorld (updated here) its
 * place in a world whose frame is the probe scene's turned to glTF's +Y up (a z-up scene
 * exported to .glb), or the probe scene's own frame when that is y-up. `light` is in the
 * probes' scene frame. Call it each frame the object moves: R⁻¹·L_in at its position.
 */
export function probeLightForObject(probes, object, light) {
  object.updateWorldMatrix(true, false);
  const e = object.matrixWorld.elements;
  // Row-major rotation of the world matrix (column-major), its columns' scale taken out.
  const scale = [0, 1, 2].map((c) => Math.hypot(e[4 * c], e[4 * c + 1], e[4 * c + 2]));
  const inverse = [0, 1, 2].flatMap((r) => [0, 1, 2].map((c) => e[4 * r + c] / scale[r]));
  const world = [e[12], e[13], e[14]];
  if (probes.up === 'y') return rotateLight(probeIncident(probes, world, light), inverse);
  const x = [0, 1, 2].map((i) => GLTF_TO_Z_UP[3 * i] * world[0] + GLTF_TO_Z_UP[3 * i + 1] * world[1] + GLTF_TO_Z_UP[3 * i + 2] * world[2]);
  return rotateLight(rotateLight(probeIncident(probes, x, light), Z_UP_TO_GLTF), inverse);
}
