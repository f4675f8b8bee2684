// Validates glTF files with the Khronos glTF-Validator (npm package `gltf-validator`) and
// exits 1 if any has an error. Also checks prt-bake's own promises (docs/reference/gltf.md): every
// texture is named by a material slot (or its extras); a texel bake's relit lightmap is in
// every material's extras.prt_lightmap on TEXCOORD_1, beside its own base colour; AO is an
// occlusionTexture on TEXCOORD_1 or `_AO`.
// Usage: node validate.mjs VALIDATOR_MODULE_DIR FILE.glb...
import { createRequire } from "node:module";
import { readFileSync } from "node:fs";
import path from "node:path";

const [moduleDir, ...files] = process.argv.slice(2);
const require = createRequire(path.resolve(moduleDir) + "/");
const validator = require("gltf-validator");

let failed = false;
for (const file of files) {
  const report = await validator.validateBytes(new Uint8Array(readFileSync(file)), {
    maxIssues: 0,
    externalResourceFunction: (uri) =>
      Promise.resolve(new Uint8Array(readFileSync(path.join(path.dirname(file), decodeURI(uri))))),
  });
  const { numErrors, numWarnings, numInfos, numHints, messages } = report.issues;
  console.log(
    `${file}: ${numErrors} errors, ${numWarnings} warnings, ${numInfos} infos, ${numHints} hints` +
      ` (glTF-Validator ${report.validatorVersion})`,
  );
  for (const m of messages.filter((m) => m.severity <= 1)) {
    console.log(`  ${m.severity === 0 ? "error" : "warning"} ${m.code} at ${m.pointer}: ${m.message}`);
  }
  if (numErrors > 0) failed = true;
  for (const problem of layoutProblems(readFileSync(file))) {
    console.log(`  layout: ${problem}`);
    failed = true;
  }
}

// The JSON chunk of a .glb.
function glbJson(bytes) {
  const length = bytes.readUInt32LE(12);
  return JSON.parse(bytes.subarray(20, 20 + length).toString("utf8"));
}

function layoutProblems(bytes) {
  const root = glbJson(bytes);
  const problems = [];
  const materials = root.materials ?? [];
  const slots = (m) => [m.pbrMetallicRoughness?.baseColorTexture, m.occlusionTexture, m.emissiveTexture,
    m.normalTexture, m.pbrMetallicRoughness?.metallicRoughnessTexture].filter(Boolean);
  const extras = (m) => [m.extras?.prt_lightmap, m.extras?.prt_alpha_texture].filter(Boolean);
  const named = new Set(materials.flatMap((m) => [...slots(m), ...extras(m)].map((s) => s.index)));
  (root.textures ?? []).forEach((t, i) => {
    if (!named.has(i)) problems.push(`texture ${i} (${t.name ?? "unnamed"}) is in no material slot`);
  });
  const lightmap = root.asset?.extras?.prt?.lightmap;
  if (lightmap && Number.isInteger(lightmap.texture)) {
    materials.forEach((m, i) => {
      const slot = m.extras?.prt_lightmap;
      const base = m.pbrMetallicRoughness?.baseColorTexture;
      if (slot?.index !== lightmap.texture || slot?.texCoord !== 1 || base?.index === lightmap.texture) {
        problems.push(`material ${i}: the relit lightmap is not in extras.prt_lightmap on TEXCOORD_1 beside the base colour`);
      }
    });
  }
  if (lightmap && Number.isInteger(lightmap.ao_texture)) {
    materials.forEach((m, i) => {
      if (m.occlusionTexture?.index !== lightmap.ao_texture || m.occlusionTexture?.texCoord !== 1) {
        problems.push(`material ${i}: the AO is not its occlusionTexture on TEXCOORD_1`);
      }
    });
  }
  if (root.asset?.extras?.prt?.ao) {
    root.meshes.forEach((mesh) => {
      if (!mesh.primitives.every((p) => Number.isInteger(p.attributes._AO))) problems.push(`mesh ${mesh.name}: no _AO`);
    });
  }
  return problems;
}
process.exit(failed ? 1 : 0);
