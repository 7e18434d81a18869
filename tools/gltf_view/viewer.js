// Loads /mesh.glb with three.js's GLTFLoader (the loader most browser glTF viewers build on) and
// frames it from above at an angle. With ?shot=1 (view.mjs --screenshot) it renders once and
// POSTs the picture and what it drew to /result, so a headless browser run can be checked.
import * as THREE from 'three';
import {GLTFLoader} from 'three/addons/loaders/GLTFLoader.js';
import {OrbitControls} from 'three/addons/controls/OrbitControls.js';

const params = new URLSearchParams(location.search);
const shot = params.has('shot');
const status = document.getElementById('status');
const background = new THREE.Color(0x1d2630);

async function report(body) {
  if (shot) await fetch('/result', {method: 'POST', body: JSON.stringify(body)});
}

function webglRenderer() {
  try {
    // preserveDrawingBuffer: the canvas is read back after the frame for the screenshot.
    return new THREE.WebGLRenderer({antialias: true, preserveDrawingBuffer: shot});
  } catch (e) {
    throw new Error(`no WebGL in this browser (${e.message})`);
  }
}

// What the picture shows: pixels that are not background, and how many distinct colours they
// have (a textured terrain has many, an untextured or black one very few).
function pixelStats(canvas) {
  const w = 320, h = Math.round(320 * canvas.height / canvas.width);
  const c = document.createElement('canvas');
  c.width = w;
  c.height = h;
  const ctx = c.getContext('2d');
  ctx.drawImage(canvas, 0, 0, w, h);
  const px = ctx.getImageData(0, 0, w, h).data;
  const hex = background.getHex();  // sRGB, as drawn (.r/.g/.b are linear)
  const bg = [hex >> 16 & 255, hex >> 8 & 255, hex & 255];
  let covered = 0;
  const colours = new Set();
  for (let i = 0; i < px.length; i += 4) {
    const d = Math.abs(px[i] - bg[0]) + Math.abs(px[i + 1] - bg[1]) + Math.abs(px[i + 2] - bg[2]);
    if (d > 12) {
      ++covered;
      colours.add((px[i] >> 3) << 10 | (px[i + 1] >> 3) << 5 | (px[i + 2] >> 3));
    }
  }
  return {covered_fraction: covered / (w * h), distinct_colours: colours.size};
}

async function main() {
  const renderer = webglRenderer();
  renderer.setPixelRatio(1);
  renderer.setSize(innerWidth, innerHeight);
  document.body.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  scene.background = background;
  const camera = new THREE.PerspectiveCamera(45, innerWidth / innerHeight, 0.1, 1e6);

  const gltf = await new GLTFLoader().loadAsync('/mesh.glb');
  scene.add(gltf.scene);
  let meshes = 0, vertices = 0, triangles = 0, textured = 0;
  gltf.scene.traverse((o) => {
    if (!o.isMesh) return;
    ++meshes;
    vertices += o.geometry.attributes.position.count;
    triangles += (o.geometry.index ? o.geometry.index.count : o.geometry.attributes.position.count) / 3;
    if (o.material && o.material.map) ++textured;
  });

  // glTF is y-up; look at the centre from the south-west, 45° above the horizon.
  const box = new THREE.Box3().setFromObject(gltf.scene);
  const centre = box.getCenter(new THREE.Vector3());
  const size = box.getSize(new THREE.Vector3());
  const reach = 0.75 * Math.max(size.x, size.z, 1);
  camera.position.set(centre.x - 0.35 * reach, centre.y + reach, centre.z + 0.9 * reach);
  camera.near = reach / 1000;
  camera.far = reach * 20;
  camera.updateProjectionMatrix();
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.target.copy(centre);
  controls.update();
  status.textContent = `${meshes} tiles, ${vertices} vertices, ${Math.round(triangles)} triangles, ` +
                       `${textured} textured; extent ${size.x.toFixed(0)} × ${size.z.toFixed(0)} m`;

  if (shot) {
    status.style.display = 'none';  // the picture shows only the mesh
    renderer.render(scene, camera);
    const gl = renderer.getContext();
    await report({
      ok: true,
      renderer: gl.getParameter(gl.VERSION),
      meshes, vertices, triangles: Math.round(triangles), textured,
      extent_m: [size.x, size.y, size.z],
      ...pixelStats(renderer.domElement),
      png: renderer.domElement.toDataURL('image/png'),
    });
    return;
  }
  renderer.setAnimationLoop(() => renderer.render(scene, camera));
  addEventListener('resize', () => {
    camera.aspect = innerWidth / innerHeight;
    camera.updateProjectionMatrix();
    renderer.setSize(innerWidth, innerHeight);
  });
}

main().catch(async (e) => {
  status.textContent = `error: ${e.message}`;
  await report({ok: false, error: String(e && e.stack || e)});
});
