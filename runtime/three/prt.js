// prt.js: relight prt-bake's glTF exports in three.js (docs/reference/gltf.md, "Relighting in three.js").
//
// An ES module with no build step; `three` is imported by its bare name (an import map in the
// page names the file). Per vertex or per texel, grey or RGB transfer, any order:
//
//   import { lightFromJSON, lightFromGLTF, rotateLight, applyPRT, loadLightmapTransfer } from './prt.js';
//   const light = lightFromJSON(await (await fetch('light.json')).json()); // prt-bake light --up y
//   const light = lightFromGLTF(gltf);       // or the rig the .glb was exported with (--lights)
//   const prt = applyPRT(gltf.scene, light);                   // vertex bakes (_PRT_k)
//   const prt = applyPRT(gltf.scene, light, { lightmap: await loadLightmapTransfer('exr/manifest.json') });
//   const prt = applyPRT(gltf, light, { cpca: await loadCompressedTransfer(gltf) }); // compressed
//   prt.setLight(rotateLight(light, m));                       // m: row-major 3×3, glTF frame
//
// Shading is `prt-bake relight`'s: radiance_c = albedo_c · Σ_j T_j·L_c,j with albedo the
// material's base colour (factor × texture), written out like any three.js colour (linear,
// encoded by the renderer's output colour space). The light is in the glTF file's frame
// (+Y up): `prt-bake light RIG --up y` writes exactly that.

import * as THREE from 'three';
import { EXRLoader } from 'three/addons/loaders/EXRLoader.js';
import { GLTF_TO_Z_UP, coeffCount, lightFromJSON, lightOfOrder, rotateLight } from './sh.js';

export { lightFromJSON, rotateLight, shRotation, axisAngle, multiply3, Z_UP_TO_GLTF, GLTF_TO_Z_UP } from './sh.js';
// Transfer probes and rigid objects that move through them (docs/guides/probes.md).
export { parseProbes, loadProbes, probeWeights, probeIncident, probeLightAt, probeLightForObject, lightProbeCoefficients } from './probes.js';

/**
 * The light a `.glb` was exported with (`prt-bake export … --lights RIG`): its
 * `asset.extras.prt.light`, which is `prt-bake light RIG --up y`'s JSON, in the file's frame.
 * `gltf` is GLTFLoader's result. Returns null when the file carries no light.
 */
export function lightFromGLTF(gltf) {
  const light = gltf?.parser?.json?.asset?.extras?.prt?.light;
  return light === undefined ? null : lightFromJSON(light);
}

/** The `_PRT_k` attribute names of a geometry (three.js lower-cases them), per channel. */
function vertexTransfer(geometry) {
  const names = Object.keys(geometry.attributes);
  const grey = [];
  const rgb = [[], [], []];
  for (const name of names) {
    let match = /^_prt_(\d+)$/.exec(name);
    if (match) grey[Number(match[1])] = name;
    match = /^_prt_([rgb])(\d+)$/.exec(name);
    if (match) rgb['rgb'.indexOf(match[1])][Number(match[2])] = name;
  }
  const dense = (list) => list.length > 0 && list.every(Boolean) && list.length === Object.keys(list).length;
  if (dense(grey)) return { channels: [grey, grey, grey], groups: grey.length };
  if (rgb.every(dense) && rgb[0].length === rgb[1].length && rgb[1].length === rgb[2].length) {
    return { channels: rgb, groups: rgb[0].length };
  }
  return null;
}

/**
 * A texel bake's transfer from `prt-bake export LM.prt --scene S --exr DIR`: reads
 * DIR/manifest.json and its `transfer_*.exr` images (three's EXRLoader, half float, linear
 * filtering, clamp to edge). Resolves to { order, channels, up, textures: [[tex…] × 3] }.
 */
