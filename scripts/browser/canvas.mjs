// What every test page shares: a WebGL renderer on the page's #view canvas that keeps its
// drawing buffer (so the pixels can be read after the frame), and the two ways data crosses
// the page's boundary as text: the canvas's RGBA pixels and float arrays, both in base64.
import * as THREE from 'three';

export const canvas = document.getElementById('view');
export const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true, alpha: true });
renderer.setPixelRatio(1);
renderer.setClearColor(0x000000, 0);
export const gl = renderer.getContext();

// The canvas's RGBA pixels, top row first (GL reads the bottom row first), as base64.
export function pixels() {
  const { width, height } = canvas;
  const data = new Uint8Array(width * height * 4);
  gl.readPixels(0, 0, width, height, gl.RGBA, gl.UNSIGNED_BYTE, data);
  const flipped = new Uint8Array(data.length);
  for (let y = 0; y < height; y++) flipped.set(data.subarray((height - 1 - y) * width * 4, (height - y) * width * 4), y * width * 4);
  let text = '';
  for (let i = 0; i < flipped.length; i += 0x8000) text += String.fromCharCode(...flipped.subarray(i, i + 0x8000));
  return btoa(text);
}

// A little-endian float32 array sent as base64.
export const floats = (base64) => new Float32Array(Uint8Array.from(atob(base64), (ch) => ch.charCodeAt(0)).buffer);
