// The skinned LDPRT browser test (make browser; docs/guides/characters.md, "In three.js"): the
// skinned tube (scenes/tube/tube-skinned.glb) baked as LDPRT at rest (order 4, 3 lobes; grey
// shadowed and RGB interreflected), exported to a skinned .glb, posed in Chromium by three's
// AnimationMixer at `bend` 0, 0.5 and 1 s and lit by runtime/three/ldprt.js. Each frame must
// match the same .glb at the same time coloured with `prt-bake relight --pose bend@T`'s
// radiance: at least 99 % of the lit pixels (a code of 8 or more in the reference) within 2
// codes; so must the grey 0.5 s frame with the tube's root, the camera and the light (by
// setLight and sh.js's rotateLight) all turned 70° about an oblique axis. The 1 s render
// against the 0 s reference must miss that bound (the pose matters). And directly against
// prt-view: its headless screenshots of the grey bake at 0, 0.5 and 1 s and three.js's render
// through the same camera, at least 99 % of the pixels inside both silhouettes within 2 codes.
//
//   node scripts/browser/ldprt-skinned.mjs NODE_MODULES BAKE OUT
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { compareLit, openBrowser, readPly } from './harness.mjs';

const [nodeModules, bake, outRoot] = process.argv.slice(2).map((p) => path.resolve(p));
const out = path.join(outRoot, 'ldprt-skinned');
const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const { chromium } = await import(path.join(nodeModules, 'playwright-core/index.mjs'));
const sh = await import(path.join(repo, 'runtime/three/sh.js'));
fs.mkdirSync(out, { recursive: true });
const run = (...args) => execFileSync(bake, args, { stdio: ['ignore', 'ignore', 'inherit'] });
const file = (name) => path.join(out, name);
const started = Date.now();

// The tube with a base colour (a primitive without a material is white in glTF and three.js,
// but the baker's default albedo is 0.8): a copy whose JSON chunk names one material.
function withMaterial(source, target, baseColorFactor) {
  const glb = fs.readFileSync(source);
  const jsonLength = glb.readUInt32LE(12);
  const json = JSON.parse(glb.subarray(20, 20 + jsonLength).toString('utf8'));
  json.materials = [{ name: 'tube', pbrMetallicRoughness: { baseColorFactor, metallicFactor: 0 } }];
  for (const mesh of json.meshes) for (const primitive of mesh.primitives) primitive.material = 0;
  let text = JSON.stringify(json);
  text += ' '.repeat((4 - (text.length % 4)) % 4);
  const header = Buffer.alloc(20);
  const rest = glb.subarray(20 + jsonLength);
  header.write('glTF', 0, 'latin1');
  header.writeUInt32LE(2, 4);
  header.writeUInt32LE(20 + text.length + rest.length, 8);
  header.writeUInt32LE(text.length, 12);
  header.writeUInt32LE(0x4e4f534a, 16);
  fs.writeFileSync(target, Buffer.concat([header, Buffer.from(text, 'utf8'), rest]));
}
const tube = file('tube.glb');
withMaterial(path.join(repo, 'scenes/tube/tube-skinned.glb'), tube, [0.9, 0.7, 0.5, 1]);
const rig = path.join(repo, 'viewer/src/default-rig.toml');
run('light', rig, '--order', '4', '--up', 'y', '-o', file('light.json'));
const cases = [
  { name: 'grey', mode: 'shadowed', samples: '64', times: [0, 0.5, 1] },
  { name: 'rgb', mode: 'interreflected', samples: '32', times: [0.5] },
];
for (const c of cases) {
  run('bake', tube, '-o', file(`${c.name}.ldprt`), '--transfer', 'ldprt', '--lobes', '3', '--order', '4',
    '--mode', c.mode, '--samples', c.samples, '--seed', '1', '--quiet');
  run('export', file(`${c.name}.ldprt`), '--scene', tube, '--glb', file(`${c.name}.glb`));
  for (const t of c.times) run('relight', tube, file(`${c.name}.ldprt`), '--pose', `bend@${t}`, '--lights', rig, '-o', file(`${c.name}-${t}.ply`));
}

console.log(`browser: ldprt-skinned: baked, exported and relit in ${((Date.now() - started) / 1000).toFixed(1)} s`);


// prt-view's camera for the direct comparison (z-up: X,Y,Z,YAW,PITCH, 50° vertical field of
// view, up +z), and the same camera in the glTF's y-up frame, (x, y, z) -> (x, z, -y).
const prtView = path.join(path.dirname(bake), 'prt-view');
const VIEW = (() => {
  const [x, y, z, yaw, pitch] = [1.2, -1.6, 3.6, 146.31, -73.28];
  const [cy, sy, cp, sp] = [Math.cos((yaw * Math.PI) / 180), Math.sin((yaw * Math.PI) / 180), Math.cos((pitch * Math.PI) / 180), Math.sin((pitch * Math.PI) / 180)];
  const forward = [cp * cy, cp * sy, sp];
  const gltf = (v) => [v[0], v[2], -v[1]];
  return { argument: [x, y, z, yaw, pitch].join(','), three: { position: gltf([x, y, z]), forward: gltf(forward), up: [0, 1, 0], fov: 50 } };
})();
// Pixels covered in both images (three.js: alpha 255; prt-view: not its background, the
// corner pixel) and whose four neighbours are too: the rasterisers' silhouette edges, where
// one may cover a pixel the other does not, are left out (eroded by one pixel).
function compareInterior(viewer, three, width, height, tolerance) {
  const background = viewer.subarray(0, 3);
  const covered = (i) => three[4 * i + 3] === 255 && [0, 1, 2].some((c) => viewer[4 * i + c] !== background[c]);
  let [count, close, worst] = [0, 0, 0];
  for (let y = 1; y < height - 1; y++) for (let x = 1; x < width - 1; x++) {
    const i = y * width + x;
    if (![i, i - 1, i + 1, i - width, i + width].every(covered)) continue;
    count += 1;
    const d = Math.max(...[0, 1, 2].map((c) => Math.abs(viewer[4 * i + c] - three[4 * i + c])));
    worst = Math.max(worst, d);
    if (d <= tolerance) close += 1;
  }
  return { share: count ? close / count : 0, count, worst };
}

