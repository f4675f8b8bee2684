// The skinned LDPRT browser test's page module: window.prtLdprt.render(...) loads the tube's
// LDPRT export (a SkinnedMesh with its `bend` animation), sets an AnimationMixer to a time,
// and draws it either lit by runtime/three/ldprt.js or with its vertices coloured by given
// radiances (prt-bake relight --pose's PLY, in the .glb's vertex order). Returns the RGBA
// pixels (base64, top row first).
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { lightFromJSON, rotateLight } from '/runtime/three/prt.js';
import { applyLDPRT } from '/runtime/three/ldprt.js';
import { canvas, renderer, gl, pixels, floats } from '/scripts/browser/canvas.mjs';

window.prtLdprt = {
  /**
   * glb, light: urls (the LDPRT export, `prt-bake light --up y`'s JSON); time: seconds of the
   * first animation; radiance (optional): base64 float32 RGB per vertex to draw instead;
   * turn (optional): a row-major 3×3 rotation applied to the scene's root, the camera and
   * (by setLight after the material is made) the light, which must leave the picture as it was;
   * view (optional): { position, forward, up, fov } of prt-view's camera in the glTF's frame.
   */
  async render({ glb, light, time, radiance, turn, view }) {
    const gltf = await new GLTFLoader().loadAsync(glb);
    const world = new THREE.Scene();
    const R = turn ? new THREE.Matrix4().set(turn[0], turn[1], turn[2], 0, turn[3], turn[4], turn[5], 0, turn[6], turn[7], turn[8], 0, 0, 0, 0, 1) : new THREE.Matrix4();
    gltf.scene.quaternion.setFromRotationMatrix(R);
    world.add(gltf.scene);
    const mixer = new THREE.AnimationMixer(gltf.scene);
    const action = mixer.clipAction(gltf.animations[0]);
    // Held at the end, not wrapped to 0, at time = duration.
    action.setLoop(THREE.LoopOnce, 1);
    action.clampWhenFinished = true;
    action.play();
    mixer.setTime(time);
    let skinned = 0;
    let attributes = [];
    let key = '';
    if (radiance) {
      const colours = floats(radiance);
      gltf.scene.traverse((object) => {
        if (!object.isMesh) return;
        if (object.geometry.attributes.position.count * 3 !== colours.length) throw new Error(`${glb}: vertex count differs from the PLY's`);
        object.geometry.setAttribute('color', new THREE.BufferAttribute(colours, 3));
        object.material = new THREE.MeshBasicMaterial({ vertexColors: true });
      });
    } else {
      const sceneLight = lightFromJSON(await fetch(light).then((r) => r.text()));
      const handle = applyLDPRT(gltf, sceneLight);
      if (turn) handle.setLight(rotateLight(sceneLight, turn));
      if (handle.meshes.length !== 1) throw new Error(`${glb}: ${handle.meshes.length} LDPRT meshes, not 1`);
      skinned = handle.meshes.filter((m) => m.isSkinnedMesh).length;
      key = handle.meshes[0].material.customProgramCacheKey();
    }
    const camera = new THREE.PerspectiveCamera(view ? view.fov : 45, canvas.width / canvas.height, 0.05, 20);
    if (view) {
      // prt-view's camera (--camera), given in the glTF's frame.
      camera.position.set(...view.position);
      camera.up.set(...view.up);
      camera.lookAt(new THREE.Vector3(...view.position).add(new THREE.Vector3(...view.forward)));
    } else {
      camera.position.set(1.2, 3.6, 1.6).applyMatrix4(R);
      camera.up.set(0, 0, 1).applyMatrix4(R);
      camera.lookAt(new THREE.Vector3(0.3, 0, 1.0).applyMatrix4(R));
    }
    renderer.render(world, camera);
    if (!radiance) {
      // The program's active vertex attributes (the lobes are in a texture: three).
      const program = renderer.info.programs.find((p) => p.cacheKey.includes(key));
      if (program) {
        const count = gl.getProgramParameter(program.program, gl.ACTIVE_ATTRIBUTES);
        attributes = Array.from({ length: count }, (_, i) => gl.getActiveAttrib(program.program, i).name);
      }
    }
    return { pixels: pixels(), skinned, attributes };
  },
};
// A PNG (prt-view's screenshot) decoded by the browser: RGBA, top row first, as base64.
window.prtLdprt.image = async (url) => {
  const bitmap = await createImageBitmap(await fetch(url).then((r) => r.blob()), { colorSpaceConversion: 'none', premultiplyAlpha: 'none' });
  const context = new OffscreenCanvas(bitmap.width, bitmap.height).getContext('2d');
  context.drawImage(bitmap, 0, 0);
  const data = context.getImageData(0, 0, bitmap.width, bitmap.height).data;
  let text = '';
  for (let i = 0; i < data.length; i += 0x8000) text += String.fromCharCode(...data.subarray(i, i + 0x8000));
  return btoa(text);
};
window.prtLdprtReady = true;