export async function loadLightmapTransfer(manifestUrl) {
  const url = new URL(manifestUrl, document.baseURI);
  const response = await fetch(url);
  if (!response.ok) throw new Error(`prt: ${url}: HTTP ${response.status}`);
  const manifest = await response.json();
  const { order, channels } = manifest;
  if (!Number.isInteger(order) || ![1, 3].includes(channels) || !Array.isArray(manifest.transfer)) {
    throw new Error(`prt: ${url}: not a prt-bake lightmap manifest (order, channels, transfer)`);
  }
  const loader = new EXRLoader();
  loader.setDataType(THREE.HalfFloatType);
  const groups = Math.ceil(coeffCount(order) / 4);
  const textures = [[], [], []];
  await Promise.all(manifest.transfer.map(async (entry, i) => {
    const texture = await loader.loadAsync(new URL(entry.file, url).href);
    texture.magFilter = THREE.LinearFilter;
    texture.minFilter = THREE.LinearFilter;
    texture.generateMipmaps = false;
    texture.wrapS = THREE.ClampToEdgeWrapping;
    texture.wrapT = THREE.ClampToEdgeWrapping;
    texture.colorSpace = THREE.NoColorSpace;
    const channel = channels === 1 ? 0 : Math.floor(i / groups);
    textures[channel][i % groups] = texture;
  }));
  if (channels === 1) {
    textures[1] = textures[0];
    textures[2] = textures[0];
  }
  return { order, channels, up: manifest.up, groups, textures, manifest };
}

/**
 * A CPCA-compressed bake's clusters (the export of a `prt-bake compress` file): the means and
 * principal components that `asset.extras.prt.cpca` names, read from the file's buffer.
 * `gltf` is GLTFLoader's result. Resolves to { clusters, pcs, dim, order, channels, means,
 * bases } (Float32Arrays, layout as docs/reference/gltf.md says), or null when the file has none.
 */
export async function loadCompressedTransfer(gltf) {
  const cpca = gltf?.parser?.json?.asset?.extras?.prt?.cpca;
  if (!cpca) return null;
  const { clusters, pcs, dim, order, channels } = cpca;
  // A transfer-matrix (glossy) bake's vectors are n² × n² matrices: applyGlossyPRT.
  const matrix = cpca.transfer === 'matrix';
  const perChannel = matrix ? coeffCount(order) ** 2 : coeffCount(order);
  if (![clusters, pcs, dim, order].every(Number.isInteger) || ![1, 3].includes(channels) || dim !== channels * perChannel) {
    throw new Error('prt: asset.extras.prt.cpca: clusters, pcs, dim, order and channels do not fit together');
  }
  const [means, bases] = await Promise.all([cpca.means, cpca.bases].map((i) => gltf.parser.getDependency('accessor', i)));
  if (means.array.length !== clusters * dim || bases.array.length !== clusters * pcs * dim) {
    throw new Error(`prt: asset.extras.prt.cpca: ${means.array.length} mean and ${bases.array.length} component floats, expected ${clusters * dim} and ${clusters * pcs * dim}`);
  }
  const glossy = matrix ? { transfer: 'matrix', diffuseBands: cpca.diffuse_bands } : {};
  return { clusters, pcs, dim, order, channels, means: means.array, bases: bases.array, ...glossy };
}

// Texels of the per-cluster light texture per row.
const CLUSTER_ROW = 1024;

// The light dotted into every cluster's mean and components, per channel: texel
// k·(M + 1) + r holds, in RGB, cluster k's mean (r = 0) or component r − 1 dotted with the
// light. Written into `texture` (a DataTexture) or a new one.
function clusterLight(cpca, light, texture = null) {
  const { clusters, pcs, dim, order, channels, means, bases } = cpca;
  const n = coeffCount(order);
  const fitted = lightOfOrder(light, order);
  const count = clusters * (pcs + 1);
  const width = Math.min(count, CLUSTER_ROW);
  const height = Math.ceil(count / width);
  const data = texture ? texture.image.data : new Float32Array(4 * width * height);
  for (let k = 0; k < clusters; k++) {
    for (let r = 0; r <= pcs; r++) {
      const vector = r === 0 ? means.subarray(k * dim, (k + 1) * dim) : bases.subarray(((k * pcs) + r - 1) * dim, ((k * pcs) + r) * dim);
      const texel = 4 * (k * (pcs + 1) + r);
      for (let c = 0; c < 3; c++) {
        const offset = channels === 1 ? 0 : c * n;
        let sum = 0;
        for (let j = 0; j < n; j++) sum += vector[offset + j] * fitted.rgb[c][j];
        data[texel + c] = sum;
      }
      data[texel + 3] = 1;
    }
  }
  if (texture) {
    texture.needsUpdate = true;
    return texture;
  }
  const made = new THREE.DataTexture(data, width, height, THREE.RGBAFormat, THREE.FloatType);
  made.magFilter = THREE.NearestFilter;
  made.minFilter = THREE.NearestFilter;
  made.generateMipmaps = false;
  made.needsUpdate = true;
  return made;
}

