// Moving occluders in the browser (docs/guides/occluders.md): a sphere set fitted to an object
// (`prt-bake bake OBJ --occluder -o OBJ_OCC.prt`) darkens a baked scene where it stands.
//
//   import { parseOccluder, occluderSpheresForObject, occludedTransfer } from './occluders.js';
//   const ball = parseOccluder(await (await fetch('ball.occ')).arrayBuffer());
//   // each frame the ball moves (beside probeLightForObject, which lights it); a scene
//   // exported to .glb has its positions, normals and transfer in glTF's frame, so 'y':
//   const spheres = occluderSpheresForObject(ball, mesh, 'y');
//   const shadowed = occludedTransfer(transfer, channels, order, positions, normals, spheres);
//
// Per receiver within reach of a sphere, the spheres' visibility V is built in SH (each a cap
// in closed form, several multiplied by the truncated triple product), and the transfer is
// replaced by T′ = Γ(T, V), the order-n projection of T·V; relighting T′ with any light gives
// ∫ L·T·V, the triple product of light, transfer and visibility, as
// `prt-bake relight --occluder` (baker/src/export/relight_occluded.rs) computes it.
// scripts/browser/occluder-test.mjs holds the two to each other.
import { GLTF_TO_Z_UP, Z_UP_TO_GLTF } from './sh.js';

const MAGIC = [0x89, 0x50, 0x52, 0x54, 0x4f, 0x43, 0x43, 0x0a]; // \x89PRTOCC\n
/** Spheres farther than this many radii from a receiver are left out (as the baker does). */
export const REACH = 10;

/** An occluder file's spheres, in the object's frame: { spheres: [{ centre: [x, y, z], radius }] }. */
export function parseOccluder(buffer) {
  const bytes = new Uint8Array(buffer);
  if (bytes.length < 16 || MAGIC.some((b, i) => bytes[i] !== b)) throw new Error('occluder: bad magic');
  const view = new DataView(buffer);
  const version = view.getUint32(8, true);
  if (version !== 1) throw new Error(`occluder: version ${version}, this reads 1`);
  const count = view.getUint32(12, true);
  if (count < 1 || bytes.length !== 16 + 16 * count) throw new Error(`occluder: ${bytes.length} bytes for ${count} spheres`);
  const spheres = [];
  for (let s = 0; s < count; s++) {
    const f = (k) => view.getFloat32(16 + 16 * s + 4 * k, true);
    spheres.push({ centre: [f(0), f(1), f(2)], radius: f(3) });
  }
  return { spheres };
}

/** The spheres placed: turned by `rotation` (row-major 3×3) about the object's origin, moved to `position`. */
export function placeOccluder(occluder, position, rotation) {
  const m = rotation;
  return occluder.spheres.map(({ centre: c, radius }) => ({
    centre: [0, 1, 2].map((i) => position[i] + m[3 * i] * c[0] + m[3 * i + 1] * c[1] + m[3 * i + 2] * c[2]),
    radius,
  }));
}

/**
 * The spheres of an occluder carried by the THREE.Object3D `object` (its matrixWorld, updated
 * here, scale taken out), in the scene frame of a z-up bake exported to .glb (glTF's +Y up
 * turned back), or in three's world (the .glb's own frame, where its transfer is) when `up`
 * is 'y'. The occluder's spheres are in the object's source frame: a z-up object (an OBJ,
 * `objectUp` 'z') exported to .glb has its vertices turned to +Y up, (x, y, z) ↦ (x, z, −y),
 * and its spheres are turned the same way before the object's matrix places them.
 */
export function occluderSpheresForObject(occluder, object, up = 'z', objectUp = 'z') {
  object.updateWorldMatrix(true, false);
  const e = object.matrixWorld.elements;
  const scale = [0, 1, 2].map((c) => Math.hypot(e[4 * c], e[4 * c + 1], e[4 * c + 2]));
  const rotation = [0, 1, 2].flatMap((r) => [0, 1, 2].map((c) => e[4 * c + r] / scale[c]));
  const apply = (m, v) => [0, 1, 2].map((i) => m[3 * i] * v[0] + m[3 * i + 1] * v[1] + m[3 * i + 2] * v[2]);
  const local = objectUp === 'y' ? occluder.spheres
    : occluder.spheres.map(({ centre, radius }) => ({ centre: apply(Z_UP_TO_GLTF, centre), radius }));
  const placed = placeOccluder({ spheres: local }, [e[12], e[13], e[14]], rotation);
  if (up === 'y') return placed;
  return placed.map(({ centre, radius }) => ({ centre: apply(GLTF_TO_Z_UP, centre), radius }));
}

/** y_i(d) for i < n², d unit (the baker's recurrence, Condon–Shortley phase). */
export function shBasis(order, d) {
  const out = new Float64Array(order * order);
  const [x, y, z] = d;
  let c = 1;
  let s = 0;
  let qmm = 1;
  for (let m = 0; m < order; m++) {
    if (m > 0) {
      [c, s] = [c * x - s * y, c * y + s * x];
      qmm *= -(2 * m - 1);
    }
    let q2 = 0;
    let q1 = qmm;
    for (let l = m; l < order; l++) {
      let q;
      if (l === m) q = qmm;
      else if (l === m + 1) q = z * (2 * m + 1) * qmm;
      else q = (z * (2 * l - 1) * q1 - (l + m - 1) * q2) / (l - m);
      if (l > m) [q2, q1] = [q1, q];
      const k = normalization(l, m) * (m === 0 ? 1 : Math.SQRT2);
      if (m === 0) out[l * (l + 1)] = k * q;
      else {
        out[l * (l + 1) + m] = k * q * c;
        out[l * (l + 1) - m] = k * q * s;
      }
    }
  }
  return out;
}

