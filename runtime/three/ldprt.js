// ldprt.js: LDPRT lobes on a skinned mesh in three.js (docs/guides/characters.md, "In three.js";
// the attributes and the shading rule: docs/reference/gltf.md, "LDPRT lobes on a skinned mesh").
//
//   import { applyLDPRT } from './ldprt.js';
//   const gltf = await new GLTFLoader().loadAsync('skinned-ldprt.glb'); // prt-bake export FILE.ldprt --scene SKINNED.glb --glb
//   const ldprt = applyLDPRT(gltf, lightFromJSON(json));             // prt-bake light RIG --up y
//   ldprt.setLight(rotateLight(light, m));                           // any frame, like prt.js
//
// Per vertex, in the vertex shader: the frame (_LDPRT_NORMAL, _LDPRT_TANGENT) skinned by
// three's own skinMatrix (skinbase/skinnormal chunks: the matrix three skins NORMAL with) and
// the node's model matrix into the world (glTF's frame, the light's), the tangent made
// orthogonal to the normal, each lobe's axis turned with that frame, and
//   radiance_c = albedo_c · Σ_k Σ_l c_l g_kl Σ_m L_c,lm y_lm(axis_k),  c_l = sqrt(4π/(2l+1)),
// `prt-bake relight SKINNED.glb FILE.ldprt --pose P`'s radiance at the pose three.js shows.
//
// The lobes are copied at load into a float texture read per vertex (lobeTexture), so the
// shader binds only POSITION, JOINTS_0 and WEIGHTS_0, for any number of lobes and channels.

import * as THREE from 'three';
import { lightOfOrder } from './sh.js';
import { albedoMaterial, shBasisGlsl } from './prt.js';

// The zonal coefficients are g_0..g_3: order 4 at most (extras.prt_ldprt.order).
const ORDER = 4;

// The lobes of a geometry: K, and per lobe the zonal attribute names per channel (RGB or grey).
function lobesOf(geometry) {
  const a = geometry.attributes;
  if (!a._ldprt_normal || !a._ldprt_tangent) return null;
  const lobes = [];
  for (let k = 0; a[`_ldprt_axis_${k}`]; k++) {
    const grey = `_ldprt_zh_${k}`;
    const rgb = ['r', 'g', 'b'].map((c) => `_ldprt_zh_${c}_${k}`);
    if (a[grey]) lobes.push([grey, grey, grey]);
    else if (rgb.every((n) => a[n])) lobes.push(rgb);
    else throw new Error(`ldprt: lobe ${k} has an axis but no _LDPRT_ZH_${k} (or _R/_G/_B) attribute`);
  }
  if (lobes.length === 0) throw new Error('ldprt: _LDPRT_NORMAL without any _LDPRT_AXIS_k');
  const names = ['_ldprt_normal', '_ldprt_tangent', ...lobes.map((_, k) => `_ldprt_axis_${k}`)];
  for (const n of names) if (a[n].itemSize !== 3 || a[n].normalized) throw new Error(`ldprt: ${n} is not a float VEC3`);
  for (const n of new Set(lobes.flat())) if (a[n].itemSize !== 4 || a[n].normalized) throw new Error(`ldprt: ${n} is not a float VEC4`);
  return { lobes, grey: lobes[0][0] === lobes[0][1] };
}

// Texels per row of the lobe texture (WebGL 2 guarantees 2048 on a side).
const ROW = 1024;

