// prt.js's SH rotation (runtime/three/sh.js) against the baker: `prt-bake light --up y` is
// the z-up light turned by (x, y, z) ↦ (x, z, −y), at order 8; and a directional light
// turned by an arbitrary rotation equals the light projected from the turned direction.
//   node scripts/browser/sh-test.mjs BAKE OUT
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const [bake, out] = process.argv.slice(2).map((p) => path.resolve(p));
const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const sh = await import(path.join(repo, 'runtime/three/sh.js'));
const light = (rig, up) => {
  const file = path.join(out, `sh-test-${up}.json`);
  execFileSync(bake, ['light', rig, '--order', '8', '--up', up, '-o', file], { stdio: ['ignore', 'ignore', 'inherit'] });
  return sh.lightFromJSON(fs.readFileSync(file, 'utf8'));
};
const largest = (a, b) => Math.max(...[0, 1, 2].flatMap((c) => Array.from(a.rgb[c], (x, j) => Math.abs(x - b.rgb[c][j]))));
let failed = false;
const check = (what, error) => {
  const ok = error < 1e-9;
  failed ||= !ok;
  console.log(`sh-test: ${ok ? 'ok  ' : 'FAIL'} ${what}: largest difference ${error.toExponential(2)}`);
};

const rig = path.join(repo, 'viewer/src/default-rig.toml');
check('rotateLight(light --up z, (x,y,z) ↦ (x,z,−y)) = light --up y, order 8',
  largest(sh.rotateLight(light(rig, 'z'), sh.Z_UP_TO_GLTF), light(rig, 'y')));

const m = sh.axisAngle([0.36, 0.8, 0.48], 1.1);
const d = [0.3, -0.5, 0.812404];
const md = [0, 1, 2].map((i) => m[3 * i] * d[0] + m[3 * i + 1] * d[1] + m[3 * i + 2] * d[2]);
const directional = (v, name) => {
  const file = path.join(out, `sh-test-${name}.toml`);
  fs.writeFileSync(file, `[[light]]\nkind = "directional"\ndirection = [${v.map((x) => x.toFixed(17)).join(', ')}]\ncolor = [1.0, 0.5, 0.25]\nintensity = 2.0\n`);
  return light(file, 'z');
};
check('rotateLight(directional d, m) = directional m·d, order 8',
  largest(sh.rotateLight(directional(d, 'd'), m), directional(md, 'md')));
if (failed) process.exit(1);