function compressedShaderPatch(cpca, weights) {
  const width = Math.min(cpca.clusters * (cpca.pcs + 1), CLUSTER_ROW);
  const lines = [];
  for (let i = 0; i < cpca.pcs; i++) {
    lines.push(`vPrtShading += ${weights[Math.floor(i / 4)]}.${'xyzw'[i % 4]} * prtCluster(prtBase + ${i + 1});`);
  }
  return {
    declarations: `attribute float _prt_cluster;\n${weights.map((w) => `attribute vec4 ${w};`).join('\n')}
uniform highp sampler2D prtClusterLight;
varying vec3 vPrtShading;
vec3 prtCluster(int i) { return texelFetch(prtClusterLight, ivec2(i % ${width}, i / ${width}), 0).rgb; }
`,
    body: `int prtBase = int(_prt_cluster + 0.5) * ${cpca.pcs + 1};\nvPrtShading = prtCluster(prtBase);\n${lines.join('\n')}\n`,
  };
}

// The uniform layout: per colour channel c and group k, vec4 prtLight[c * groups + k], times
// the attribute's scale where the transfer is quantized (export --quantize: the attribute
// arrives normalized to [−1, 1]; dot(a·s, L) = dot(a, s·L)).
function lightUniform(light, order, groups, scales = null) {
  const fitted = lightOfOrder(light, order);
  const values = [];
  for (let c = 0; c < 3; c++) {
    for (let k = 0; k < groups; k++) {
      const s = scales ? scales[c * groups + k] : 1;
      const v = [0, 1, 2, 3].map((i) => (fitted.rgb[c][4 * k + i] ?? 0) * s);
      values.push(new THREE.Vector4(...v));
    }
  }
  return values;
}

// Per (channel, group) the scale of a quantized transfer's attribute, or null for float.
function attributeScales(transfer, quantization) {
  if (!quantization?.scales) return null;
  const byName = new Map(Object.entries(quantization.scales).map(([name, s]) => [name.toLowerCase(), s]));
  return transfer.channels.flatMap((names) => names.map((name) => {
    const s = byName.get(name);
    if (!Number.isFinite(s)) throw new Error(`prt: quantized transfer without a scale for ${name}`);
    return s;
  }));
}

function vertexShaderPatch(transfer) {
  const { channels, groups } = transfer;
  const declared = [...new Set(channels.flat())];
  const sum = (c) => channels[c].map((name, k) => `dot(${name}, prtLight[${c * groups + k}])`).join(' + ');
  return {
    declarations: declared.map((name) => `attribute vec4 ${name};`).join('\n')
      + `\nuniform vec4 prtLight[${3 * groups}];\nvarying vec3 vPrtShading;\n`,
    body: `vPrtShading = vec3(${sum(0)}, ${sum(1)}, ${sum(2)});\n`,
  };
}

function texelShaderPatch(groups) {
  const lines = [];
  const fetches = [];
  for (let c = 0; c < 3; c++) {
    const terms = [];
    for (let k = 0; k < groups; k++) {
      lines.push(`uniform sampler2D prtT${c}_${k};`);
      terms.push(`dot(texture2D(prtT${c}_${k}, prtUv), prtLight[${c * groups + k}])`);
    }
    fetches.push(terms.join(' + '));
  }
  return {
    declarations: `${lines.join('\n')}\nuniform vec4 prtLight[${3 * groups}];\nvarying vec2 vPrtUv;\n`,
    // The EXR's top row is v = 0 of TEXCOORD_1, and EXRLoader puts it at t = 1.
    body: `vec2 prtUv = vec2(vPrtUv.x, 1.0 - vPrtUv.y);\nvec3 prtShading = vec3(${fetches.join(', ')});\n`,
  };
}