// Everything per vertex in one float RGBA texture, P texels per vertex at v·P + j: the normal,
// the tangent and the K axes (6 + 3K floats, zero padded to whole texels), then each lobe's
// zonal coefficients per channel (K or 3K texels). Read by gl_VertexID (the index value, so
// the vertex's own), which leaves the attributes to POSITION, JOINTS_0 and WEIGHTS_0 however
// many lobes and channels there are (9 VEC4 attributes of an RGB bake of 3 lobes would leave
// too few of WebGL's 16 for Chromium on SwiftShader).
function lobeTexture(geometry, lobes) {
  const a = geometry.attributes;
  const frame = ['_ldprt_normal', '_ldprt_tangent', ...lobes.map((_, k) => `_ldprt_axis_${k}`)];
  const frameTexels = Math.ceil((3 * frame.length) / 4);
  const zh = lobes.flatMap((names) => (names[0] === names[1] ? [names[0]] : names));
  const perVertex = frameTexels + zh.length;
  const count = a._ldprt_normal.count;
  const width = Math.min(ROW, count * perVertex);
  const height = Math.ceil((count * perVertex) / width);
  const data = new Float32Array(4 * width * height);
  for (let v = 0; v < count; v++) {
    const base = 4 * v * perVertex;
    frame.forEach((name, s) => { for (let i = 0; i < 3; i++) data[base + 3 * s + i] = a[name].getComponent(v, i); });
    zh.forEach((name, j) => { for (let i = 0; i < 4; i++) data[base + 4 * (frameTexels + j) + i] = a[name].getComponent(v, i); });
  }
  const texture = new THREE.DataTexture(data, width, height, THREE.RGBAFormat, THREE.FloatType);
  texture.magFilter = THREE.NearestFilter;
  texture.minFilter = THREE.NearestFilter;
  texture.generateMipmaps = false;
  texture.needsUpdate = true;
  // GLSL of float f of the vertex's frame, and of its j-th zonal texel.
  const float = (f) => `ldprtTexel(${Math.floor(f / 4)}).${'xyzw'[f % 4]}`;
  const vec3At = (f) => `vec3(${float(f)}, ${float(f + 1)}, ${float(f + 2)})`;
  return {
    texture,
    perVertex,
    normal: vec3At(0),
    tangent: vec3At(3),
    axis: (k) => vec3At(6 + 3 * k),
    zh: (k) => lobes[k].map((name) => `ldprtTexel(${frameTexels + zh.indexOf(name)})`),
  };
}

// The vertex shader's declarations and body (after begin_vertex, where three's skinnormal
// chunk has made skinMatrix for a SkinnedMesh).
function shaderPatch(lobes, frame) {
  const n = ORDER * ORDER;
  const c = [0, 1, 2, 3].map((l) => Math.sqrt((4 * Math.PI) / (2 * l + 1)).toPrecision(17));
  const declarations = [
    'uniform highp sampler2D ldprtLobes;',
    `vec4 ldprtTexel(int j) { int i = gl_VertexID * ${frame.perVertex} + j; return texelFetch(ldprtLobes, ivec2(i % ${ROW}, i / ${ROW}), 0); }`,
    `uniform vec4 prtLight[${3 * (n / 4)}];`,
    'varying vec3 vPrtShading;',
    shBasisGlsl(ORDER),
    // Per coefficient i (band l = ⌊√i⌋, packed 4 to a vec4) the factor c_l g_l.
    `float ldprtBand(vec4 y[4], vec4 g, int c) {
  vec4 w0 = vec4(${c[0]} * g.x, vec3(${c[1]} * g.y));
  vec4 w1 = vec4(${c[2]} * g.z);
  vec4 w2 = vec4(${c[2]} * g.z, vec3(${c[3]} * g.w));
  vec4 w3 = vec4(${c[3]} * g.w);
  return dot(y[0] * w0, prtLight[4 * c]) + dot(y[1] * w1, prtLight[4 * c + 1])
       + dot(y[2] * w2, prtLight[4 * c + 2]) + dot(y[3] * w3, prtLight[4 * c + 3]);
}`,
  ].join('\n');
  const body = [
    '#ifdef USE_SKINNING',
    'mat3 ldprtSkin = mat3(modelMatrix) * mat3(skinMatrix);',
    '#else',
    'mat3 ldprtSkin = mat3(modelMatrix);',
    '#endif',
    `vec3 ldprtN = normalize(ldprtSkin * ${frame.normal});`,
    `vec3 ldprtT = ldprtSkin * ${frame.tangent};`,
    'ldprtT = normalize(ldprtT - ldprtN * dot(ldprtN, ldprtT));',
    'vec3 ldprtB = cross(ldprtN, ldprtT);',
    'vec4 ldprtY[4];',
    'vPrtShading = vec3(0.0);',
    ...lobes.flatMap((_, k) => [
      `{ vec3 a = ${frame.axis(k)};`,
      '  prtBasis(normalize(ldprtT * a.x + ldprtB * a.y + ldprtN * a.z), ldprtY);',
      // A grey bake's lobe is the same three times: lit by each channel of the light.
      `  vPrtShading += vec3(${frame.zh(k).map((g, c) => `ldprtBand(ldprtY, ${g}, ${c})`).join(', ')}); }`,
    ]),
  ].join('\n');
  return { declarations, body, normal: frame.normal };
}