const { base, page, errors, close } = await openBrowser(chromium, { repo, out, nodeModules });
const results = [];
const direct = [];
let poseMatters;
try {
  await page.goto(`${base}/scripts/browser/ldprt.html`);
  await page.waitForFunction(() => window.prtLdprtReady === true);
  const render = (args) => page.evaluate((a) => window.prtLdprt.render(a), args);
  for (const c of cases) {
    const glb = `/data/${c.name}.glb`;
    const frames = {};
    for (const time of c.times) {
      const want = await render({ glb, time, radiance: Buffer.from(readPly(file(`${c.name}-${time}.ply`)).radiance.buffer).toString('base64') });
      const got = await render({ glb, time, light: '/data/light.json' });
      const [a, b] = [want, got].map((r) => Buffer.from(r.pixels, 'base64'));
      fs.writeFileSync(file(`${c.name}-${time}-relight.rgba`), a);
      fs.writeFileSync(file(`${c.name}-${time}-ldprt.rgba`), b);
      frames[time] = { a, b };
      results.push({ name: `${c.name} bend@${time}`, ...compareLit(a, b, 2), skinned: got.skinned, attributes: got.attributes });
      if (c.name === 'grey' && time === 0.5) {
        const n = Math.hypot(1, 2, 3);
        const turn = sh.axisAngle([1 / n, 2 / n, 3 / n], (70 * Math.PI) / 180);
        const turned = await render({ glb, time, light: '/data/light.json', turn });
        const t = Buffer.from(turned.pixels, 'base64');
        fs.writeFileSync(file('grey-0.5-turned.rgba'), t);
        results.push({ name: 'grey bend@0.5, all turned 70°', ...compareLit(a, t, 2), skinned: turned.skinned, attributes: turned.attributes });
      }
    }
    if (frames[0] && frames[1]) poseMatters = compareLit(frames[0].a, frames[1].b, 2);
  }
  // Against prt-view directly: its headless screenshots of the grey bake and three.js's
  // render through the same camera, pixel for pixel.
  for (const time of [0, 0.5, 1]) {
    const png = file(`view-${time}.png`);
    execFileSync(prtView, [tube, file('grey.ldprt'), '--pose', `bend@${time}`, '--lights', rig, '--camera', VIEW.argument,
      '--size', '256x256', '--headless', '--screenshot', png], { stdio: ['ignore', 'ignore', 'ignore'] });
    const viewer = Buffer.from(await page.evaluate((u) => window.prtLdprt.image(u), `/data/view-${time}.png`), 'base64');
    const three = Buffer.from((await render({ glb: '/data/grey.glb', time, light: '/data/light.json', view: VIEW.three })).pixels, 'base64');
    fs.writeFileSync(file(`view-${time}-three.rgba`), three);
    direct.push({ time, ...compareInterior(viewer, three, 256, 256, 2) });
  }
} finally {
  await close();
}
let ok = errors.length === 0;
for (const r of results) {
  const good = r.lit > 3000 && r.share >= 0.99 && r.skinned === 1 && r.attributes.length <= 4;
  ok &&= good;
  console.log(`browser: ${good ? 'ok  ' : 'FAIL'} ldprt-skinned ${r.name}: ${(100 * r.share).toFixed(2)} % of ${r.lit} lit pixels within 2 codes of relight --pose (worst ${r.worst}; vertex attributes ${r.attributes.join(' ')})`);
}
for (const r of direct) {
  const good = r.count > 3000 && r.share >= 0.99;
  ok &&= good;
  console.log(`browser: ${good ? 'ok  ' : 'FAIL'} ldprt-skinned three.js against prt-view at bend@${r.time}: ${(100 * r.share).toFixed(2)} % of ${r.count} pixels inside the silhouette within 2 codes (worst ${r.worst})`);
}
const differs = poseMatters && poseMatters.share < 0.99;
ok &&= differs;
console.log(`browser: ${differs ? 'ok  ' : 'FAIL'} ldprt-skinned bend@1 against the bend@0 reference: ${(100 * (poseMatters?.share ?? 1)).toFixed(2)} % within 2 codes (must be under 99 %)`);
for (const e of errors) console.log(`browser: console error: ${e}`);
if (!ok) {
  console.log('browser: ldprt-skinned FAILED');
  process.exit(1);
}
console.log(`browser: ldprt-skinned: ldprt.js on a SkinnedMesh matches relight --pose (${((Date.now() - started) / 1000).toFixed(1)} s)`);