// The relighting material's base: a MeshBasicMaterial that keeps what the loaded material
// draws besides its lighting: the base colour factor and texture on TEXCOORD_0 (with the
// texture transform GLTFLoader put on it), the alpha (alphaTest for MASK, transparent and
// depthWrite for BLEND, alphaHash, opacity, alphaMap) and the side. A node that is one sheet
// of a doubleSided surface (extras.prt_sheet: the bake's back sheet, or its front) shows the
// transfer of the side its normals face, so it is drawn front faces only; its twin draws the
// other side (docs/reference/gltf.md, "Materials").
export function albedoMaterial(source, object) {
  const sheet = Boolean(object?.userData?.prt_sheet);
  const material = new THREE.MeshBasicMaterial({
    color: source.color ? source.color.clone() : new THREE.Color(1, 1, 1),
    side: sheet ? THREE.FrontSide : source.side,
    transparent: source.transparent,
    opacity: source.opacity ?? 1,
    alphaTest: source.alphaTest ?? 0,
    alphaHash: source.alphaHash ?? false,
    depthWrite: source.depthWrite ?? true,
  });
  // The base colour texture is on TEXCOORD_0. (Files exported before the lightmap moved to
  // extras.prt_lightmap had the relit lightmap there on TEXCOORD_1, which is not albedo.)
  if (source.map && source.map.channel === 0) material.map = source.map;
  if (source.alphaMap) material.alphaMap = source.alphaMap;
  material.name = `${source.name || 'material'} (PRT)`;
  return material;
}

/**
 * Gives every mesh under `root` (an Object3D, or GLTFLoader's result, whose
 * asset.extras.prt.quantization then gives a quantized transfer's scales) that carries PRT data a relighting material (a
 * MeshBasicMaterial whose colour is multiplied by Σ_j T_j·L_j per channel) and returns a
 * handle: setLight(light), setExposure(ev), restore() (the as-exported materials back), and
 * meshes. Per-vertex meshes are found by their `_PRT_k` attributes; texel meshes (those with
 * TEXCOORD_1) need `options.lightmap` from `loadLightmapTransfer`. Options:
 *   lightmap       a texel bake's transfer (loadLightmapTransfer)
 *   order          the transfer's order (default: the light's; the file's asset.extras.prt
 *                  says it); the light is cut or zero-padded to it
 *   clampShading   clamp Σ T·L to [0, 1] before the albedo, as COLOR_0 and the embedded
 *                  lightmap of an export are (default false: prt-bake relight's radiance)
 *   exposure       EV, radiance × 2^exposure (default 0)
 *   quantization   asset.extras.prt.quantization of a file exported with --quantize, when
 *                  `root` is not the GLTFLoader result
 *   cpca           a compressed bake's clusters (loadCompressedTransfer): meshes with
 *                  _PRT_CLUSTER and _PRT_Wk attributes are relit from them
 */
