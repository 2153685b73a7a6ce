// The scene both pages share (the visibility page, viewer.js, and the level-of-detail page,
// lod.js): the renderer, the cloud's group (positions quantised over the data's box, scaled
// back by the group's transform), the view's camera drawn as three.js's CameraHelper, the
// orbiting camera with OrbitControls, the look-through and overview poses, the picture
// saver, the frame loop and the orbit benchmark. three.js does every matrix and the orbit.

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

import { swatch } from './swatch.js';

/** The URL fragment's options: #k=v&k=v. */
export function fragmentOptions() {
  const out = {};
  for (const part of location.hash.replace(/^#/, '').split('&')) {
    if (!part) continue;
    const [k, v = ''] = part.split('=');
    out[decodeURIComponent(k)] = decodeURIComponent(v);
  }
  return out;
}

/** An element with attributes (`on...`: listeners; `style`: CSS text) and children. */
export function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === 'style') e.style.cssText = v;
    else if (k.startsWith('on')) e.addEventListener(k.slice(2), v);
    else e.setAttribute(k, v);
  }
  for (const c of children) e.append(c);
  return e;
}

/**
 * A method's name cell: its swatch (the style the harness gives it, as in every figure of the
 * report) and its name.
 */
export function nameCell(m, markers) {
  const td = el('td', {});
  if (m.style && markers) td.append(swatch(m.style, markers, { line: false }));
  td.append(m.name);
  return td;
}

/** The page's links (`data.links`: the report's results pages), as a paragraph; null if none. */
export function linksOf(data) {
  if (!data.links || !data.links.length) return null;
  return el('div', { class: 'note links' }, ...data.links.flatMap((l, k) => [k ? ' · ' : '', el('a', { href: l.href }, l.label)]));
}

/** A number with `digits` decimals, or an en dash. */
export function fmt(x, digits = 4) {
  return x == null || Number.isNaN(x) ? '–' : Number(x).toFixed(digits);
}

export const CSS = `
html, body { margin: 0; height: 100%; font: 13px/1.35 system-ui, sans-serif; color: #222; }
#ps-root { display: flex; height: 100%; }
#ps-canvas { flex: 1; position: relative; min-width: 0; }
#ps-canvas canvas { display: block; }
#ps-panel { width: 330px; overflow-y: auto; padding: 10px 12px; border-left: 1px solid #ccc;
  background: #fafafa; box-sizing: border-box; }
#ps-panel h1 { font-size: 15px; margin: 0 0 6px; }
#ps-panel table { border-collapse: collapse; width: 100%; margin: 6px 0; }
#ps-panel td, #ps-panel th { padding: 2px 4px; text-align: right; border-bottom: 1px solid #e4e4e4; }
#ps-panel td:first-child, #ps-panel th:first-child { text-align: left; }
#ps-panel tr.method { cursor: pointer; }
#ps-panel tr.chosen { background: #dde8ff; }
#ps-panel .ps-swatch { vertical-align: -2px; margin-right: 5px; }
#ps-panel .swatch { display: inline-block; width: 11px; height: 11px; margin-right: 5px;
  vertical-align: -1px; border: 1px solid #999; }
#ps-panel .note { color: #555; font-size: 12px; margin: 6px 0; }
#ps-panel button { margin: 3px 4px 3px 0; }
#ps-panel label { display: block; margin: 4px 0; }
`;

/**
 * The page's layout and scene for `data` (its `box` and `camera`); `opts` the fragment's
 * options (`panel=0` hides the panel). `onResize` is called after each resize.
 */
