// The browser test (make browser): Debian's chromium, driven by playwright-core, renders
// prt-bake's .glb exports with three.js as exported (COLOR_0, or the relit lightmap) and
// relit by runtime/three/prt.js, at the rig and with the light turned in JavaScript (against
// an export of the turned rig). Every pair must agree within 2 codes (4 for texel bakes) on
// at least 99 % of the covered pixels, with no console error. Frame times of both are printed.
//
//   node scripts/browser/test.mjs NODE_MODULES BAKE OUT
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { compare, openBrowser } from './harness.mjs';

const [nodeModules, bake, out] = process.argv.slice(2).map((p) => path.resolve(p));
const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const { chromium } = await import(path.join(nodeModules, 'playwright-core/index.mjs'));
const sh = await import(path.join(repo, 'runtime/three/sh.js'));
fs.mkdirSync(out, { recursive: true });

function run(...args) {
  execFileSync(bake, args, { stdio: ['ignore', 'ignore', 'inherit'] });
}

// The rig and its turned twin. The turn is given in glTF's frame (+Y up) as prt.js takes it;
// rigs are written in the baker's z-up world, so the twin's directions are turned by
// Aᵀ·m·A with A = (x, y, z) ↦ (x, z, −y).
const turn = sh.axisAngle([0.36, 0.8, 0.48], (50 * Math.PI) / 180);
const turnZUp = sh.multiply3(sh.multiply3(sh.GLTF_TO_Z_UP, turn), sh.Z_UP_TO_GLTF);
const apply = (m, v) => [0, 1, 2].map((i) => m[3 * i] * v[0] + m[3 * i + 1] * v[1] + m[3 * i + 2] * v[2]);
const sun = [Math.sin(1.134) * Math.cos(0.524), Math.sin(1.134) * Math.sin(0.524), Math.cos(1.134)];
function rig(file, m) {
  const d = (v) => `[${apply(m, v).map((x) => x.toFixed(15)).join(', ')}]`;
  fs.writeFileSync(file, `[[light]]
kind = "sun"
direction = ${d(sun)}
color = [1.0, 0.92, 0.8]
intensity = 2.5

[[light]]
kind = "hemisphere"
direction = ${d([0, 0, 1])}
color = [0.35, 0.4, 0.5]
ground_color = [0.05, 0.045, 0.04]
`);
}
const identity = [1, 0, 0, 0, 1, 0, 0, 0, 1];
rig(path.join(out, 'rig.toml'), identity);
rig(path.join(out, 'rig-turned.toml'), turnZUp);

// The bakes: grey per vertex (textured torus), RGB interreflected per vertex (Cornell box),
// and a texel bake of the Cornell box.
const cases = [
  { name: 'torus', scene: 'scenes/torus/torus.scene', bake: ['--order', '3'], tolerance: 2, view: [0.6, 0.9, 1] },
  { name: 'cornell-rgb', scene: 'scenes/cornell/cornell.scene', bake: ['--mode', 'interreflected'], tolerance: 2, view: [0.15, 0.2, 1] },
  { name: 'cornell-texel', scene: 'scenes/cornell/cornell.scene', bake: ['--lightmap', '128'], tolerance: 4, view: [0.15, 0.2, 1], texel: true },
  // CPCA-compressed (64 clusters × 4 components, Sloan 2003): the .glb carries a cluster index
  // and 4 weights per vertex, and prt.js dots the light into each cluster once per frame.
  { name: 'cornell-cpca', scene: 'scenes/cornell/cornell.scene', bake: ['--mode', 'interreflected', '--clusters', '64', '--pcs', '4'], tolerance: 2, view: [0.15, 0.2, 1], cpca: true },
];
const started = Date.now();
for (const c of cases) {
  const prt = path.join(out, `${c.name}.prt`);
  run('bake', path.join(repo, c.scene), '-o', prt, '--samples', '64', '--quiet', ...c.bake);
  for (const [suffix, lights] of [['', 'rig.toml'], ['-turned', 'rig-turned.toml']]) {
    run('export', prt, '--scene', path.join(repo, c.scene), '--glb', path.join(out, `${c.name}${suffix}.glb`), '--lights', path.join(out, lights));
  }
  if (c.texel) run('export', prt, '--scene', path.join(repo, c.scene), '--exr', path.join(out, `${c.name}-exr`), '--exr-type', 'f16');
  else if (!c.cpca) {
    for (const bits of [16, 8]) {
      run('export', prt, '--scene', path.join(repo, c.scene), '--glb', path.join(out, `${c.name}-q${bits}.glb`), '--quantize', String(bits), '--lights', path.join(out, 'rig.toml'));
    }
  }
}
run('light', path.join(out, 'rig.toml'), '--order', '3', '--up', 'y', '-o', path.join(out, 'light-3.json'));
run('light', path.join(out, 'rig.toml'), '--order', '4', '--up', 'y', '-o', path.join(out, 'light-4.json'));
console.log(`browser: baked and exported in ${((Date.now() - started) / 1000).toFixed(1)} s`);