export function applyPRT(rootOrGltf, light, options = {}) {
  if (options.cpca?.transfer === 'matrix') return applyGlossyPRT(rootOrGltf, light, options);
  // A GLTFLoader result brings its asset.extras.prt (the quantization scales) along.
  const isGltf = Boolean(rootOrGltf?.scene && rootOrGltf?.asset);
  const root = isGltf ? rootOrGltf.scene : rootOrGltf;
  const quantization = options.quantization ?? (isGltf ? rootOrGltf.asset.extras?.prt?.quantization : null);
  const entries = [];
  const order = options.order ?? light.order;
  const lightmap = options.lightmap ?? null;
  const cpca = options.cpca ?? null;
  // One per-cluster light texture, shared by every compressed mesh.
  const clusterTexture = cpca ? { value: clusterLight(cpca, light) } : null;
  const clamp = options.clampShading ? 'clamp(prtShading, 0.0, 1.0)' : 'prtShading';
  const common = {
    prtExposure: { value: 2 ** (options.exposure ?? 0) },
  };
  root.traverse((object) => {
    if (!object.isMesh) return;
    const geometry = object.geometry;
    if (geometry.attributes._prt_cluster) {
      if (!cpca) throw new Error(`prt: mesh '${object.name}': compressed transfer (_PRT_CLUSTER): pass options.cpca = await loadCompressedTransfer(gltf)`);
      const weights = Array.from({ length: Math.ceil(cpca.pcs / 4) }, (_, k) => `_prt_w${k}`);
      const missing = weights.find((w) => !geometry.attributes[w]);
      if (missing) throw new Error(`prt: mesh '${object.name}': compressed transfer without its ${missing} attribute`);
      const uniforms = { prtClusterLight: clusterTexture, ...common };
      const patch = compressedShaderPatch(cpca, weights);
      const made = relitMaterials(object, uniforms, patch, true, `c:${cpca.clusters}:${cpca.pcs}:${clamp}`, clamp);
      entries.push({ object, ...made, uniforms, compressed: true });
      return;
    }
    const transfer = vertexTransfer(geometry);
    const texel = !transfer && lightmap && geometry.attributes.uv1;
    if (!transfer && !texel) return;
    const groups = transfer ? transfer.groups : lightmap.groups;
    const transferOrder = lightmap && texel ? lightmap.order : order;
    if (Math.ceil(coeffCount(transferOrder) / 4) !== groups) {
      throw new Error(`prt: mesh '${object.name}': ${groups} VEC4 groups of transfer, but order ${transferOrder} needs ${Math.ceil(coeffCount(transferOrder) / 4)} (pass options.order)`);
    }
    const scales = transfer ? attributeScales(transfer, quantization) : null;
    if (transfer && !scales && geometry.attributes[transfer.channels[0][0]].normalized) {
      throw new Error(`prt: mesh '${object.name}': quantized transfer, but no scales: pass the GLTFLoader result, or options.quantization`);
    }
    const uniforms = { prtLight: { value: lightUniform(light, transferOrder, groups, scales) }, ...common };
    if (texel) {
      for (let c = 0; c < 3; c++) for (let k = 0; k < groups; k++) uniforms[`prtT${c}_${k}`] = { value: lightmap.textures[c][k] };
    }
    const patch = transfer ? vertexShaderPatch(transfer) : texelShaderPatch(groups);
    const key = `${transfer ? 'v' : 't'}:${groups}:${transfer ? transfer.channels.flat().join(',') : ''}:${clamp}`;
    const made = relitMaterials(object, uniforms, patch, Boolean(transfer), key, clamp);
    entries.push({ object, ...made, uniforms, groups, scales, order: transferOrder, texel: Boolean(texel) });
  });
  const handle = {
    meshes: entries.map((e) => e.object),
    setLight(next) {
      if (clusterTexture) clusterLight(cpca, next, clusterTexture.value);
      for (const e of entries) {
        if (e.compressed) continue;
        // The texel transfer is in the bake's own frame (manifest.up): a z-up bake gets the
        // glTF-frame light turned back to z-up.
        const framed = e.texel && lightmap.up === 'z' ? rotateLight(next, GLTF_TO_Z_UP) : next;
        e.uniforms.prtLight.value = lightUniform(framed, e.order, e.groups, e.scales);
      }
    },
    setExposure(ev) {
      common.prtExposure.value = 2 ** ev;
    },
    /** The as-exported materials back (and again the PRT ones with `enable`). */
    restore() {
      for (const e of entries) e.object.material = e.original;
    },
    enable() {
      for (const e of entries) e.object.material = Array.isArray(e.original) ? e.made : e.made[0];
    },
    dispose() {
      handle.restore();
      for (const e of entries) e.made.forEach((m) => m.dispose());
      clusterTexture?.value.dispose();
    },
  };
  handle.setLight(light);
  return handle;
}

// The relighting materials of `object`, one per material it has: the shading computed per
// vertex (`perVertex`: the patch goes into the vertex shader, vPrtShading to the fragment) or
// per texel (the patch goes into the fragment shader). Puts them on the object.
function relitMaterials(object, uniforms, patch, perVertex, key, clamp) {
  const original = object.material;
  const sources = Array.isArray(original) ? original : [original];
  const made = sources.map((source) => {
    const material = albedoMaterial(source, object);
    material.onBeforeCompile = (shader) => {
      Object.assign(shader.uniforms, uniforms);
      if (perVertex) {
        shader.vertexShader = shader.vertexShader
          .replace('#include <common>', `#include <common>\n${patch.declarations}`)
          .replace('#include <begin_vertex>', `#include <begin_vertex>\n${patch.body}`);
        shader.fragmentShader = shader.fragmentShader
          .replace('#include <common>', '#include <common>\nvarying vec3 vPrtShading;\nuniform float prtExposure;')
          .replace('#include <color_fragment>', `#include <color_fragment>\nvec3 prtShading = vPrtShading;\ndiffuseColor.rgb *= ${clamp} * prtExposure;`);
      } else {
        shader.vertexShader = shader.vertexShader
          .replace('#include <common>', '#include <common>\n#ifndef USE_UV1\nattribute vec2 uv1;\n#endif\nvarying vec2 vPrtUv;')
          .replace('#include <begin_vertex>', '#include <begin_vertex>\nvPrtUv = uv1;');
        shader.fragmentShader = shader.fragmentShader
          .replace('#include <common>', `#include <common>\n${patch.declarations}\nuniform float prtExposure;`)
          .replace('#include <color_fragment>', `#include <color_fragment>\n${patch.body}diffuseColor.rgb *= ${clamp} * prtExposure;`);
      }
    };
    material.customProgramCacheKey = () => `prt:${key}`;
    return material;
  });
  object.material = Array.isArray(original) ? made : made[0];
  return { original, made };
}

