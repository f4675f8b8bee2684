// The glossy browser test (make browser): a transfer-matrix bake of a glossy Cornell box
// (untextured, so a per-vertex reference is exact), CPCA-compressed (64 × 4), exported to .glb and
// relit in Chromium by runtime/three/prt.js from three camera positions, each against
// `prt-bake relight --view` from the same position (its per-vertex radiance rendered as vertex
// colours by three.js, interpolated as prt.js's per-vertex shading is). At least 99 % of the
// covered pixels must agree within 2 codes, and the glossy layer must matter: relight --view
// must differ from the diffuse relight (no --view) on at least 5 % of the pixels, or a
// renderer that left the highlight out would pass.
//
//   node scripts/browser/glossy.mjs NODE_MODULES BAKE OUT
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { compare, openBrowser } from './harness.mjs';

const [nodeModules, bake, outRoot] = process.argv.slice(2).map((p) => path.resolve(p));
const out = path.join(outRoot, 'glossy');
const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const { chromium } = await import(path.join(nodeModules, 'playwright-core/index.mjs'));
const sh = await import(path.join(repo, 'runtime/three/sh.js'));
fs.mkdirSync(out, { recursive: true });
const run = (...args) => execFileSync(bake, args, { stdio: ['ignore', 'ignore', 'inherit'] });

// The Cornell box (untextured: its albedo is constant per material, so per-vertex radiance
// interpolated equals prt.js's albedo × interpolated shading) with every material given a
// glossy layer (Ks 0.3, Ns 20). 2,944 vertices: the CPCA fit takes seconds.
const cornell = path.join(repo, 'scenes/cornell');
const scene = path.join(out, 'cornell-glossy.obj');
fs.copyFileSync(path.join(cornell, 'cornell.obj'), scene);
const mtl = fs.readFileSync(path.join(cornell, 'cornell.mtl'), 'utf8');
fs.writeFileSync(path.join(out, 'cornell.mtl'), mtl.replace(/^Kd .*$/gm, (kd) => `${kd}\nKs 0.3 0.3 0.3\nNs 20`));
// A low sun through the open front (the highlights on the floor and the boxes) and a sky.
const rig = path.join(out, 'rig.toml');
fs.writeFileSync(rig, `[[light]]
kind = "sun"
direction = [0.3, -0.8, 0.5]
color = [1.0, 0.92, 0.8]
intensity = 3.0

[[light]]
kind = "hemisphere"
direction = [0.0, 0.0, 1.0]
color = [0.35, 0.4, 0.5]
ground_color = [0.05, 0.045, 0.04]
`);
const started = Date.now();
const matrix = path.join(out, 'glossy-m.prt');
const compressed = path.join(out, 'glossy-c.prt');
const glb = path.join(out, 'glossy.glb');
run('bake', scene, '-o', matrix, '--transfer', 'matrix', '--order', '4', '--samples', '64', '--seed', '1', '--denoise', 'on', '--quiet');
run('compress', matrix, '-o', compressed, '--clusters', '64', '--pcs', '4', '--starts', '1');
run('export', compressed, '--scene', scene, '--glb', glb, '--lights', rig);
console.log(`browser: glossy: baked, compressed and exported in ${((Date.now() - started) / 1000).toFixed(1)} s`);

// prt-bake relight's per-vertex radiance (the PLY's radiance_r/g/b floats), from `eye` in the
// scene's frame (z up), or diffuse without it.
function relight(eye, name) {
  const ply = path.join(out, `${name}.ply`);
  run('relight', scene, compressed, '--lights', rig, '-o', ply, ...(eye ? ['--view', eye.join(',')] : []));
  const bytes = fs.readFileSync(ply);
  const end = bytes.indexOf('end_header\n') + 'end_header\n'.length;
  const header = bytes.subarray(0, end).toString('latin1').split('\n');
  const count = Number(header.find((l) => l.startsWith('element vertex')).split(' ')[2]);
  const properties = [];
  let inVertex = false;
  for (const line of header) {
    if (line.startsWith('element')) inVertex = line.startsWith('element vertex');
    else if (inVertex && line.startsWith('property')) {
      const [, type, prop] = line.split(' ');
      properties.push({ prop, size: type === 'float' ? 4 : 1 });
    }
  }
  const stride = properties.reduce((s, p) => s + p.size, 0);
  const offset = (name) => {
    let o = 0;
    for (const p of properties) {
      if (p.prop === name) return o;
      o += p.size;
    }
    throw new Error(`${ply}: no ${name}`);
  };
  const channels = ['radiance_r', 'radiance_g', 'radiance_b'].map(offset);
  const radiance = new Float32Array(3 * count);
  for (let v = 0; v < count; v++) {
    channels.forEach((o, c) => { radiance[3 * v + c] = bytes.readFloatLE(end + v * stride + o); });
  }
  return Buffer.from(radiance.buffer).toString('base64');
}

const { base, page, errors, close } = await openBrowser(chromium, { repo, out, nodeModules });


// Three camera positions through the open front (directions from the centre in the file's
// frame, +Y up), from which the highlights sit in different places.
const views = [[0.15, 0.2, 1], [-0.4, 0.1, 1], [0.35, 0.45, 1]];
let failures = 0;
try {
  await page.goto(`${base}/scripts/browser/glossy.html`);
  await page.waitForFunction(() => window.prtGlossyReady === true);
  const render = (args) => page.evaluate((a) => window.prtGlossy.render(a), args);
  const diffuse = relight(null, 'diffuse');
  const highlights = [];
  for (const [i, view] of views.entries()) {
    const relit = await render({ glb: '/data/glossy.glb', view, distance: 2.4, frames: i === 0 ? 20 : 0 });
    // The camera in the scene's own frame (z up) for relight --view.
    const [x, y, z] = relit.camera;
    const eye = [0, 1, 2].map((r) => sh.GLTF_TO_Z_UP[3 * r] * x + sh.GLTF_TO_Z_UP[3 * r + 1] * y + sh.GLTF_TO_Z_UP[3 * r + 2] * z);
    const reference = await render({ glb: '/data/glossy.glb', view, distance: 2.4, radiance: relight(eye, `view-${i}`) });
    const flat = await render({ glb: '/data/glossy.glb', view, distance: 2.4, radiance: diffuse });
    const [a, b, d] = [reference, relit, flat].map((r) => Buffer.from(r.pixels, 'base64'));
    fs.writeFileSync(path.join(out, `view-${i}-relight.rgba`), a);
    fs.writeFileSync(path.join(out, `view-${i}-prt.rgba`), b);
    const { share, covered, worst } = compare(a, b, 2);
    const glossy = 1 - compare(a, d, 2).share;
    highlights.push(glossy);
    const ok = covered > 1000 && share >= 0.99 && glossy >= 0.05;
    failures += ok ? 0 : 1;
    const timing = relit.ms ? `; frame ${relit.ms.toFixed(2)} ms` : '';
    console.log(`browser: ${ok ? 'ok  ' : 'FAIL'} glossy view ${i} (eye ${eye.map((e) => e.toFixed(2)).join(', ')}): ${(100 * share).toFixed(2)} % of ${covered} covered pixels within 2 codes of relight --view (worst ${worst}); the glossy layer changes ${(100 * glossy).toFixed(1)} % of them${timing}`);
  }
} finally {
  await close();
}
for (const e of errors) console.log(`browser: console error: ${e}`);
if (errors.length > 0 || failures > 0) {
  console.log(`browser: glossy FAILED (${failures} comparison(s), ${errors.length} console error(s))`);
  process.exit(1);
}
console.log('browser: glossy renders match relight --view, no console errors');