export function makeStage(data, opts, onResize = () => {}) {
  const style = document.createElement('style');
  style.textContent = CSS;
  document.head.append(style);
  const holder = el('div', { id: 'ps-canvas' });
  const panel = el('div', { id: 'ps-panel' });
  document.body.append(el('div', { id: 'ps-root' }, holder, panel));
  if (opts.panel === '0') panel.style.display = 'none';

  // Renderer: colours pass through unchanged (the harness's RGB values land in the pixels).
  THREE.ColorManagement.enabled = false;
  const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
  renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setClearColor(0xffffff, 1);
  holder.append(renderer.domElement);
  const scene = new THREE.Scene();

  const [lo, hi] = [data.box.min, data.box.max];
  const size = hi.map((h, k) => Math.max(h - lo[k], 1e-30));
  const cloud = new THREE.Group();
  cloud.position.set(lo[0], lo[1], lo[2]);
  cloud.scale.set(size[0], size[1], size[2]);
  scene.add(cloud);

  // The view's camera, drawn, and the orbiting camera.
  const cam = data.camera;
  const center = new THREE.Vector3((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2);
  const diag = Math.hypot(size[0], size[1], size[2]);
  const eye = new THREE.Vector3(...cam.eye);
  const target = new THREE.Vector3(...cam.target);
  const reach = eye.distanceTo(center) + diag;
  const viewCamera = new THREE.PerspectiveCamera(cam.fov_y_deg ?? 45, cam.width / cam.height, diag * 1e-3, eye.distanceTo(target));
  viewCamera.position.copy(eye);
  const basis = new THREE.Matrix4().makeBasis(
    new THREE.Vector3(...cam.right),
    new THREE.Vector3(...cam.up),
    new THREE.Vector3(...cam.forward).negate(),
  );
  viewCamera.quaternion.setFromRotationMatrix(basis);
  viewCamera.updateMatrixWorld();
  const helper = new THREE.CameraHelper(viewCamera);
  scene.add(helper);

  const camera = new THREE.PerspectiveCamera(cam.fov_y_deg ?? 45, 1, diag * 1e-3, reach * 4);
  // Up before the controls: OrbitControls orbits about the up it finds at construction.
  camera.up.set(...cam.up);
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.enableDamping = false;

  const stage = {
    holder,
    panel,
    renderer,
    scene,
    cloud,
    camera,
    controls,
    helper,
    helperBox: null,
    dirty: true,
    frames: 0,
  };

  stage.resize = () => {
    const w = holder.clientWidth || window.innerWidth;
    const h = holder.clientHeight || window.innerHeight;
    renderer.setSize(w, h);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
    onResize();
    stage.dirty = true;
  };

  stage.lookThrough = () => {
    camera.position.copy(viewCamera.position);
    camera.quaternion.copy(viewCamera.quaternion);
    camera.fov = viewCamera.fov;
    camera.updateProjectionMatrix();
    controls.target.copy(target);
    controls.update();
    camera.quaternion.copy(viewCamera.quaternion);
    helper.visible = false;
    if (stage.helperBox) stage.helperBox.checked = false;
    onResize();
    stage.dirty = true;
  };

  stage.overview = () => {
    const back = new THREE.Vector3().subVectors(eye, center).normalize();
    const side = new THREE.Vector3().crossVectors(back, new THREE.Vector3(...cam.up)).normalize();
    const d = eye.distanceTo(center);
    camera.position.copy(center).addScaledVector(back, d * 1.6).addScaledVector(side, d * 0.9);
    controls.target.copy(center);
    controls.update();
    helper.visible = true;
    if (stage.helperBox) stage.helperBox.checked = true;
    stage.dirty = true;
  };

  stage.savePicture = (name) => {
    const url = renderer.domElement.toDataURL('image/png');
    const a = el('a', { href: url, download: `${name}.png` });
    document.body.append(a);
    a.click();
    a.remove();
    return url;
  };

  /** The checkbox that shows or hides the view's camera. */
  stage.helperToggle = () => {
    stage.helperBox = el('input', { type: 'checkbox', onchange: (e) => { helper.visible = e.target.checked; stage.dirty = true; } });
    stage.helperBox.checked = helper.visible;
    return stage.helperBox;
  };

  /** The panel's camera controls: the helper's checkbox, look through, overview, save. */
  stage.cameraControls = (savePicture) => [
    el('label', {}, stage.helperToggle(), " draw the view's camera"),
    el('button', { onclick: stage.lookThrough }, "look through the view's camera"),
    el('button', { onclick: stage.overview }, 'overview'),
    el('button', { onclick: savePicture }, 'save picture'),
    el('div', { class: 'note' }, 'drag: orbit; wheel: zoom; right-drag or shift-drag: pan'),
  ];

  const pixel = new Uint8Array(4);
  stage.draw = () => {
    renderer.render(scene, camera);
    // Reading one pixel waits for the GPU: frame times and the first frame are real.
    const gl = renderer.getContext();
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel);
    stage.frames++;
  };

  /** Draws whenever dirty; `afterDraw` is called after each drawn frame. */
  stage.loop = (afterDraw) => {
    function tick() {
      if (stage.dirty || controls.autoRotate) {
        stage.dirty = false;
        if (controls.autoRotate) controls.update();
        stage.draw();
        afterDraw();
      }
      requestAnimationFrame(tick);
    }
    requestAnimationFrame(tick);
  };

  /** Frame times while orbiting (OrbitControls' auto-rotation), for measurements. */
  stage.benchmark = (frames = 30) =>
    new Promise((resolve) => {
      const times = [];
      controls.autoRotate = true;
      controls.autoRotateSpeed = 6;
      function step() {
        const t = performance.now();
        controls.update();
        stage.draw();
        times.push(performance.now() - t);
        if (times.length < frames) requestAnimationFrame(step);
        else {
          controls.autoRotate = false;
          const sorted = [...times].sort((a, b) => a - b);
          resolve({ frames, median: sorted[frames >> 1], min: sorted[0], max: sorted[frames - 1], times });
        }
      }
      requestAnimationFrame(step);
    });

  window.addEventListener('resize', stage.resize);
  controls.addEventListener('change', () => { stage.dirty = true; });
  return stage;
}