// ---------------------------------------------------------------------------------------------
// Glossy PRT: a CPCA-compressed transfer-matrix bake (docs/reference/gltf.md, "Glossy transfer";
// docs/guides/glossy.md for the formula). Per vertex and channel c, with L′ = M·L_c its shadowed
// incident radiance (n² coefficients),
//
//   radiance_c = albedo_c · w · Σ_lm ĝ_l(1) L′_lm y_lm(n)  +  ks_c · Σ_lm ĝ_l(s) L′_lm y_lm(r)
//
// r the mirror direction of the unit vector towards the camera about the normal: `prt-bake
// relight --view`'s formula, evaluated per vertex in the vertex shader (so the highlight
// moves as the camera does) and interpolated. L′ comes from the clusters: per frame the light
// is projected through each cluster's mean and components (K·(M + 1) matrix-vector products
// per channel, on the CPU), and each vertex adds M + 1 of those n²-vectors with its weights.

// The light projected through every cluster's mean and components: n² values per (cluster k,
// row r, channel c), packed 4 to a texel from texel ((k·(M + 1) + r)·3 + c)·⌈n²/4⌉.
function glossyClusterLight(cpca, light, texture = null) {
  const { clusters, pcs, dim, order, channels, means, bases } = cpca;
  const n = coeffCount(order);
  const groups = Math.ceil(n / 4);
  const fitted = lightOfOrder(light, order);
  const count = clusters * (pcs + 1) * 3 * groups;
  const width = Math.min(count, CLUSTER_ROW);
  const height = Math.ceil(count / width);
  const data = texture ? texture.image.data : new Float32Array(4 * width * height);
  for (let k = 0; k < clusters; k++) {
    for (let r = 0; r <= pcs; r++) {
      const at = r === 0 ? k * dim : ((k * pcs) + r - 1) * dim;
      for (let c = 0; c < 3; c++) {
        const matrix = at + (channels === 1 ? 0 : c * n * n);
        const source = r === 0 ? means : bases;
        const l = fitted.rgb[c];
        const texel = 4 * (((k * (pcs + 1) + r) * 3 + c) * groups);
        for (let i = 0; i < 4 * groups; i++) {
          let sum = 0;
          if (i < n) for (let j = 0; j < n; j++) sum += source[matrix + i * n + j] * l[j];
          data[texel + i] = sum;
        }
      }
    }
  }
  if (texture) {
    texture.needsUpdate = true;
    return texture;
  }
  const made = new THREE.DataTexture(data, width, height, THREE.RGBAFormat, THREE.FloatType);
  made.magFilter = THREE.NearestFilter;
  made.minFilter = THREE.NearestFilter;
  made.generateMipmaps = false;
  made.needsUpdate = true;
  return made;
}

// A GLSL literal of a JS number.
const glslFloat = (x) => {
  const text = Number(x).toPrecision(17);
  return /[.e]/.test(text) ? text : `${text}.0`;
};

// GLSL of `void prtBasis(vec3 d, out vec4 y[G])`: the real SH y_i(d), i < n², packed 4 to a
// vec4 (unused lanes 0), by the baker's recurrence (baker/src/math/sh/basis.rs: Q_l^m with
// the Condon–Shortley phase, times Re/Im (x + iy)^m), unrolled with its constants.
export function shBasisGlsl(order) {
  const n = coeffCount(order);
  const groups = Math.ceil(n / 4);
  const factorial = (k) => (k <= 1 ? 1 : k * factorial(k - 1));
  const scale = (l, m) => Math.sqrt(((2 * l + 1) / (4 * Math.PI)) * (factorial(l - m) / factorial(l + m))) * (m === 0 ? 1 : Math.SQRT2);
  const lines = [`void prtBasis(vec3 d, out vec4 y[${groups}]) {`, `  float v[${4 * groups}];`];
  lines.push(`  for (int i = ${n}; i < ${4 * groups}; i++) v[i] = 0.0;`);
  lines.push('  float c = 1.0, s = 0.0, t, q, q1, q2;');
  let qmm = 1;
  for (let m = 0; m < order; m++) {
    if (m > 0) {
      lines.push('  t = c * d.x - s * d.y; s = c * d.y + s * d.x; c = t;');
      qmm *= -(2 * m - 1);
    }
    lines.push(`  q2 = 0.0; q1 = ${glslFloat(qmm)};`);
    for (let l = m; l < order; l++) {
      if (l === m) lines.push(`  q = ${glslFloat(qmm)};`);
      else if (l === m + 1) lines.push(`  q = d.z * ${glslFloat((2 * m + 1) * qmm)};`);
      else lines.push(`  q = (d.z * ${glslFloat(2 * l - 1)} * q1 - ${glslFloat(l + m - 1)} * q2) / ${glslFloat(l - m)};`);
      if (l > m) lines.push('  q2 = q1; q1 = q;');
      const k = glslFloat(scale(l, m));
      if (m === 0) lines.push(`  v[${l * (l + 1)}] = ${k} * q;`);
      else lines.push(`  v[${l * (l + 1) + m}] = ${k} * q * c; v[${l * (l + 1) - m}] = ${k} * q * s;`);
    }
  }
  lines.push(`  for (int g = 0; g < ${groups}; g++) y[g] = vec4(v[4 * g], v[4 * g + 1], v[4 * g + 2], v[4 * g + 3]);`, '}');
  return lines.join('\n');
}

