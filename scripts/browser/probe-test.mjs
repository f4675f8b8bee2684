// runtime/three/probes.js against the baker: a rigid object lit through a probe grid by
// `prt-bake relight --probes --at --turn` (baker/src/export/relight_rigid.rs) and by
// probeLightAt in JavaScript, from the same .prt files, must give the same radiance.
//   node scripts/browser/probe-test.mjs BAKE OUT
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const [bake, out] = process.argv.slice(2).map((p) => path.resolve(p));
const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const sh = await import(path.join(repo, 'runtime/three/sh.js'));
const probes = await import(path.join(repo, 'runtime/three/probes.js'));
const run = (...args) => execFileSync(bake, args, { stdio: ['ignore', 'ignore', 'inherit'] });
const file = (name) => path.join(out, name);
const buffer = (name) => { const b = fs.readFileSync(file(name)); return b.buffer.slice(b.byteOffset, b.byteOffset + b.length); };

// An object of two tilted white triangles, baked alone (unshadowed, order 3).
fs.writeFileSync(file('probe-object.mtl'), 'newmtl white\nKd 1 1 1\n');
fs.writeFileSync(file('probe-object.obj'), 'mtllib probe-object.mtl\nusemtl white\n'
  + 'v 0 0 0\nv 0.2 0 0.1\nv 0 0.2 0\nv 0.3 0.1 0\nvn 0.3 0 0.95\nvn -0.4 0.2 0.9\nvn 0 0.3 0.95\nvn 0.5 0.5 0.7\n'
  + 'f 1//1 2//2 3//3\nf 2//2 4//4 3//3\n');
run('bake', file('probe-object.obj'), '-o', file('probe-object.prt'), '--order', '3', '--mode', 'unshadowed', '--quiet');
// The Cornell room's interreflected probes (RGB), and a light.
const cornell = path.join(repo, 'scenes/cornell/cornell.scene');
run('bake', cornell, '-o', file('probes.prt'), '--probes', 'grid:3,3,3', '--order', '3', '--samples', '256',
  '--mode', 'interreflected', '--quiet');
const rig = path.join(repo, 'viewer/src/default-rig.toml');
run('light', rig, '--order', '3', '-o', file('probe-light.json'));
const light = sh.lightFromJSON(fs.readFileSync(file('probe-light.json'), 'utf8'));
const position = [0.3, -0.2, 0.9];
const axis = [0.2, 0.9, 0.4];
const degrees = 70;
run('relight', file('probe-object.obj'), file('probe-object.prt'), '--lights', rig, '-o', file('probe-object.ply'),
  '--probes', file('probes.prt'), '--at', position.join(','), '--turn', [...axis, degrees].join(','));

// The object's transfer (a version-1 vector file: 128-byte header, V × C × n² floats).
const object = buffer('probe-object.prt');
const view = new DataView(object);
const vertices = Number(view.getBigUint64(24, true));
const channels = view.getUint32(20, true);
const transfer = new Float32Array(object.slice(128, 128 + 4 * vertices * channels * 9));
const norm = Math.hypot(...axis);
const lit = probes.probeLightAt(probes.parseProbes(buffer('probes.prt')), position,
  sh.axisAngle(axis.map((x) => x / norm), (degrees * Math.PI) / 180), light);
// The PLY's linear radiance: 6 floats, 3 colour bytes, then the 3 radiance floats per vertex.
const ply = fs.readFileSync(file('probe-object.ply'));
const start = ply.indexOf('end_header\n') + 'end_header\n'.length;
let worst = 0;
for (let v = 0; v < vertices; v++) {
  for (let c = 0; c < 3; c++) {
    const t = transfer.subarray((v * channels + (channels === 1 ? 0 : c)) * 9, (v * channels + (channels === 1 ? 0 : c)) * 9 + 9);
    const js = t.reduce((s, x, j) => s + x * lit.rgb[c][j], 0);
    const baked = ply.readFloatLE(start + v * 39 + 27 + 4 * c);
    worst = Math.max(worst, Math.abs(js - baked) / Math.max(Math.abs(baked), 1e-3));
  }
}
const ok = worst < 1e-4 && vertices === 4;
console.log(`probe-test: ${ok ? 'ok  ' : 'FAIL'} probeLightAt = relight --probes --at --turn, ${vertices} vertices: largest relative difference ${worst.toExponential(2)}`);
if (!ok) process.exit(1);
