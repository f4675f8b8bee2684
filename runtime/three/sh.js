// Spherical-harmonic lights for prt.js, without three.js (so node can test it on its own).
//
// Conventions (the baker's, docs/reference/gltf.md): real orthonormal SH, coefficient (l, m) at index
// l(l+1)+m, θ from +z, φ from +x towards +y, Condon–Shortley phase (y_1^1 = −0.488603·x).
// A light is { order, rgb: [Float64Array(n²) × 3] }.

/** Number of coefficients of an order (n²). */
export function coeffCount(order) {
  return order * order;
}

/**
 * The light that `prt-bake light RIG --order N [--up y] -o light.json` writes, parsed
 * (`json` an object or a JSON string). Throws an Error naming the problem.
 */
export function lightFromJSON(json) {
  const value = typeof json === 'string' ? JSON.parse(json) : json;
  if (!value || typeof value !== 'object') throw new Error('prt light: not a JSON object');
  const order = value.order;
  if (!Number.isInteger(order) || order < 1 || order > 16) {
    throw new Error(`prt light: "order" must be an integer in 1..16, got ${order}`);
  }
  const c = value.coefficients;
  const n = coeffCount(order);
  if (!Array.isArray(c) || c.length !== 3) {
    throw new Error('prt light: "coefficients" must hold 3 arrays (R, G, B)');
  }
  const rgb = c.map((channel, i) => {
    if (!Array.isArray(channel) || channel.length !== n) {
      throw new Error(`prt light: channel ${'RGB'[i]} has ${channel?.length} coefficients, order ${order} needs ${n}`);
    }
    if (!channel.every(Number.isFinite)) {
      throw new Error(`prt light: channel ${'RGB'[i]} holds a non-finite number`);
    }
    return Float64Array.from(channel);
  });
  return { order, rgb };
}

/** The light cut or zero-padded to another order. */
export function lightOfOrder(light, order) {
  const n = coeffCount(order);
  return {
    order,
    rgb: light.rgb.map((channel) => {
      const out = new Float64Array(n);
      out.set(channel.subarray(0, Math.min(n, channel.length)));
      return out;
    }),
  };
}

/**
 * The SH matrix of the rotation `m` (row-major 3×3, orthonormal, determinant +1), for any
 * order: one (2l+1)² row-major block per band, rows the output m, columns the input m′.
 * It carries a function along with the rotation: g(s) = f(mᵀs), so a light that shone from
 * d shines from m·d. Ivanic & Ruedenberg's recurrence (J. Phys. Chem. 1996, 100, 6342, with
 * the 1998 erratum), stated without the Condon–Shortley phase; the blocks are then conjugated
 * by diag((−1)^m): entry (m, m′) changes sign when m + m′ is odd. The same construction as
 * the baker's `RecurrenceRotator` (baker/src/sh/rotation.rs).
 */
export function shRotation(order, m) {
  checkRotation(m);
  const bands = [];
  if (order > 0) bands.push(Float64Array.of(1));
  if (order > 1) {
    // Band 1 without the phase is (y, z, x) up to one constant.
    const axis = [1, 2, 0];
    const b = new Float64Array(9);
    for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) b[i * 3 + j] = m[axis[i] * 3 + axis[j]];
    bands.push(b);
  }
  for (let l = 2; l < order; l++) bands.push(band(l, bands[1], bands[l - 1]));
  bands.forEach((block, l) => {
    const w = 2 * l + 1;
    for (let i = 0; i < w; i++) for (let j = 0; j < w; j++) if ((i + j) % 2 === 1) block[i * w + j] = -block[i * w + j];
  });
  return bands;
}

function checkRotation(m) {
  if (!m || m.length !== 9 || !Array.from(m).every(Number.isFinite)) {
    throw new Error('prt rotateLight: the rotation must be 9 finite numbers (row-major 3×3)');
  }
  const dot = (i, j) => m[i * 3] * m[j * 3] + m[i * 3 + 1] * m[j * 3 + 1] + m[i * 3 + 2] * m[j * 3 + 2];
  for (let i = 0; i < 3; i++) {
    for (let j = 0; j < 3; j++) {
      if (Math.abs(dot(i, j) - (i === j ? 1 : 0)) > 1e-5) throw new Error('prt rotateLight: the matrix is not orthonormal');
    }
  }
  const det = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) + m[2] * (m[3] * m[7] - m[4] * m[6]);
  if (det < 0) throw new Error('prt rotateLight: the matrix is a reflection (determinant −1), not a rotation');
}

