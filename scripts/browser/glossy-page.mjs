// The glossy browser test's page module: window.prtGlossy.render(...) loads a glossy .glb
// (a CPCA-compressed transfer-matrix export) and renders it relit by prt.js from a camera, or
// with its vertices coloured by given radiances (prt-bake relight --view's), and returns the
// RGBA pixels (base64, top row first) and the camera's position in the file's frame.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { applyPRT, lightFromGLTF, loadCompressedTransfer } from '/runtime/three/prt.js';
import { canvas, renderer, gl, pixels } from '/scripts/browser/canvas.mjs';

// The camera: from the scene's bounding box, `distance` radii from its centre along `view`.
function frame(root, view, distance) {
  const box = new THREE.Box3().setFromObject(root);
  const centre = box.getCenter(new THREE.Vector3());
  const radius = box.getSize(new THREE.Vector3()).length() / 2;
  const camera = new THREE.PerspectiveCamera(40, canvas.width / canvas.height, radius / 100, radius * 10);
  camera.position.copy(centre).addScaledVector(new THREE.Vector3(...view).normalize(), radius * distance);
  camera.lookAt(centre);
  return camera;
}

// Colours every mesh's vertices with `radiance` (linear RGB floats of the whole scene, in the
// exporter's vertex order: mesh i is scene object i, its vertices after those of meshes < i).
function colourWith(gltf, radiance) {
  const json = gltf.parser.json;
  const offsets = [0];
  for (const mesh of json.meshes) offsets.push(offsets.at(-1) + json.accessors[mesh.primitives[0].attributes.POSITION].count);
  if (offsets.at(-1) * 3 !== radiance.length) throw new Error(`${offsets.at(-1)} vertices in the .glb, ${radiance.length / 3} radiances`);
  gltf.scene.traverse((object) => {
    if (!object.isMesh) return;
    const index = gltf.parser.associations.get(object)?.meshes;
    if (!Number.isInteger(index)) throw new Error(`mesh '${object.name}': no glTF mesh index`);
    const count = object.geometry.attributes.position.count;
    const colours = radiance.subarray(3 * offsets[index], 3 * (offsets[index] + count));
    object.geometry.setAttribute('color', new THREE.BufferAttribute(new Float32Array(colours), 3));
    object.material = new THREE.MeshBasicMaterial({ vertexColors: true });
  });
}

window.prtGlossy = {
  /**
   * glb: url; view: [x, y, z] the camera's direction from the centre (file frame), distance
   * in bounding radii; radiance: base64 of float32 RGB per vertex to render instead of prt.js.
   * Returns { pixels, camera: [x, y, z] }, and with `frames` the mean frame time.
   */
  async render({ glb, view, distance, radiance, frames }) {
    const gltf = await new GLTFLoader().loadAsync(glb);
    const camera = frame(gltf.scene, view, distance);
    if (radiance) {
      const bytes = Uint8Array.from(atob(radiance), (ch) => ch.charCodeAt(0));
      colourWith(gltf, new Float32Array(bytes.buffer));
    } else {
      const cpca = await loadCompressedTransfer(gltf);
      if (cpca?.transfer !== 'matrix') throw new Error(`${glb}: not a glossy (transfer-matrix) export`);
      const handle = applyPRT(gltf, lightFromGLTF(gltf), { cpca });
      if (handle.meshes.length === 0) throw new Error(`${glb}: no mesh carries PRT data`);
    }
    renderer.render(gltf.scene, camera);
    const result = { pixels: pixels(), camera: camera.position.toArray() };
    if (frames) {
      const probe = new Uint8Array(4);
      const start = performance.now();
      for (let i = 0; i < frames; i++) {
        renderer.render(gltf.scene, camera);
        gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, probe);
      }
      result.ms = (performance.now() - start) / frames;
    }
    return result;
  },
};
window.prtGlossyReady = true;
