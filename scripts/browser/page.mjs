// The browser test's page module: window.prtTest.render(...) loads a .glb, renders it as
// exported or relit by prt.js, and returns the canvas's RGBA pixels (base64, top row first).
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { applyPRT, lightFromGLTF, lightFromJSON, loadCompressedTransfer, loadLightmapTransfer, rotateLight } from '/runtime/three/prt.js';
import { canvas, renderer, gl, pixels } from '/scripts/browser/canvas.mjs';

async function loadGLB(url) {
  return new GLTFLoader().loadAsync(url);
}

// One camera for every render of a scene: from its bounding box, looking at its centre.
function frame(root, view, zoom = 1) {
  const box = new THREE.Box3().setFromObject(root);
  const centre = box.getCenter(new THREE.Vector3());
  const radius = box.getSize(new THREE.Vector3()).length() / 2;
  const camera = new THREE.PerspectiveCamera(40, canvas.width / canvas.height, radius / 100, radius * 10);
  const dir = new THREE.Vector3(...view).normalize();
  camera.position.copy(centre).addScaledVector(dir, (radius * 2.4) / zoom);
  camera.lookAt(centre);
  return camera;
}

// Milliseconds per frame over `frames` renders, each waited for by reading one pixel back
// (gl.finish returns before Chromium's GPU process has drawn).
function frameTime(scene, camera, frames) {
  const probe = new Uint8Array(4);
  renderer.render(scene, camera);
  gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, probe);
  const start = performance.now();
  for (let i = 0; i < frames; i++) {
    renderer.render(scene, camera);
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, probe);
  }
  return (performance.now() - start) / frames;
}

// A texel bake's export as an engine shows it: the relit lightmap (extras.prt_lightmap, on
// TEXCOORD_1) times the base colour. In three.js that is the material's lightMap, channel 1;
// MeshBasicMaterial divides a light map by π, so its intensity is π.
async function showLightmaps(gltf) {
  const meshes = [];
  gltf.scene.traverse((o) => { if (o.isMesh && o.material.userData?.prt_lightmap) meshes.push(o); });
  for (const o of meshes) {
    const slot = o.material.userData.prt_lightmap;
    const lightMap = await gltf.parser.getDependency('texture', slot.index);
    lightMap.channel = slot.texCoord;
    lightMap.colorSpace = THREE.SRGBColorSpace; // relight's PNG: sRGB-encoded
    o.material = new THREE.MeshBasicMaterial({
      color: o.material.color, map: o.material.map, lightMap, lightMapIntensity: Math.PI,
      side: o.material.side, alphaTest: o.material.alphaTest, transparent: o.material.transparent,
    });
  }
}

window.prtTest = {
  /**
   * glb: url; mode: 'exported' | 'prt' | 'basic'; light: JSON (prt-bake light --up y), or
   * 'embedded' for the rig the .glb was exported with (lightFromGLTF);
   * rotation: row-major 3×3 or null; lightmap: manifest url for texel bakes; view: [x, y, z]
   * the camera's direction from the centre; zoom: the camera that much nearer; frames: also
   * time this many frames. As exported, the sheets of doubleSided surfaces (nodes with
   * extras.prt_sheet) are drawn front faces only, as docs/reference/gltf.md asks of an engine.
   */
  async render({ glb, mode, light, rotation, lightmap, view, zoom, frames }) {
    const gltf = await loadGLB(glb);
    const scene = gltf.scene;
    const camera = frame(scene, view, zoom);
    scene.traverse((o) => {
      if (o.isMesh && o.userData.prt_sheet) o.material.side = THREE.FrontSide;
    });
    if (mode === 'exported') await showLightmaps(gltf);
    if (mode === 'prt') {
      let l = light === 'embedded' ? lightFromGLTF(gltf) : lightFromJSON(light);
      if (!l) throw new Error(`${glb}: no light in asset.extras.prt.light`);
      if (rotation) l = rotateLight(l, rotation);
      const options = { clampShading: true };
      if (lightmap) options.lightmap = await loadLightmapTransfer(lightmap);
      // A compressed bake's clusters (null for the others).
      options.cpca = await loadCompressedTransfer(gltf);
      const handle = applyPRT(gltf, l, options);
      if (handle.meshes.length === 0) throw new Error(`${glb}: no mesh carries PRT data`);
    } else if (mode === 'basic') {
      scene.traverse((o) => {
        if (o.isMesh) o.material = new THREE.MeshBasicMaterial({ color: o.material.color, map: o.material.map });
      });
    }
    renderer.render(scene, camera);
    const result = { width: canvas.width, height: canvas.height, pixels: pixels() };
    if (frames) result.ms = frameTime(scene, camera, frames);
    return result;
  },
};
/** The light a .glb carries (lightFromGLTF), as plain arrays, or null. */
window.prtTest.embeddedLight = async (glb) => {
  const l = lightFromGLTF(await loadGLB(glb));
  return l && { order: l.order, rgb: l.rgb.map((c) => Array.from(c)) };
};
window.prtReady = true;
