// Validates glTF files with the Khronos glTF-Validator (npm package `gltf-validator`) and
// exits 1 if any has an error. Usage: node validate.mjs VALIDATOR_MODULE_DIR FILE.glb...
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
}
process.exit(failed ? 1 : 0);
