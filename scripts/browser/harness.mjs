// What the Chromium tests share (test.mjs, glossy.mjs, probe-move.mjs, occluder-render.mjs,
// ldprt-skinned.mjs): a loopback server for
// the repository (/), the run's output folder (/data/) and three.js (/three/); Debian's
// chromium, headless on SwiftShader with a throw-away profile, whose page may reach nothing
// but that server and collects its console errors; the pixel comparisons of two renders; and
// relight's PLY read back.
import fs from 'node:fs';
import http from 'node:http';
import os from 'node:os';
import path from 'node:path';

const TYPES = {
  '.html': 'text/html', '.js': 'text/javascript', '.mjs': 'text/javascript', '.json': 'application/json',
  '.glb': 'model/gltf-binary', '.exr': 'image/x-exr',
};

// Starts the server and the browser; `close()` stops both and removes the profile.
export async function openBrowser(chromium, { repo, out, nodeModules }) {
  const server = http.createServer((request, response) => {
    const url = decodeURIComponent(new URL(request.url, 'http://127.0.0.1').pathname);
    const [root, rest] = url.startsWith('/three/') ? [path.join(nodeModules, 'three'), url.slice(7)]
      : url.startsWith('/data/') ? [out, url.slice(6)] : [repo, url.slice(1)];
    const file = path.resolve(root, rest);
    if (!file.startsWith(root + path.sep) || !fs.existsSync(file) || !fs.statSync(file).isFile()) {
      response.writeHead(404).end();
      return;
    }
    response.writeHead(200, { 'content-type': TYPES[path.extname(file)] ?? 'application/octet-stream' });
    fs.createReadStream(file).pipe(response);
  });
  await new Promise((resolve) => server.listen(0, '127.0.0.1', resolve));
  const base = `http://127.0.0.1:${server.address().port}`;
  const userDataDir = fs.mkdtempSync(path.join(os.tmpdir(), 'prt-chromium-'));
  const context = await chromium.launchPersistentContext(userDataDir, {
    executablePath: '/usr/bin/chromium',
    headless: true,
    args: ['--headless', '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
      '--disable-background-networking', '--disable-component-update', '--disable-sync', '--no-first-run'],
  });
  const close = async () => {
    await context.close();
    server.close();
    fs.rmSync(userDataDir, { recursive: true, force: true });
  };
  try {
    const page = context.pages()[0] ?? await context.newPage();
    const errors = [];
    page.on('console', (message) => { if (message.type() === 'error') errors.push(message.text()); });
    page.on('pageerror', (error) => errors.push(String(error)));
    // Nothing but loopback.
    await page.route('**/*', (route) => (route.request().url().startsWith(base) ? route.continue() : route.abort()));
    return { base, page, errors, close };
  } catch (error) {
    await close();
    throw error;
  }
}

// Over the pixels either RGBA render covers: the share within `tolerance` codes in every
// channel, how many are covered, the worst and the mean difference in codes.
export function compare(a, b, tolerance) {
  let [covered, close, worst, sum] = [0, 0, 0, 0];
  for (let i = 0; i < a.length; i += 4) {
    if (a[i + 3] === 0 && b[i + 3] === 0) continue;
    covered += 1;
    const d = Math.max(Math.abs(a[i] - b[i]), Math.abs(a[i + 1] - b[i + 1]), Math.abs(a[i + 2] - b[i + 2]), Math.abs(a[i + 3] - b[i + 3]));
    worst = Math.max(worst, d);
    sum += d;
    if (d <= tolerance) close += 1;
  }
  return { share: covered ? close / covered : 0, covered, worst, meanDifference: sum / Math.max(covered, 1) };
}

// Over the reference's lit pixels (covered and not near black): the share within `tolerance`
// codes in every channel, how many are lit, and the worst difference.
export function compareLit(a, b, tolerance) {
  let [lit, close, worst] = [0, 0, 0];
  for (let i = 0; i < a.length; i += 4) {
    if (a[i + 3] === 0 || Math.max(a[i], a[i + 1], a[i + 2]) < 8) continue;
    lit += 1;
    const d = Math.max(Math.abs(a[i] - b[i]), Math.abs(a[i + 1] - b[i + 1]), Math.abs(a[i + 2] - b[i + 2]));
    worst = Math.max(worst, d);
    if (d <= tolerance) close += 1;
  }
  return { share: lit ? close / lit : 0, lit, worst };
}

// A relight PLY's positions, normals and radiance (6 floats, 3 colour bytes, 3 floats per vertex).
export function readPly(filePath) {
  const ply = fs.readFileSync(filePath);
  const start = ply.indexOf('end_header\n') + 'end_header\n'.length;
  const count = Number(/element vertex (\d+)/.exec(ply.subarray(0, start).toString('latin1'))[1]);
  const [positions, normals, radiance] = [0, 1, 2].map(() => new Float32Array(3 * count));
  for (let v = 0; v < count; v++) for (let k = 0; k < 3; k++) {
    positions[3 * v + k] = ply.readFloatLE(start + v * 39 + 4 * k);
    normals[3 * v + k] = ply.readFloatLE(start + v * 39 + 12 + 4 * k);
    radiance[3 * v + k] = ply.readFloatLE(start + v * 39 + 27 + 4 * k);
  }
  return { positions, normals, radiance };
}
