// runtime/three/occluders.js against the baker: the Cornell room's vertex bake darkened by two
// moving balls (one turned) by `prt-bake relight --occluder --at --turn`
// (baker/src/export/relight_occluded.rs) and by occludedTransfer in JavaScript, from the same
// .prt and occluder files, must give the same radiance. Fails if the occluders are dropped.
//   node scripts/browser/occluder-test.mjs BAKE OUT
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const [bake, out] = process.argv.slice(2).map((p) => path.resolve(p));
const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const sh = await import(path.join(repo, 'runtime/three/sh.js'));
const occ = await import(path.join(repo, 'runtime/three/occluders.js'));
const run = (...args) => execFileSync(bake, args, { stdio: ['ignore', 'ignore', 'inherit'] });
const file = (name) => path.join(out, name);
const buffer = (name) => { const b = fs.readFileSync(file(name)); return b.buffer.slice(b.byteOffset, b.byteOffset + b.length); };

// A ball of radius 0.2 about the origin, and its occluder file of 3 spheres (off its centre, so
// the turns matter).
let obj = 'o ball\n';
const [rings, segments] = [12, 24];
for (let i = 0; i <= rings; i++) for (let j = 0; j < segments; j++) {
  const [t, p] = [(Math.PI * i) / rings, (2 * Math.PI * j) / segments];
  obj += `v ${0.2 * Math.sin(t) * Math.cos(p)} ${0.2 * Math.sin(t) * Math.sin(p)} ${0.2 * Math.cos(t)}\n`;
}
const at = (i, j) => i * segments + (j % segments) + 1;
for (let i = 0; i < rings; i++) for (let j = 0; j < segments; j++) {
  obj += `f ${at(i, j)} ${at(i + 1, j)} ${at(i + 1, j + 1)}\nf ${at(i, j)} ${at(i + 1, j + 1)} ${at(i, j + 1)}\n`;
}
fs.writeFileSync(file('occ-ball.obj'), obj);
run('bake', file('occ-ball.obj'), '--occluder', '--spheres', '3', '-o', file('occ-ball.occ'));
const cornell = path.join(repo, 'scenes/cornell/cornell.scene');
run('bake', cornell, '-o', file('occ-room.prt'), '--samples', '128', '--quiet');
const rig = path.join(repo, 'viewer/src/default-rig.toml');
run('light', rig, '--order', '4', '-o', file('occ-light.json'));
const light = sh.lightFromJSON(fs.readFileSync(file('occ-light.json'), 'utf8'));
const places = [[-0.5, -0.55, 0.22], [0.55, 0.5, 0.22]];
// Only the second group is turned: its --turn must not go to the first.
const turns = [[0, 0, 1, 0], [1, 0, 0, 90]];
for (const [name, extra] of [['occ-plain.ply', []], ['occ-shadowed.ply', places.flatMap((p, k) =>
  ['--occluder', file('occ-ball.occ'), '--at', p.join(','), ...(k === 1 ? ['--turn', turns[k].join(',')] : [])])]]) {
  run('relight', cornell, file('occ-room.prt'), '--lights', rig, '-o', file(name), ...extra);
}

// The room's transfer (a version-1 vector file: 128-byte header, V × C × 16 floats).
const room = buffer('occ-room.prt');
const view = new DataView(room);
const vertices = Number(view.getBigUint64(24, true));
const channels = view.getUint32(20, true);
const transfer = new Float32Array(room.slice(128, 128 + 4 * vertices * channels * 16));
// Positions and normals from the PLY: 6 floats, 3 colour bytes, 3 radiance floats per vertex.
const ply = (name) => { const b = fs.readFileSync(file(name)); return [b, b.indexOf('end_header\n') + 'end_header\n'.length]; };
const [plain, p0] = ply('occ-plain.ply');
const [shadowed, s0] = ply('occ-shadowed.ply');
const positions = new Float32Array(3 * vertices);
const normals = new Float32Array(3 * vertices);
for (let v = 0; v < vertices; v++) for (let k = 0; k < 3; k++) {
  positions[3 * v + k] = plain.readFloatLE(p0 + v * 39 + 4 * k);
  normals[3 * v + k] = plain.readFloatLE(p0 + v * 39 + 12 + 4 * k);
}
const ball = occ.parseOccluder(buffer('occ-ball.occ'));
const spheres = places.flatMap((p, k) => {
  const [x, y, z, deg] = turns[k];
  return occ.placeOccluder(ball, p, sh.axisAngle([x, y, z], (deg * Math.PI) / 180));
});
const check = (dark, what) => {
  let worst = 0;
  let darkened = 0;
  for (let v = 0; v < vertices; v++) for (let c = 0; c < 3; c++) {
    const t = (tr) => tr.subarray((v * channels + (channels === 1 ? 0 : c)) * 16, (v * channels + (channels === 1 ? 0 : c)) * 16 + 16);
    const dot = (tr) => t(tr).reduce((s, x, j) => s + x * light.rgb[c][j], 0);
    const lit = dot(transfer);
    if (Math.abs(lit) < 1e-3) continue;
    const albedo = plain.readFloatLE(p0 + v * 39 + 27 + 4 * c) / lit;
    const js = albedo * dot(dark);
    const baked = shadowed.readFloatLE(s0 + v * 39 + 27 + 4 * c);
    if (baked < plain.readFloatLE(p0 + v * 39 + 27 + 4 * c) - 1e-3) darkened++;
    worst = Math.max(worst, Math.abs(js - baked) / Math.max(Math.abs(baked), 1e-2));
  }
  const ok = worst < 1e-3 && darkened > 100;
  console.log(`occluder-test: ${ok ? 'ok  ' : 'FAIL'} ${what}: ${darkened} receiver channels darkened, largest relative difference ${worst.toExponential(2)}`);
  return ok;
};
const ok = check(occ.occludedTransfer(transfer, channels, 4, positions, normals, spheres),
  'occludedTransfer = relight --occluder --at [--turn] (two 3-sphere balls, the second turned)');
// The test must fail without the occluders.
const off = check(transfer, 'without occluders (expected to FAIL)');
if (!ok || off) process.exit(1);