// Per coefficient i < n², the factor of its band l (⌊√i⌋), as vec4s padded with 0.
function bandUniform(bands, order) {
  const n = coeffCount(order);
  const groups = Math.ceil(n / 4);
  return Array.from({ length: groups }, (_, g) => new THREE.Vector4(...[0, 1, 2, 3].map((j) => {
    const i = 4 * g + j;
    return i < n ? bands[Math.floor(Math.sqrt(i + 0.5))] : 0;
  })));
}

function glossyShaderPatch(cpca, weights) {
  const groups = Math.ceil(coeffCount(cpca.order) / 4);
  const perRow = 3 * groups;
  const width = Math.min(cpca.clusters * (cpca.pcs + 1) * perRow, CLUSTER_ROW);
  const adds = [];
  for (let i = 0; i < cpca.pcs; i++) {
    adds.push(`for (int i = 0; i < ${perRow}; i++) prtL[i] += ${weights[Math.floor(i / 4)]}.${'xyzw'[i % 4]} * prtFetch(prtBase + ${(i + 1) * perRow} + i);`);
  }
  return {
    declarations: `attribute float _prt_cluster;\n${weights.map((w) => `attribute vec4 ${w};`).join('\n')}
uniform highp sampler2D prtClusterLight;
uniform vec4 prtDiffuseBands[${groups}];
uniform vec4 prtGlossyBands[${groups}];
uniform vec3 prtKs;
uniform float prtDiffuseWeight;
varying vec3 vPrtDiffuse;
varying vec3 vPrtGlossy;
vec4 prtFetch(int i) { return texelFetch(prtClusterLight, ivec2(i % ${width}, i / ${width}), 0); }
${shBasisGlsl(cpca.order)}
`,
    body: `vec4 prtL[${perRow}];
int prtBase = int(_prt_cluster + 0.5) * ${(cpca.pcs + 1) * perRow};
for (int i = 0; i < ${perRow}; i++) prtL[i] = prtFetch(prtBase + i);
${adds.join('\n')}
vec3 prtN = normalize(normal);
vec3 prtToEye = normalize(cameraPosition - (modelMatrix * vec4(transformed, 1.0)).xyz);
vec3 prtR = normalize(2.0 * dot(prtN, prtToEye) * prtN - prtToEye);
vec4 prtYn[${groups}];
vec4 prtYr[${groups}];
prtBasis(prtN, prtYn);
prtBasis(prtR, prtYr);
for (int c = 0; c < 3; c++) {
  float diffuse = 0.0;
  float glossy = 0.0;
  for (int g = 0; g < ${groups}; g++) {
    diffuse += dot(prtL[c * ${groups} + g], prtYn[g] * prtDiffuseBands[g]);
    glossy += dot(prtL[c * ${groups} + g], prtYr[g] * prtGlossyBands[g]);
  }
  vPrtDiffuse[c] = prtDiffuseWeight * diffuse;
  vPrtGlossy[c] = prtKs[c] * glossy;
}
`,
  };
}

