// Checks that `prt-bake export --gltf` kept the source's materials (docs/reference/gltf.md,
// "Materials"): every exported material against the source material of its name, field by
// field: alphaMode, alphaCutoff (as engines read it: 0.5 where MASK gives none), doubleSided,
// the base colour factor, the base colour texture (present, on the exported TEXCOORD_0, its
// sampler's wrap modes and KHR_texture_transform) and the normal texture (present, its scale,
// with TANGENT on the primitives that use it where the source had TANGENT). Every source
// material must be in the export. Exits 1 on any difference.
//
//   node scripts/gltf/materials.mjs SOURCE.glb EXPORT.glb...
import { readFileSync } from "node:fs";

const [source, ...exports] = process.argv.slice(2);
const json = (file) => {
  const bytes = readFileSync(file);
  return JSON.parse(bytes.subarray(20, 20 + bytes.readUInt32LE(12)).toString("utf8"));
};
const REPEAT = 10497;
const wrap = (root, info) => {
  const sampler = root.samplers?.[root.textures[info.index].sampler] ?? {};
  return [sampler.wrapS ?? REPEAT, sampler.wrapT ?? REPEAT];
};
const transform = (info) => {
  const t = info?.extensions?.KHR_texture_transform;
  return t ? [t.offset ?? [0, 0], t.rotation ?? 0, t.scale ?? [1, 1]] : null;
};
// What an engine reads from a material, with the specification's defaults filled in.
function fields(root, m, uses) {
  const pbr = m.pbrMetallicRoughness ?? {};
  const base = pbr.baseColorTexture;
  const normal = m.normalTexture;
  const mode = m.alphaMode ?? "OPAQUE";
  return {
    alphaMode: mode,
    alphaCutoff: mode === "MASK" ? (m.alphaCutoff ?? 0.5) : null,
    doubleSided: m.doubleSided ?? false,
    baseColorFactor: (pbr.baseColorFactor ?? [1, 1, 1, 1]).map((x) => Math.fround(x)),
    baseColorTexture: base ? { wrap: wrap(root, base), transform: transform(base) } : null,
    normalTexture: normal ? { scale: Math.fround(normal.scale ?? 1), wrap: wrap(root, normal), tangents: uses.every((p) => "TANGENT" in p.attributes) } : null,
  };
}
const primitivesOf = (root, index) => root.meshes.flatMap((mesh) => mesh.primitives).filter((p) => p.material === index);

const src = json(source);
const expected = new Map();
src.materials.forEach((m, i) => expected.set(m.name, fields(src, m, primitivesOf(src, i))));
let failed = false;
for (const file of exports) {
  const root = json(file);
  const seen = new Set();
  let checked = 0;
  root.materials.forEach((m, i) => {
    const want = expected.get(m.name);
    if (!want) return;
    seen.add(m.name);
    checked += 1;
    const got = fields(root, m, primitivesOf(root, i));
    // The exported TEXCOORD_0 holds the set the source's textures read.
    for (const slot of [m.pbrMetallicRoughness?.baseColorTexture, m.normalTexture]) {
      if (slot && (slot.texCoord ?? 0) !== 0) {
        console.log(`${file}: material ${i} '${m.name}': a texture on TEXCOORD_${slot.texCoord}, not the exported TEXCOORD_0`);
        failed = true;
      }
    }
    for (const key of Object.keys(want)) {
      const [a, b] = [JSON.stringify(want[key]), JSON.stringify(got[key])];
      if (a !== b) {
        console.log(`${file}: material ${i} '${m.name}': ${key} is ${b}, the source's ${a}`);
        failed = true;
      }
    }
  });
  const missing = [...expected.keys()].filter((name) => !seen.has(name));
  if (missing.length > 0) {
    console.log(`${file}: the source's material(s) ${missing.join(", ")} are not in the export`);
    failed = true;
  }
  console.log(`${file}: ${checked} materials checked field by field against ${source}: ${failed ? "DIFFER" : "the source's"}`);
}
process.exit(failed ? 1 : 0);
