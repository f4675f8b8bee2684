// Cut-outs, textures and two-sided materials in three.js (make browser; docs/reference/gltf.md,
// "Materials"): prt.js must keep what the loaded material draws besides its lighting.
//
// 1. The cut-out card of scenes/cutout (alphaMode MASK, 4 of 8 stripes kept) and its geometry
//    twin, baked alike and exported with a rig, relit by prt.js and seen from above: at least
//    99 % of the covered pixels within 8 codes.
// 2. The production courtyard (foliage cards: MASK, textured, doubleSided; a normal-mapped
//    wall), exported with a rig: relit by prt.js against three.js's own rendering of the file
//    as exported (COLOR_0 × the base colour, GLTFLoader's alphaTest), at least 99 % of the
//    covered pixels within 2 codes. The relit render is written as PNG (docs/images).
//
//   node scripts/browser/cutouts.mjs NODE_MODULES BAKE OUT
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import zlib from 'node:zlib';
import { fileURLToPath } from 'node:url';
import { compare, openBrowser } from './harness.mjs';

const [nodeModules, bake, out] = process.argv.slice(2).map((p) => path.resolve(p));
const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const { chromium } = await import(path.join(nodeModules, 'playwright-core/index.mjs'));
fs.mkdirSync(out, { recursive: true });
const run = (...args) => execFileSync(bake, args, { stdio: ['ignore', 'ignore', 'inherit'] });
const rig = path.join(repo, 'viewer/src/default-rig.toml');

for (const name of ['card', 'twin']) {
  const scene = path.join(repo, `scenes/cutout/${name}.glb`);
  run('bake', scene, '-o', path.join(out, `cutout-${name}.prt`), '--samples', '256', '--seed', '1', '--quiet');
  run('export', path.join(out, `cutout-${name}.prt`), '--scene', scene, '--glb', path.join(out, `cutout-${name}.glb`), '--lights', rig);
}
const courtyard = path.join(repo, 'scenes/production/courtyard.glb');
run('bake', courtyard, '-o', path.join(out, 'courtyard.prt'), '--samples', '128', '--seed', '1', '--quiet');
run('export', path.join(out, 'courtyard.prt'), '--scene', courtyard, '--glb', path.join(out, 'courtyard.glb'), '--lights', rig);

// An RGBA render (top row first) as PNG.
function png(file, { width, height, pixels }) {
  const rgba = Buffer.from(pixels, 'base64');
  const rows = Buffer.alloc((4 * width + 1) * height);
  for (let y = 0; y < height; y++) rgba.copy(rows, y * (4 * width + 1) + 1, 4 * width * y, 4 * width * (y + 1));
  const chunk = (kind, data) => {
    const body = Buffer.concat([Buffer.from(kind), data]);
    const length = Buffer.alloc(4);
    length.writeUInt32BE(data.length);
    const crc = Buffer.alloc(4);
    crc.writeUInt32BE(zlib.crc32(body));
    return Buffer.concat([length, body, crc]);
  };
  const header = Buffer.alloc(13);
  header.writeUInt32BE(width, 0);
  header.writeUInt32BE(height, 4);
  header.set([8, 6, 0, 0, 0], 8);
  fs.writeFileSync(file, Buffer.concat([Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]),
    chunk('IHDR', header), chunk('IDAT', zlib.deflateSync(rows)), chunk('IEND', Buffer.alloc(0))]));
}

const { base, page, errors, close } = await openBrowser(chromium, { repo, out, nodeModules });
let failures = 0;
const report = (ok, text) => {
  failures += ok ? 0 : 1;
  console.log(`browser: ${ok ? 'ok  ' : 'FAIL'} ${text}`);
};
try {
  await page.goto(`${base}/scripts/browser/page.html`);
  await page.waitForFunction(() => window.prtReady === true);
  const render = (args) => page.evaluate((a) => window.prtTest.render(a), args);
  // From above the card (glTF +y up), nearer than the whole floor's framing.
  const above = { view: [0, 1, 0.12], zoom: 2.6 };
  const [card, twin] = await Promise.all(['card', 'twin'].map((name) => render({ glb: `/data/cutout-${name}.glb`, mode: 'prt', light: 'embedded', ...above })));
  const a = Buffer.from(card.pixels, 'base64');
  const b = Buffer.from(twin.pixels, 'base64');
  const agreement = compare(a, b, 8);
  report(agreement.covered > 1000 && agreement.share >= 0.99,
    `the cut-out card relit by prt.js is its geometry twin's: ${(100 * agreement.share).toFixed(2)} % of ${agreement.covered} covered pixels within 8 codes (worst ${agreement.worst})`);
  png(path.join(out, 'cutout-card-prt.png'), card);
  png(path.join(out, 'cutout-twin-prt.png'), twin);

  const view = { view: [0.55, 0.45, 1], zoom: 1.15 };
  const exported = await render({ glb: '/data/courtyard.glb', mode: 'exported', ...view });
  const relit = await render({ glb: '/data/courtyard.glb', mode: 'prt', light: 'embedded', ...view });
  const c = compare(Buffer.from(exported.pixels, 'base64'), Buffer.from(relit.pixels, 'base64'), 2);
  report(c.covered > 1000 && c.share >= 0.99,
    `the courtyard relit by prt.js is three.js's own render of the export: ${(100 * c.share).toFixed(2)} % of ${c.covered} covered pixels within 2 codes (worst ${c.worst})`);
  png(path.join(out, 'courtyard-prt.png'), relit);
  png(path.join(out, 'courtyard-exported.png'), exported);
} finally {
  await close();
}
for (const e of errors) console.log(`browser: console error: ${e}`);
if (errors.length > 0 || failures > 0) {
  console.log(`browser: cut-outs FAILED (${failures} comparison(s), ${errors.length} console error(s))`);
  process.exit(1);
}
console.log(`browser: cut-outs, textures and sheets kept; renders in ${out}`);
