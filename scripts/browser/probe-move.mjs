// The moving-object browser test (make browser; docs/guides/probes.md, "A moving object"): a small
// grey ball baked alone is moved along a path through the Cornell room and lit in Chromium by
// runtime/three/prt.js from the room's interreflected probe grid (probeLightForObject: the
// grid's incident radiance at the ball's position, turned into its frame). At each of four
// positions (in the short box's shadow, by the red wall, by the green wall, in the sun) the
// render must match the ball coloured with `prt-bake relight --probes --at --turn`'s radiance
// from a probe baked exactly at that position (a 1 × 1 × 1 grid around it): the interpolation,
// the frames and the rotation together, on at least 95 % of the ball's pixels within 4 codes.
// And the scene must reach it: in the shadow its mean luminance is under half the sunlit
// one, and its red/green ratio (the ball's pixels, linear) is above 1.05 by the red wall, under
// 0.99 by the green wall and 0.1 above it.
//
//   node scripts/browser/probe-move.mjs NODE_MODULES BAKE OUT
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { compare, openBrowser } from './harness.mjs';

const [nodeModules, bake, outRoot] = process.argv.slice(2).map((p) => path.resolve(p));
const out = path.join(outRoot, 'probe-move');
const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const { chromium } = await import(path.join(nodeModules, 'playwright-core/index.mjs'));
const sh = await import(path.join(repo, 'runtime/three/sh.js'));
fs.mkdirSync(out, { recursive: true });
const run = (...args) => execFileSync(bake, args, { stdio: ['ignore', 'ignore', 'inherit'] });
const file = (name) => path.join(out, name);
const started = Date.now();