const { base, page, errors, close } = await openBrowser(chromium, { repo, out, nodeModules });

let failures = 0;
try {
  await page.goto(`${base}/scripts/browser/page.html`);
  await page.waitForFunction(() => window.prtReady === true);
  const render = (args) => page.evaluate((a) => window.prtTest.render(a), args);
  const light = (order) => JSON.parse(fs.readFileSync(path.join(out, `light-${order}.json`), 'utf8'));

  for (const c of cases) {
    const order = c.name === 'torus' ? 3 : 4;
    const lightmap = c.texel ? `/data/${c.name}-exr/manifest.json` : null;
    const exported = {};
    for (const [label, glb, rotation] of [['rig', `${c.name}.glb`, null], ['turned', `${c.name}-turned.glb`, turn]]) {
      const frames = label === 'rig' ? 30 : 0;
      const reference = await render({ glb: `/data/${glb}`, mode: 'exported', view: c.view, frames });
      // At the rig, the light is the one the .glb carries (export --lights puts it in
      // asset.extras.prt.light); turned, it is prt-bake light's JSON turned by prt.js.
      const relitLight = label === 'rig' ? 'embedded' : light(order);
      const relit = await render({ glb: `/data/${c.name}.glb`, mode: 'prt', light: relitLight, rotation, lightmap, view: c.view, frames });
      const a = Buffer.from(reference.pixels, 'base64');
      const b = Buffer.from(relit.pixels, 'base64');
      exported[label] = a;
      const { share, covered, worst } = compare(a, b, c.tolerance);
      const ok = covered > 1000 && share >= 0.99;
      failures += ok ? 0 : 1;
      const timing = frames ? `; frame ${relit.ms.toFixed(2)} ms PRT, ${reference.ms.toFixed(2)} ms as exported (MeshBasicMaterial)` : '';
      console.log(`browser: ${ok ? 'ok  ' : 'FAIL'} ${c.name} ${label}: ${(100 * share).toFixed(2)} % of ${covered} covered pixels within ${c.tolerance} codes (worst ${worst})${timing}`);
      for (const [which, r] of [['exported', reference], ['prt', relit]]) {
        fs.writeFileSync(path.join(out, `${c.name}-${label}-${which}.rgba`), Buffer.from(r.pixels, 'base64'));
      }
    }
    // The light in the .glb is prt-bake light --up y's, to rounding.
    const embedded = await page.evaluate((glb) => window.prtTest.embeddedLight(glb), `/data/${c.name}.glb`);
    const json = light(order);
    const lightError = embedded && embedded.order === json.order
      ? Math.max(...embedded.rgb.flatMap((channel, i) => channel.map((x, j) => Math.abs(x - json.coefficients[i][j]))))
      : Infinity;
    failures += lightError <= 1e-9 ? 0 : 1;
    console.log(`browser: ${lightError <= 1e-9 ? 'ok  ' : 'FAIL'} ${c.name}: the .glb's light (asset.extras.prt.light) is prt-bake light --up y's (largest difference ${lightError.toExponential(1)})`);
    // export --quantize: the relit render of the 16-bit transfer must match the float
    // COLOR_0 as closely as the float transfer does, the 8-bit one within twice the codes.
    if (!c.texel && !c.cpca) {
      const reference = Buffer.from((await render({ glb: `/data/${c.name}.glb`, mode: 'exported', view: c.view })).pixels, 'base64');
      const float = fs.statSync(path.join(out, `${c.name}.glb`)).size;
      for (const bits of [16, 8]) {
        const relit = await render({ glb: `/data/${c.name}-q${bits}.glb`, mode: 'prt', light: light(order), view: c.view });
        const b = Buffer.from(relit.pixels, 'base64');
        const tolerance = bits === 8 ? 2 * c.tolerance : c.tolerance;
        const { share, covered, worst } = compare(reference, b, tolerance);
        const size = fs.statSync(path.join(out, `${c.name}-q${bits}.glb`)).size;
        // The quantized file must be smaller: an export that ignored --quantize matched too.
        const ok = covered > 1000 && share >= 0.99 && size < float;
        failures += ok ? 0 : 1;
        console.log(`browser: ${ok ? 'ok  ' : 'FAIL'} ${c.name} --quantize ${bits}: ${(100 * share).toFixed(2)} % within ${tolerance} codes of the float COLOR_0 (worst ${worst}); ${size} bytes, ${(100 * size / float).toFixed(1)} % of float's ${float}`);
      }
    }
    // What the transfer costs in vertex attributes (WebGL 2 guarantees 16), and bytes.
    if (!c.texel) {
      const bytes = fs.readFileSync(path.join(out, `${c.name}.glb`));
      const doc = JSON.parse(bytes.subarray(20, 20 + bytes.readUInt32LE(12)).toString('utf8'));
      const counts = doc.meshes.map((m) => Object.keys(m.primitives[0].attributes));
      const all = Math.max(...counts.map((a) => a.length));
      const prtCount = Math.max(...counts.map((a) => a.filter((n) => n.startsWith('_PRT')).length));
      const ok = !c.cpca || all <= 6;
      failures += ok ? 0 : 1;
      console.log(`browser: ${ok ? 'ok  ' : 'FAIL'} ${c.name}: ${all} vertex attributes per primitive, ${prtCount} of them transfer; ${bytes.length} bytes`);
    }
    // The turn must change the picture, or the turned comparison proves nothing.
    const { rig: r, turned: t } = exported;
    let changed = 0;
    for (let i = 0; i < r.length; i += 4) {
      if (Math.max(Math.abs(r[i] - t[i]), Math.abs(r[i + 1] - t[i + 1]), Math.abs(r[i + 2] - t[i + 2])) > 3 * c.tolerance) changed += 1;
    }
    const sensitive = changed > 0.2 * (r.length / 4) * 0.5;
    failures += sensitive ? 0 : 1;
    console.log(`browser: ${sensitive ? 'ok  ' : 'FAIL'} ${c.name}: the turned rig changes ${changed} pixels by more than ${3 * c.tolerance} codes`);
  }
  // The example page given only a .glb relights it with the rig the file carries (the README's
  // web round trip), ...
  await page.goto(`${base}/runtime/three/example.html?glb=/data/cornell-rgb.glb`);
  await page.waitForFunction(() => window.prtExample?.handle?.meshes.length > 0, null, { timeout: 30000 });
  console.log('browser: ok   example.html relights a .glb with its own light (no light file)');
  // ... and given a light, it loads that; a right drag turns the light.
  await page.goto(`${base}/runtime/three/example.html?glb=/data/cornell-rgb.glb&light=/data/light-4.json`);
  await page.waitForFunction(() => window.prtExample?.handle?.meshes.length > 0, null, { timeout: 30000 });
  await page.mouse.move(400, 300);
  await page.mouse.down({ button: 'right' });
  await page.mouse.move(460, 330, { steps: 5 });
  await page.mouse.up({ button: 'right' });
  const turned = await page.evaluate(() => window.prtExample.turn);
  const exampleOk = Math.abs(turned[0] - 1) > 1e-3;
  failures += exampleOk ? 0 : 1;
  console.log(`browser: ${exampleOk ? 'ok  ' : 'FAIL'} example.html relights ${await page.evaluate(() => window.prtExample.handle.meshes.length)} meshes; a right drag turns the light`);
} finally {
  await close();
}
for (const e of errors) console.log(`browser: console error: ${e}`);
if (errors.length > 0 || failures > 0) {
  console.log(`browser: FAILED (${failures} comparison(s), ${errors.length} console error(s))`);
  process.exit(1);
}
console.log('browser: every render matches, no console errors');
