// Compiles every ```glsl block of docs/reference/gltf.md with glslangValidator (Debian glslang-tools):
// a block with gl_Position is a vertex shader, any other a fragment shader; each must be
// GLSL ES 3.00 (#version 300 es). Any error fails.
//   node scripts/browser/glsl-snippets.mjs DOC OUT
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';

const [doc, out] = process.argv.slice(2);
const text = fs.readFileSync(doc, 'utf8');
const blocks = [...text.matchAll(/^```glsl\n([\s\S]*?)^```$/gm)].map((m) => m[1]);
if (blocks.length === 0) {
  console.log(`glsl-snippets: ${doc}: no \`\`\`glsl block`);
  process.exit(1);
}
fs.mkdirSync(out, { recursive: true });
let failed = 0;
blocks.forEach((source, i) => {
  const stage = source.includes('gl_Position') ? 'vert' : 'frag';
  // WebGL 2 is the target: desktop GLSL (#version 330 core) accepts what GLSL ES refuses.
  if (!source.startsWith('#version 300 es\n')) {
    failed += 1;
    console.log(`glsl-snippets: FAIL ${doc} block ${i + 1}: the first line must be #version 300 es (WebGL 2)`);
    return;
  }
  const file = path.join(out, `snippet-${i}.${stage}`);
  fs.writeFileSync(file, source);
  const result = spawnSync('glslangValidator', [file], { encoding: 'utf8' });
  const ok = result.status === 0;
  failed += ok ? 0 : 1;
  console.log(`glsl-snippets: ${ok ? 'ok  ' : 'FAIL'} ${doc} block ${i + 1} (${stage}, ${source.split('\n')[0]})`);
  if (!ok) console.log((result.stdout + result.stderr).trim());
});
process.exit(failed ? 1 : 0);