/**
 * Glossy PRT for a CPCA-compressed transfer-matrix bake (its export; `applyPRT` hands such a
 * file here): `options.cpca` from `loadCompressedTransfer(gltf)` is required. Every mesh with
 * `_PRT_CLUSTER` gets a MeshBasicMaterial (base colour and texture copied) whose colour is
 * albedo · w · diffuse + ks · glossy, per vertex from the camera's position (three's
 * `cameraPosition`, each frame), with w, ks and the lobe's band factors from the source
 * material's `extras.prt_glossy` (a material without it is diffuse: w = 1, ks = 0). The
 * geometry and the transfer are in the file's frame: move the model, do not turn it (turn
 * the light instead). Options: `exposure` (EV). Returns the handle `applyPRT` returns.
 */
export function applyGlossyPRT(rootOrGltf, light, options = {}) {
  const isGltf = Boolean(rootOrGltf?.scene && rootOrGltf?.asset);
  const root = isGltf ? rootOrGltf.scene : rootOrGltf;
  const cpca = options.cpca;
  if (cpca?.transfer !== 'matrix') throw new Error('prt: applyGlossyPRT needs options.cpca = await loadCompressedTransfer(gltf) of a transfer-matrix export');
  if (!Array.isArray(cpca.diffuseBands) || cpca.diffuseBands.length !== cpca.order) throw new Error('prt: asset.extras.prt.cpca.diffuse_bands: not one factor per band');
  const clusterTexture = { value: glossyClusterLight(cpca, light) };
  const shared = {
    prtClusterLight: clusterTexture,
    prtDiffuseBands: { value: bandUniform(cpca.diffuseBands, cpca.order) },
    prtExposure: { value: 2 ** (options.exposure ?? 0) },
  };
  const weights = Array.from({ length: Math.ceil(cpca.pcs / 4) }, (_, k) => `_prt_w${k}`);
  const patch = glossyShaderPatch(cpca, weights);
  const entries = [];
  root.traverse((object) => {
    if (!object.isMesh || !object.geometry.attributes._prt_cluster) return;
    const missing = weights.find((w) => !object.geometry.attributes[w]);
    if (missing) throw new Error(`prt: mesh '${object.name}': compressed transfer without its ${missing} attribute`);
    const original = object.material;
    const sources = Array.isArray(original) ? original : [original];
    const made = sources.map((source) => {
      const lobe = source.userData?.prt_glossy;
      if (lobe && (!Array.isArray(lobe.bands) || lobe.bands.length !== cpca.order || lobe.ks?.length !== 3)) {
        throw new Error(`prt: material '${source.name}': extras.prt_glossy needs ks (3 numbers) and ${cpca.order} bands`);
      }
      const uniforms = {
        ...shared,
        prtGlossyBands: { value: bandUniform(lobe ? lobe.bands : new Array(cpca.order).fill(0), cpca.order) },
        prtKs: { value: new THREE.Vector3(...(lobe ? lobe.ks : [0, 0, 0])) },
        prtDiffuseWeight: { value: lobe ? lobe.diffuse_weight : 1 },
      };
      const material = albedoMaterial(source, object);
      material.onBeforeCompile = (shader) => {
        Object.assign(shader.uniforms, uniforms);
        shader.vertexShader = shader.vertexShader
          .replace('#include <common>', `#include <common>\n${patch.declarations}`)
          .replace('#include <begin_vertex>', `#include <begin_vertex>\n${patch.body}`);
        shader.fragmentShader = shader.fragmentShader
          .replace('#include <common>', '#include <common>\nvarying vec3 vPrtDiffuse;\nvarying vec3 vPrtGlossy;\nuniform float prtExposure;')
          .replace('#include <color_fragment>', '#include <color_fragment>\ndiffuseColor.rgb = (diffuseColor.rgb * vPrtDiffuse + vPrtGlossy) * prtExposure;');
      };
      material.customProgramCacheKey = () => `prt-glossy:${cpca.clusters}:${cpca.pcs}:${cpca.order}`;
      return material;
    });
    object.material = Array.isArray(original) ? made : made[0];
    entries.push({ object, original, made });
  });
  const handle = {
    meshes: entries.map((e) => e.object),
    setLight(next) {
      glossyClusterLight(cpca, next, clusterTexture.value);
    },
    setExposure(ev) {
      shared.prtExposure.value = 2 ** ev;
    },
    restore() {
      for (const e of entries) e.object.material = e.original;
    },
    enable() {
      for (const e of entries) e.object.material = Array.isArray(e.original) ? e.made : e.made[0];
    },
    dispose() {
      handle.restore();
      for (const e of entries) e.made.forEach((m) => m.dispose());
      clusterTexture.value.dispose();
    },
  };
  return handle;
}