// The light as the shader's uniform: per channel c, vec4 prtLight[4c + g] (order 4, padded).
function lightUniform(light) {
  const fitted = lightOfOrder(light, ORDER);
  const values = [];
  for (let c = 0; c < 3; c++) for (let g = 0; g < 4; g++) values.push(new THREE.Vector4(...fitted.rgb[c].subarray(4 * g, 4 * g + 4)));
  return values;
}

/**
 * Gives every mesh under `rootOrGltf` (an Object3D or GLTFLoader's result) that carries
 * `_LDPRT_*` attributes (three.js lower-cases them: `_ldprt_normal` …) a material that
 * evaluates its lobes per vertex, skinned as three.js skins the mesh (a SkinnedMesh, posed by
 * an AnimationMixer or by hand; a plain Mesh works too), lit by `light` (sh.js's
 * { order, rgb }, in glTF's frame: `prt-bake light RIG --up y`, or lightFromGLTF). Returns
 * { meshes, setLight(light), restore() }.
 */
export function applyLDPRT(rootOrGltf, light) {
  const root = rootOrGltf.isObject3D ? rootOrGltf : rootOrGltf.scene;
  const uniforms = { prtLight: { value: lightUniform(light) } };
  const entries = [];
  root.traverse((object) => {
    if (!object.isMesh) return;
    const found = lobesOf(object.geometry);
    if (!found) return;
    const frame = lobeTexture(object.geometry, found.lobes);
    const patch = shaderPatch(found.lobes, frame);
    const own = { ...uniforms, ldprtLobes: { value: frame.texture } };
    const original = object.material;
    const made = (Array.isArray(original) ? original : [original]).map((source) => {
      const material = albedoMaterial(source, object);
      material.onBeforeCompile = (shader) => {
        Object.assign(shader.uniforms, own);
        shader.vertexShader = shader.vertexShader
          .replace('#include <common>', `#include <common>\n${patch.declarations}`)
          // The skinned normal chunks read NORMAL: the LDPRT normal instead, so that NORMAL's
          // attribute stays unbound (an RGB bake of 3 lobes needs all 16 others).
          .replace('#include <beginnormal_vertex>', `vec3 objectNormal = ${patch.normal};`)
          .replace('#include <begin_vertex>', `#include <begin_vertex>\n${patch.body}`);
        shader.fragmentShader = shader.fragmentShader
          .replace('#include <common>', '#include <common>\nvarying vec3 vPrtShading;')
          .replace('#include <color_fragment>', '#include <color_fragment>\ndiffuseColor.rgb *= vPrtShading;');
      };
      material.customProgramCacheKey = () => `ldprt:${found.lobes.length}:${found.grey}:${frame.perVertex}`;
      return material;
    });
    object.material = Array.isArray(original) ? made : made[0];
    entries.push({ object, original });
  });
  return {
    meshes: entries.map((e) => e.object),
    /** A new light (same frame): only the uniform changes, nothing recompiles. */
    setLight(next) {
      uniforms.prtLight.value = lightUniform(next);
    },
    /** The materials the meshes had before. */
    restore() {
      for (const e of entries) e.object.material = e.original;
    },
  };
}