function normalization(l, m) {
  let ratio = 1;
  for (let k = l - m + 1; k <= l + m; k++) ratio /= k;
  return Math.sqrt(((2 * l + 1) / (4 * Math.PI)) * ratio);
}

function legendre(l, x) {
  if (l === 0) return 1;
  let [p0, p1] = [1, x];
  for (let k = 2; k <= l; k++) [p0, p1] = [p1, ((2 * k - 1) * x * p1 - (k - 1) * p0) / k];
  return p1;
}

/** The SH (order n) of the visibility one sphere leaves a receiver at `point`: 1 − its cap. */
export function sphereVisibility(order, point, sphere) {
  const v = sphere.centre.map((c, i) => c - point[i]);
  const d = Math.hypot(...v);
  if (d <= sphere.radius) return new Float64Array(order * order);
  const sinA = sphere.radius / d;
  const cosA = Math.sqrt(1 - sinA * sinA);
  const out = shBasis(order, v.map((x) => x / d));
  for (let l = 0; l < order; l++) {
    const integral = l === 0 ? 1 - cosA : (legendre(l - 1, cosA) - legendre(l + 1, cosA)) / (2 * l + 1);
    const cap = 2 * Math.PI * normalization(l, 0) * integral;
    const scale = -Math.sqrt((4 * Math.PI) / (2 * l + 1)) * cap;
    for (let i = l * l; i < (l + 1) * (l + 1); i++) out[i] *= scale;
  }
  out[0] += Math.sqrt(4 * Math.PI);
  return out;
}

const gaunts = new Map();

/**
 * The non-zero entries [i, j, k, Γ_ijk] of the triple-product tensor at `order`, by quadrature
 * exact for three order-n functions (Gauss–Legendre in cos θ, equal steps in φ); cached.
 */
export function gaunt(order) {
  if (gaunts.has(order)) return gaunts.get(order);
  const n = order * order;
  const degree = 3 * (order - 1);
  const [nodes, weights] = gaussLegendre(Math.floor(degree / 2) + 1);
  const steps = degree + 1;
  const points = [];
  nodes.forEach((z, a) => {
    const r = Math.sqrt(Math.max(0, 1 - z * z));
    for (let k = 0; k < steps; k++) {
      const phi = (2 * Math.PI * k) / steps;
      points.push([(weights[a] * 2 * Math.PI) / steps, shBasis(order, [r * Math.cos(phi), r * Math.sin(phi), z])]);
    }
  });
  const entries = [];
  for (let i = 0; i < n; i++) for (let j = 0; j < n; j++) for (let k = 0; k < n; k++) {
    let value = 0;
    for (const [w, y] of points) value += w * y[i] * y[j] * y[k];
    if (Math.abs(value) > 1e-12) entries.push([i, j, k, value]);
  }
  gaunts.set(order, entries);
  return entries;
}

function gaussLegendre(n) {
  const nodes = new Float64Array(n);
  const weights = new Float64Array(n);
  for (let i = 0; i < Math.ceil(n / 2); i++) {
    let x = Math.cos((Math.PI * (i + 0.75)) / (n + 0.5));
    let derivative = 0;
    for (let it = 0; it < 100; it++) {
      let [p0, p] = [1, x];
      for (let k = 2; k <= n; k++) [p0, p] = [p, ((2 * k - 1) * x * p - (k - 1) * p0) / k];
      derivative = (n * (x * p - p0)) / (x * x - 1);
      const step = p / derivative;
      x -= step;
      if (Math.abs(step) < 1e-16) break;
    }
    nodes[i] = -x;
    nodes[n - 1 - i] = x;
    weights[i] = weights[n - 1 - i] = 2 / ((1 - x * x) * derivative * derivative);
  }
  return [nodes, weights];
}

/** out = Γ(a, b): the order-n projection of the product of a and b. */
export function shProduct(order, a, b) {
  const out = new Float64Array(order * order);
  for (const [i, j, k, g] of gaunt(order)) out[i] += g * a[j] * b[k];
  return out;
}

/**
 * The visibility the spheres leave a receiver at `point` with `normal`, the product of each
 * sphere's, or null where none is within REACH radii and above its horizon.
 */
export function occluderVisibility(order, point, normal, spheres) {
  let v = null;
  for (const s of spheres) {
    const o = s.centre.map((c, i) => c - point[i]);
    if (Math.hypot(...o) > REACH * s.radius || o[0] * normal[0] + o[1] * normal[1] + o[2] * normal[2] < -s.radius) continue;
    const one = sphereVisibility(order, point, s);
    v = v ? shProduct(order, v, one) : one;
  }
  return v;
}

/**
 * A vector bake's transfer (V × C × n² floats) darkened by `spheres`: each receiver (positions
 * and normals, 3 floats each) within reach gets T′ = Γ(T, V), the others keep T. Relight the
 * result as before (applyPRT's setLight, or Σ T′_j L_j).
 */
export function occludedTransfer(transfer, channels, order, positions, normals, spheres) {
  const n = order * order;
  const out = Float32Array.from(transfer);
  const count = positions.length / 3;
  for (let r = 0; r < count; r++) {
    const p = [positions[3 * r], positions[3 * r + 1], positions[3 * r + 2]];
    const nn = [normals[3 * r], normals[3 * r + 1], normals[3 * r + 2]];
    const v = occluderVisibility(order, p, nn, spheres);
    if (!v) continue;
    for (let c = 0; c < channels; c++) {
      const at = (r * channels + c) * n;
      out.set(shProduct(order, transfer.subarray(at, at + n), v), at);
    }
  }
  return out;
}
