// The moving-occluder browser test's page module: window.prtOccluder.render(...) draws the
// Cornell room's .glb export either relit by prt.js with each mesh's transfer darkened by
// occluders.js's occludedTransfer for the given occluder places, or with its vertices
// coloured by given radiances (prt-bake relight --occluder's, matched to the mesh's vertices
// by position and normal). Returns the RGBA pixels (base64, top row first).
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { applyPRT, lightFromJSON, loadProbes, probeLightForObject, Z_UP_TO_GLTF, GLTF_TO_Z_UP } from '/runtime/three/prt.js';
import { parseOccluder, occluderSpheresForObject, occludedTransfer } from '/runtime/three/occluders.js';
import { canvas, renderer, pixels, floats } from '/scripts/browser/canvas.mjs';

const zUp = (v) => [0, 1, 2].map((i) => GLTF_TO_Z_UP[3 * i] * v[0] + GLTF_TO_Z_UP[3 * i + 1] * v[1] + GLTF_TO_Z_UP[3 * i + 2] * v[2]);
// A vertex's key: its z-up position and normal, rounded.
const key = (p, n) => [...p, ...n].map((x) => Math.round(x * 1e4)).join(',');

// A row-major 3×3 as a THREE.Matrix4, and glTF's frame from the z-up scene's.
const matrix4 = (m) => new THREE.Matrix4().set(m[0], m[1], m[2], 0, m[3], m[4], m[5], 0, m[6], m[7], m[8], 0, 0, 0, 0, 1);
const C = matrix4(Z_UP_TO_GLTF);

// A mesh's vertices in three's world (the .glb's frame, +Y up; `turn` maps them to another):
// positions and normals, 3 floats each.
function worldVertices(object, turn = (v) => v) {
  object.updateWorldMatrix(true, false);
  const normalMatrix = new THREE.Matrix3().getNormalMatrix(object.matrixWorld);
  const { position, normal } = object.geometry.attributes;
  const positions = new Float32Array(3 * position.count);
  const normals = new Float32Array(3 * position.count);
  for (let v = 0; v < position.count; v++) {
    const p = new THREE.Vector3().fromBufferAttribute(position, v).applyMatrix4(object.matrixWorld);
    const n = new THREE.Vector3().fromBufferAttribute(normal, v).applyMatrix3(normalMatrix).normalize();
    positions.set(turn(p.toArray()), 3 * v);
    normals.set(turn(n.toArray()), 3 * v);
  }
  return { positions, normals };
}