// P^i_{a,b} of the paper from band 1 (r1) and band l−1 (prev).
function p(l, r1, prev, i, a, b) {
  const r = (x, y) => r1[(x + 1) * 3 + (y + 1)];
  const pw = 2 * l - 1;
  const q = (x, y) => prev[(x + l - 1) * pw + (y + l - 1)];
  if (b === l) return r(i, 1) * q(a, l - 1) - r(i, -1) * q(a, -l + 1);
  if (b === -l) return r(i, 1) * q(a, -l + 1) + r(i, -1) * q(a, l - 1);
  return r(i, 0) * q(a, b);
}

function band(l, r1, prev) {
  const w = 2 * l + 1;
  const block = new Float64Array(w * w);
  for (let m = -l; m <= l; m++) {
    for (let n = -l; n <= l; n++) {
      const d0 = m === 0 ? 1 : 0;
      const denominator = Math.abs(n) === l ? 2 * l * (2 * l - 1) : (l + n) * (l - n);
      const am = Math.abs(m);
      const u = Math.sqrt(((l + m) * (l - m)) / denominator);
      const v = 0.5 * Math.sqrt(((1 + d0) * (l + am - 1) * (l + am)) / denominator) * (1 - 2 * d0);
      const wc = -0.5 * Math.sqrt(((l - am - 1) * (l - am)) / denominator) * (1 - d0);
      let value = 0;
      if (u !== 0) value += u * p(l, r1, prev, 0, m, n);
      if (v !== 0) {
        let bigV;
        if (m === 0) bigV = p(l, r1, prev, 1, 1, n) + p(l, r1, prev, -1, -1, n);
        else if (m > 0) bigV = p(l, r1, prev, 1, m - 1, n) * (m === 1 ? Math.SQRT2 : 1) - (m === 1 ? 0 : p(l, r1, prev, -1, -m + 1, n));
        else bigV = (m === -1 ? 0 : p(l, r1, prev, 1, m + 1, n)) + p(l, r1, prev, -1, -m - 1, n) * (m === -1 ? Math.SQRT2 : 1);
        value += v * bigV;
      }
      if (wc !== 0) {
        const bigW = m > 0
          ? p(l, r1, prev, 1, m + 1, n) + p(l, r1, prev, -1, -m - 1, n)
          : p(l, r1, prev, 1, m - 1, n) - p(l, r1, prev, -1, -m + 1, n);
        value += wc * bigW;
      }
      block[(m + l) * w + (n + l)] = value;
    }
  }
  return block;
}

/**
 * The light turned by the rotation `m` (row-major 3×3 in the light's frame, which for
 * `applyPRT` is the glTF file's: +Y up): what shone from direction d shines from m·d.
 * Any order. Returns a new light.
 */
export function rotateLight(light, m) {
  const bands = shRotation(light.order, m);
  const rgb = light.rgb.map((c) => {
    const out = new Float64Array(c.length);
    bands.forEach((block, l) => {
      const start = l * l;
      const w = 2 * l + 1;
      for (let i = 0; i < w; i++) {
        let sum = 0;
        for (let j = 0; j < w; j++) sum += block[i * w + j] * c[start + j];
        out[start + i] = sum;
      }
    });
    return out;
  });
  return { order: light.order, rgb };
}

/** Row-major rotation by `angle` radians about the unit `axis` [x, y, z] (right-handed). */
export function axisAngle(axis, angle) {
  const [x, y, z] = axis;
  const c = Math.cos(angle);
  const s = Math.sin(angle);
  const t = 1 - c;
  return [
    t * x * x + c, t * x * y - s * z, t * x * z + s * y,
    t * x * y + s * z, t * y * y + c, t * y * z - s * x,
    t * x * z - s * y, t * y * z + s * x, t * z * z + c,
  ];
}

/** Row-major product a·b of two 3×3 matrices. */
export function multiply3(a, b) {
  const out = new Array(9).fill(0);
  for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) for (let k = 0; k < 3; k++) out[i * 3 + j] += a[i * 3 + k] * b[k * 3 + j];
  return out;
}

/** The turn from the baker's z-up world to glTF's +Y-up frame: (x, y, z) ↦ (x, z, −y). */
export const Z_UP_TO_GLTF = Object.freeze([1, 0, 0, 0, 0, 1, 0, -1, 0]);
/** Its inverse, glTF's frame to the z-up world: (x, y, z) ↦ (x, −z, y). */
export const GLTF_TO_Z_UP = Object.freeze([1, 0, 0, 0, 0, -1, 0, 1, 0]);
