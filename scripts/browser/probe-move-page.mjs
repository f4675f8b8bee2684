// The moving-object browser test's page module: window.prtProbeMove.render(...) places a rigid
// PRT object (its own bake, exported to .glb) at a position and rotation in the probes' scene
// and renders it lit by prt.js from the probes (probeLightForObject, as a moving mesh is lit
// each frame), or with its vertices coloured by given radiances (prt-bake relight --probes
// --at --turn's), from a camera that keeps the same place relative to the object. Returns the
// RGBA pixels (base64, top row first).
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { applyPRT, lightFromJSON, loadProbes, probeLightForObject, Z_UP_TO_GLTF } from '/runtime/three/prt.js';
import { canvas, renderer, pixels } from '/scripts/browser/canvas.mjs';

// A row-major 3×3 as a THREE.Matrix4.
const matrix4 = (m) => new THREE.Matrix4().set(m[0], m[1], m[2], 0, m[3], m[4], m[5], 0, m[6], m[7], m[8], 0, 0, 0, 0, 1);
const C = matrix4(Z_UP_TO_GLTF);

window.prtProbeMove = {
  /**
   * glb, probes, light: urls (the object's export, the probe bake, `prt-bake light`'s JSON of
   * the probes' scene frame); position [x, y, z] and rotation (row-major 3×3, object to
   * scene) in the probes' scene frame (z up); radiance: base64 of float32 RGB per vertex to
   * render instead of prt.js.
   */
  async render({ glb, probes, light, position, rotation, radiance }) {
    const gltf = await new GLTFLoader().loadAsync(glb);
    const root = gltf.scene;
    // The object's place in three's world (glTF's frame: the z-up scene turned by C).
    const turn = C.clone().multiply(matrix4(rotation)).multiply(C.clone().transpose());
    root.quaternion.setFromRotationMatrix(turn);
    root.position.set(...position).applyMatrix4(C);
    const world = new THREE.Scene();
    world.add(root);
    if (radiance) {
      const bytes = Uint8Array.from(atob(radiance), (ch) => ch.charCodeAt(0));
      const colours = new Float32Array(bytes.buffer);
      root.traverse((object) => {
        if (!object.isMesh) return;
        if (object.geometry.attributes.position.count * 3 !== colours.length) throw new Error('vertex count');
        object.geometry.setAttribute('color', new THREE.BufferAttribute(colours, 3));
        object.material = new THREE.MeshBasicMaterial({ vertexColors: true });
      });
    } else {
      const [field, json] = await Promise.all([loadProbes(probes), fetch(light).then((r) => r.text())]);
      const sceneLight = lightFromJSON(json);
      const handle = applyPRT(gltf, sceneLight);
      if (handle.meshes.length !== 1) throw new Error(`${glb}: ${handle.meshes.length} PRT meshes, not 1`);
      handle.setLight(probeLightForObject(field, handle.meshes[0], sceneLight));
    }
    const camera = new THREE.PerspectiveCamera(30, canvas.width / canvas.height, 0.01, 10);
    camera.position.copy(root.position).add(new THREE.Vector3(0, 0.15, 0.5));
    camera.lookAt(root.position);
    renderer.render(world, camera);
    return { pixels: pixels() };
  },
};
window.prtProbeMoveReady = true;