window.prtOccluder = {
  /**
   * glb, light, occluder: urls (the room's export, `prt-bake light`'s JSON in its scene frame,
   * the occluder file); places: [{ position, rotation }] in the z-up scene frame (rotation a
   * row-major 3×3); reference: base64 float32 positions, normals and RGB radiance per PLY
   * vertex, to draw instead of prt.js. mover (optional): { glb, probes, light } urls (the
   * ball's own export, the room's probe grid, `prt-bake light`'s JSON in the z-up frame) and
   * `radiance` (base64 float32 RGB per vertex, relight --probes --at --turn's) or none: the
   * ball is drawn at places[mover.at], lit by prt.js from the probes (probeLightForObject)
   * and, with the others, shadowing the room from where three.js put it (unless `shadow` is
   * false).
   */
  async render({ glb, light, occluder, places, reference, mover, shadow = true }) {
    const gltf = await new GLTFLoader().loadAsync(glb);
    const world = new THREE.Scene();
    world.add(gltf.scene);
    let darkened = 0;
    // Each place as three.js holds an object there (the z-up scene turned by C); the mover's
    // own .glb at its place.
    const holders = (places ?? []).map(({ position, rotation }) => {
      const holder = new THREE.Object3D();
      holder.quaternion.setFromRotationMatrix(C.clone().multiply(matrix4(rotation)).multiply(C.clone().transpose()));
      holder.position.set(...position).applyMatrix4(C);
      return holder;
    });
    if (mover) {
      const ball = await new GLTFLoader().loadAsync(mover.glb);
      const root = ball.scene;
      root.quaternion.copy(holders[mover.at].quaternion);
      root.position.copy(holders[mover.at].position);
      holders[mover.at] = root;
      world.add(root);
      if (mover.radiance) {
        const colours = floats(mover.radiance);
        root.traverse((object) => {
          if (!object.isMesh) return;
          if (object.geometry.attributes.position.count * 3 !== colours.length) throw new Error('mover vertex count');
          object.geometry.setAttribute('color', new THREE.BufferAttribute(colours, 3));
          object.material = new THREE.MeshBasicMaterial({ vertexColors: true });
        });
      } else {
        const [field, json] = await Promise.all([loadProbes(mover.probes), fetch(mover.light).then((r) => r.text())]);
        const probeLight = lightFromJSON(json);
        const handle = applyPRT(ball, probeLight);
        if (handle.meshes.length !== 1) throw new Error(`${mover.glb}: ${handle.meshes.length} PRT meshes, not 1`);
        handle.setLight(probeLightForObject(field, handle.meshes[0], probeLight));
      }
    }
    if (reference) {
      const [positions, normals, radiance] = ['positions', 'normals', 'radiance'].map((k) => floats(reference[k]));
      const index = new Map();
      for (let v = 0; v < positions.length / 3; v++) {
        index.set(key(positions.subarray(3 * v, 3 * v + 3), normals.subarray(3 * v, 3 * v + 3)), v);
      }
      gltf.scene.traverse((object) => {
        if (!object.isMesh) return;
        const mine = worldVertices(object, zUp);
        const colours = new Float32Array(mine.positions.length);
        for (let v = 0; v < colours.length / 3; v++) {
          const at = index.get(key(mine.positions.subarray(3 * v, 3 * v + 3), mine.normals.subarray(3 * v, 3 * v + 3)));
          if (at === undefined) throw new Error(`mesh '${object.name}': vertex ${v} is not in the PLY`);
          colours.set(radiance.subarray(3 * at, 3 * at + 3), 3 * v);
        }
        object.geometry.setAttribute('color', new THREE.BufferAttribute(colours, 3));
        object.material = new THREE.MeshBasicMaterial({ vertexColors: true });
      });
    } else {
      const [json, bytes] = await Promise.all([fetch(light).then((r) => r.text()), fetch(occluder).then((r) => r.arrayBuffer())]);
      const sceneLight = lightFromJSON(json);
      const ball = parseOccluder(bytes);
      // The .glb's transfer is in glTF's frame, so the spheres are taken in it ('y').
      const spheres = shadow ? holders.flatMap((holder) => occluderSpheresForObject(ball, holder, 'y')) : [];
      const handle = applyPRT(gltf, sceneLight);
      for (const object of handle.meshes) {
        const attributes = object.geometry.attributes;
        const grey = Boolean(attributes._prt_0);
        const names = grey ? [[0, 1, 2, 3].map((k) => `_prt_${k}`)] : ['r', 'g', 'b'].map((c) => [0, 1, 2, 3].map((k) => `_prt_${c}${k}`));
        const channels = names.length;
        const count = attributes.position.count;
        const transfer = new Float32Array(count * channels * 16);
        for (const [c, group] of names.entries()) {
          for (const [k, name] of group.entries()) {
            const a = attributes[name];
            if (!a || a.itemSize !== 4 || a.normalized) throw new Error(`mesh '${object.name}': ${name} is not a float VEC4`);
            for (let v = 0; v < count; v++) for (let i = 0; i < 4; i++) transfer[(v * channels + c) * 16 + 4 * k + i] = a.getComponent(v, i);
          }
        }
        const { positions, normals } = worldVertices(object);
        const shadowed = occludedTransfer(transfer, channels, 4, positions, normals, spheres);
        for (const [c, group] of names.entries()) {
          for (const [k, name] of group.entries()) {
            const a = attributes[name];
            for (let v = 0; v < count; v++) for (let i = 0; i < 4; i++) a.setComponent(v, i, shadowed[(v * channels + c) * 16 + 4 * k + i]);
            a.needsUpdate = true;
          }
        }
        for (let i = 0; i < transfer.length; i++) if (shadowed[i] !== transfer[i]) darkened += 1;
      }
    }
    const camera = new THREE.PerspectiveCamera(40, canvas.width / canvas.height, 0.05, 20);
    camera.position.set(0, -2.9, 2.3).applyMatrix4(C);
    camera.up.set(0, 0, 1).applyMatrix4(C);
    camera.lookAt(new THREE.Vector3(0, -0.2, 0.2).applyMatrix4(C));
    renderer.render(world, camera);
    return { pixels: pixels(), darkened };
  },
};
window.prtOccluderReady = true;