// The ball: radius 0.12, 12 × 8 segments, Kd 0.8, baked alone (order 3).
const [nu, nv, radius] = [12, 8, 0.12];
const lines = ['mtllib ball.mtl', 'usemtl grey'];
const normals = [];
for (let j = 0; j <= nv; j++) {
  for (let i = 0; i <= nu; i++) {
    const [t, p] = [(Math.PI * j) / nv, (2 * Math.PI * i) / nu];
    normals.push([Math.sin(t) * Math.cos(p), Math.sin(t) * Math.sin(p), Math.cos(t)]);
  }
}
normals.forEach((n) => lines.push(`v ${n.map((c) => (radius * c).toFixed(6)).join(' ')}`));
normals.forEach((n) => lines.push(`vn ${n.map((c) => c.toFixed(6)).join(' ')}`));
const face = (...v) => lines.push(`f ${v.map((k) => `${k + 1}//${k + 1}`).join(' ')}`);
for (let j = 0; j < nv; j++) {
  for (let i = 0; i < nu; i++) {
    const a = j * (nu + 1) + i;
    if (j > 0) face(a, a + nu + 1, a + 1);
    if (j < nv - 1) face(a + 1, a + nu + 1, a + nu + 2);
  }
}
fs.writeFileSync(file('ball.obj'), `${lines.join('\n')}\n`);
fs.writeFileSync(file('ball.mtl'), 'newmtl grey\nKd 0.8 0.8 0.8\n');
// A sun through the open front and a sky: the room's rig of the viewer's tests.
fs.copyFileSync(path.join(repo, 'scenes/cornell/room-rig.toml'), file('rig.toml'));
run('bake', file('ball.obj'), '-o', file('ball.prt'), '--order', '3', '--mode', 'shadowed', '--samples', '256', '--quiet');
run('export', file('ball.prt'), '--scene', file('ball.obj'), '--glb', file('ball.glb'));
const cornell = path.join(repo, 'scenes/cornell/cornell.scene');
const probeBake = ['--order', '3', '--samples', '1024', '--mode', 'interreflected', '--quiet'];
run('bake', cornell, '-o', file('grid.prt'), '--probes', 'grid:8,8,8', ...probeBake);
run('light', file('rig.toml'), '--order', '3', '-o', file('light.json'));

// The path's four test positions (scene frame, z up; the grid's probes are 0.25 apart at
// ±0.125, ±0.375, …, so none is at a probe) and the ball's turn.
const stops = [
  { name: 'shadow', position: [0.35, 0.4, 0.2] },
  { name: 'red wall', position: [-0.75, -0.5, 0.8] },
  { name: 'green wall', position: [0.75, -0.5, 0.8] },
  { name: 'sun', position: [0.0, -0.3, 1.0] },
];
const axis = [0.2, 0.9, 0.4];
const degrees = 70;
const norm = Math.hypot(...axis);
const rotation = sh.axisAngle(axis.map((a) => a / norm), (degrees * Math.PI) / 180);

// relight --probes --at --turn from a probe baked exactly at `position`: per-vertex linear
// radiance (the PLY's radiance floats: 6 floats and 3 colour bytes before them).
function exactRadiance(position, k) {
  const box = [...position.map((c) => c - 0.001), ...position.map((c) => c + 0.001)];
  run('bake', cornell, '-o', file(`exact-${k}.prt`), '--probes', `grid:1,1,1:${box.join(',')}`, ...probeBake);
  run('relight', file('ball.obj'), file('ball.prt'), '--lights', file('rig.toml'), '-o', file(`exact-${k}.ply`),
    '--probes', file(`exact-${k}.prt`), '--at', position.join(','), '--turn', [...axis, degrees].join(','));
  const ply = fs.readFileSync(file(`exact-${k}.ply`));
  const start = ply.indexOf('end_header\n') + 'end_header\n'.length;
  const count = Number(/element vertex (\d+)/.exec(ply.subarray(0, start).toString('latin1'))[1]);
  const radiance = new Float32Array(3 * count);
  for (let v = 0; v < count; v++) for (let c = 0; c < 3; c++) radiance[3 * v + c] = ply.readFloatLE(start + v * 39 + 27 + 4 * c);
  return Buffer.from(radiance.buffer).toString('base64');
}
const references = stops.map((s, k) => exactRadiance(s.position, k));
console.log(`browser: probe-move: baked and relit in ${((Date.now() - started) / 1000).toFixed(1)} s`);

const { base, page, errors, close } = await openBrowser(chromium, { repo, out, nodeModules });

// sRGB code to linear.
const linear = (code) => { const c = code / 255; return c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4; };
// The comparison of harness.mjs, and the probe render's mean linear RGB over the covered pixels.
function compareWithMean(a, b, tolerance) {
  const mean = [0, 0, 0];
  let covered = 0;
  for (let i = 0; i < a.length; i += 4) {
    if (a[i + 3] === 0 && b[i + 3] === 0) continue;
    covered += 1;
    for (let c = 0; c < 3; c++) mean[c] += linear(b[i + c]);
  }
  return { ...compare(a, b, tolerance), mean: mean.map((m) => m / Math.max(covered, 1)) };
}

const failures = [];
const results = [];
try {
  await page.goto(`${base}/scripts/browser/probe-move.html`);
  await page.waitForFunction(() => window.prtProbeMoveReady === true);
  const render = (args) => page.evaluate((a) => window.prtProbeMove.render(a), args);
  for (const [k, stop] of stops.entries()) {
    const common = { glb: '/data/ball.glb', probes: '/data/grid.prt', light: '/data/light.json', position: stop.position, rotation };
    const reference = await render({ ...common, radiance: references[k] });
    const moved = await render(common);
    const [a, b] = [reference, moved].map((r) => Buffer.from(r.pixels, 'base64'));
    fs.writeFileSync(file(`stop-${k}-relight.rgba`), a);
    fs.writeFileSync(file(`stop-${k}-prt.rgba`), b);
    const result = compareWithMean(a, b, 4);
    results.push(result);
    const [r, g, bl] = result.mean;
    const ok = result.covered > 1000 && result.share >= 0.95;
    if (!ok) failures.push(stop.name);
    console.log(`browser: ${ok ? 'ok  ' : 'FAIL'} probe-move ${stop.name} (${stop.position.join(', ')}): ${(100 * result.share).toFixed(2)} % of ${result.covered} pixels within 4 codes of relight at an exact probe (mean difference ${result.meanDifference.toFixed(2)} codes); luminance ${(0.2126 * r + 0.7152 * g + 0.0722 * bl).toFixed(4)}, red/green ${(r / g).toFixed(3)}`);
  }
} finally {
  await close();
}
const luminance = ([r, g, b]) => 0.2126 * r + 0.7152 * g + 0.0722 * b;
const [shadow, red, green, sun] = results.map((r) => r.mean);
const darkened = luminance(shadow) / luminance(sun);
const [redRatio, greenRatio] = [red, green].map(([r, g]) => r / g);
const bleeds = redRatio > 1.05 && greenRatio < 0.99 && redRatio - greenRatio > 0.1;
console.log(`browser: ${darkened < 0.5 ? 'ok  ' : 'FAIL'} probe-move shadow: mean luminance ${darkened.toFixed(3)} of the sunlit position's`);
console.log(`browser: ${bleeds ? 'ok  ' : 'FAIL'} probe-move colour bleeding: red/green ${redRatio.toFixed(3)} by the red wall, ${greenRatio.toFixed(3)} by the green wall`);
if (darkened >= 0.5) failures.push('shadow');
if (!bleeds) failures.push('bleeding');
for (const e of errors) console.log(`browser: console error: ${e}`);
if (errors.length > 0 || failures.length > 0) {
  console.log(`browser: probe-move FAILED (${failures.join(', ') || 'no comparison'}; ${errors.length} console error(s))`);
  process.exit(1);
}
console.log(`browser: probe-move: a moving object lit from the probes matches exact probes (${((Date.now() - started) / 1000).toFixed(1)} s)`);
