// The moving-occluder browser test (make browser; docs/guides/occluders.md, "In three.js"):
// the Cornell room's vertex bake, exported to .glb, relit in Chromium by runtime/three/prt.js
// with its transfer darkened by runtime/three/occluders.js (occluderSpheresForObject for two
// movers, one turned, then occludedTransfer); the turned one is a ball baked alone and lit
// by the room's probes (probeLightForObject). The frame must match the same .glb coloured
// with `prt-bake relight --occluder --at --turn`'s radiance and the ball coloured with
// `relight --probes --at --turn`'s: at least 99 % of the lit pixels (a code of 8 or more in
// the reference) within 2 codes. The same render without the occluders must miss that bound
// (the test can fail).
//
//   node scripts/browser/occluder-render.mjs NODE_MODULES BAKE OUT
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { compareLit, openBrowser, readPly } from './harness.mjs';

const [nodeModules, bake, outRoot] = process.argv.slice(2).map((p) => path.resolve(p));
const out = path.join(outRoot, 'occluder-render');
const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const { chromium } = await import(path.join(nodeModules, 'playwright-core/index.mjs'));
const sh = await import(path.join(repo, 'runtime/three/sh.js'));
fs.mkdirSync(out, { recursive: true });
const run = (...args) => execFileSync(bake, args, { stdio: ['ignore', 'ignore', 'inherit'] });
const file = (name) => path.join(out, name);
const started = Date.now();

// A ball of radius 0.25 about the origin, fitted with 3 spheres (off its centre, so a turn matters).
let obj = 'o ball\n';
const [rings, segments] = [12, 24];
for (let i = 0; i <= rings; i++) for (let j = 0; j < segments; j++) {
  const [t, p] = [(Math.PI * i) / rings, (2 * Math.PI * j) / segments];
  obj += `v ${0.25 * Math.sin(t) * Math.cos(p)} ${0.25 * Math.sin(t) * Math.sin(p)} ${0.25 * Math.cos(t)}\n`;
}
const at = (i, j) => i * segments + (j % segments) + 1;
for (let i = 0; i < rings; i++) for (let j = 0; j < segments; j++) {
  obj += `f ${at(i, j)} ${at(i + 1, j)} ${at(i + 1, j + 1)}\nf ${at(i, j)} ${at(i + 1, j + 1)} ${at(i, j + 1)}\n`;
}
fs.writeFileSync(file('ball.obj'), obj);
run('bake', file('ball.obj'), '--occluder', '--spheres', '3', '-o', file('ball.occ'));
const cornell = path.join(repo, 'scenes/cornell/cornell.scene');
run('bake', cornell, '-o', file('room.prt'), '--order', '4', '--samples', '128', '--quiet');
run('export', file('room.prt'), '--scene', cornell, '--glb', file('room.glb'));
const rig = path.join(repo, 'viewer/src/default-rig.toml');
run('light', rig, '--order', '4', '--up', 'y', '-o', file('light.json'));
// Two movers on the floor, the second turned 90° about x (scene frame, z up).
const places = [
  { position: [-0.45, -0.5, 0.27], turn: [0, 0, 1, 0] },
  { position: [0.1, -0.6, 0.27], turn: [1, 0, 0, 90] },
].map(({ position, turn: [x, y, z, deg] }) => ({ position, turn: [x, y, z, deg], rotation: sh.axisAngle([x, y, z], (deg * Math.PI) / 180) }));
run('relight', cornell, file('room.prt'), '--lights', rig, '-o', file('shadowed.ply'),
  ...places.flatMap((p) => ['--occluder', file('ball.occ'), '--at', p.position.join(','), '--turn', p.turn.join(',')]));

// The mover: the ball baked alone and exported, lit by the room's probes at the second place
// (relight --probes --at --turn gives its reference radiance).
run('bake', file('ball.obj'), '-o', file('ball.prt'), '--order', '4', '--samples', '128', '--quiet');
run('export', file('ball.prt'), '--scene', file('ball.obj'), '--glb', file('ball.glb'));
run('bake', cornell, '-o', file('grid.prt'), '--probes', 'grid:4,4,4', '--order', '4', '--samples', '256', '--mode', 'interreflected', '--quiet');
run('light', rig, '--order', '4', '-o', file('light-z.json'));
run('relight', file('ball.obj'), file('ball.prt'), '--lights', rig, '-o', file('ball-lit.ply'),
  '--probes', file('grid.prt'), '--at', places[1].position.join(','), '--turn', places[1].turn.join(','));

const base64 = (a) => Buffer.from(a.buffer).toString('base64');
const room = readPly(file('shadowed.ply'));
const reference = { positions: base64(room.positions), normals: base64(room.normals), radiance: base64(room.radiance) };
const ballRadiance = base64(readPly(file('ball-lit.ply')).radiance);
console.log(`browser: occluder-render: baked, exported and relit in ${((Date.now() - started) / 1000).toFixed(1)} s`);


const { base, page, errors, close } = await openBrowser(chromium, { repo, out, nodeModules });
let results;
try {
  await page.goto(`${base}/scripts/browser/occluder.html`);
  await page.waitForFunction(() => window.prtOccluderReady === true);
  const render = (args) => page.evaluate((a) => window.prtOccluder.render(a), args);
  const common = { glb: '/data/room.glb', light: '/data/light.json', occluder: '/data/ball.occ' };
  const movers = places.map(({ position, rotation }) => ({ position, rotation }));
  const mover = { glb: '/data/ball.glb', probes: '/data/grid.prt', light: '/data/light-z.json', at: 1 };
  const renders = [await render({ ...common, places: movers, reference, mover: { ...mover, radiance: ballRadiance } }),
    await render({ ...common, places: movers, mover }), await render({ ...common, places: movers, mover, shadow: false })];
  const [want, got, plain] = renders.map((r) => Buffer.from(r.pixels, 'base64'));
  ['relight', 'prt', 'unshadowed'].forEach((name, k) => fs.writeFileSync(file(`${name}.rgba`), [want, got, plain][k]));
  results = { shadowed: compareLit(want, got, 2), plain: compareLit(want, plain, 2), darkened: renders[1].darkened };
} finally {
  await close();
}
const { shadowed, plain, darkened } = results;
const ok = shadowed.lit > 10000 && shadowed.share >= 0.99 && darkened > 100;
const fails = plain.share < 0.99;
console.log(`browser: ${ok ? 'ok  ' : 'FAIL'} occluder-render: ${(100 * shadowed.share).toFixed(2)} % of ${shadowed.lit} lit pixels within 2 codes of relight --occluder (worst ${shadowed.worst}; ${darkened} transfer coefficients darkened)`);
console.log(`browser: ${fails ? 'ok  ' : 'FAIL'} occluder-render without the occluders: ${(100 * plain.share).toFixed(2)} % within 2 codes (must be under 99 %)`);
for (const e of errors) console.log(`browser: console error: ${e}`);
if (!ok || !fails || errors.length > 0) {
  console.log('browser: occluder-render FAILED');
  process.exit(1);
}
console.log(`browser: occluder-render: three.js with occluders.js matches relight --occluder (${((Date.now() - started) / 1000).toFixed(1)} s)`);
