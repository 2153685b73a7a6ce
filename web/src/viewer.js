// pointsight's viewer: one method's visible set against the reference, in 3D (three.js).
//
// The page holds its data in <script id="pointsight-data" type="application/json"> (see
// data.js for the layout). The cloud is drawn as five THREE.Points sharing one quantised
// position buffer, one per class (hidden, true positive, missed, false positive, off-surface),
// each indexing its points; "errors on top" draws them without a depth test in that order,
// as renders.png does. The first frames draw growing prefixes of the point order (uniform
// subsamples), so a picture comes before a large cloud is fully drawn.
//
// For tests and measurements, `window.pointsight` exposes the state and a few actions, and
// the URL's fragment sets the start: #method=NAME&size=PX&look=1&panel=0&ontop=0.

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import {
  CLASSES,
  FALSE_NEGATIVE,
  FALSE_POSITIVE,
  HIDDEN,
  OFF_SURFACE,
  TRUE_POSITIVE,
  bitsOf,
  classify,
  countBelow,
  positionsOf,
} from './data.js';

const CSS = `
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
#ps-panel .swatch { display: inline-block; width: 11px; height: 11px; margin-right: 5px;
  vertical-align: -1px; border: 1px solid #999; }
#ps-panel .note { color: #555; font-size: 12px; margin: 6px 0; }
#ps-panel button { margin: 3px 4px 3px 0; }
#ps-panel label { display: block; margin: 4px 0; }
`;

const CLASS_NAMES = {
  [HIDDEN]: 'hidden',
  [TRUE_POSITIVE]: 'visible and found',
  [FALSE_NEGATIVE]: 'visible, missed',
  [FALSE_POSITIVE]: 'hidden, reported visible',
  [OFF_SURFACE]: 'off-surface or outlier (not scored)',
};

function rgb(c) {
  return new THREE.Color(c[0] / 255, c[1] / 255, c[2] / 255);
}

function fragmentOptions() {
  const out = {};
  for (const part of location.hash.replace(/^#/, '').split('&')) {
    if (!part) continue;
    const [k, v = ''] = part.split('=');
    out[decodeURIComponent(k)] = decodeURIComponent(v);
  }
  return out;
}

function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === 'style') e.style.cssText = v;
    else if (k.startsWith('on')) e.addEventListener(k.slice(2), v);
    else e.setAttribute(k, v);
  }
  for (const c of children) e.append(c);
  return e;
}

function fmt(x, digits = 4) {
  return x == null || Number.isNaN(x) ? '–' : Number(x).toFixed(digits);
}

function main() {
  const t0 = performance.now();
  const data = JSON.parse(document.getElementById('pointsight-data').textContent);
  const opts = fragmentOptions();
  const n = data.n;
  const positions = positionsOf(data.positions, n);
  const truth = bitsOf(data.truth);
  const off = bitsOf(data.off);
  const methods = data.methods.map((m) => ({ ...m, bits: bitsOf(m.visible) }));
  const colors = [data.colors.hidden, data.colors.tp, data.colors.fn, data.colors.fp, data.colors.off];

  // Layout.
  const style = document.createElement('style');
  style.textContent = CSS;
  document.head.append(style);
  const holder = el('div', { id: 'ps-canvas' });
  const panel = el('div', { id: 'ps-panel' });
  const root = el('div', { id: 'ps-root' }, holder, panel);
  document.body.append(root);
  if (opts.panel === '0') panel.style.display = 'none';

  // Renderer: colours pass through unchanged (renders.png's RGB values land in the pixels).
  THREE.ColorManagement.enabled = false;
  const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
  renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setClearColor(0xffffff, 1);
  holder.append(renderer.domElement);
  const scene = new THREE.Scene();

  // The cloud: positions quantised over the box, scaled back by the group's transform.
  const [lo, hi] = [data.box.min, data.box.max];
  const size = hi.map((h, k) => Math.max(h - lo[k], 1e-30));
  const position = new THREE.BufferAttribute(positions, 3, true);
  const cloud = new THREE.Group();
  cloud.position.set(lo[0], lo[1], lo[2]);
  cloud.scale.set(size[0], size[1], size[2]);
  scene.add(cloud);
  const layers = [];
  for (let c = 0; c < CLASSES; c++) {
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', position);
    const material = new THREE.PointsMaterial({ color: rgb(colors[c]), size: 2, sizeAttenuation: false });
    const points = new THREE.Points(geometry, material);
    points.frustumCulled = false;
    points.renderOrder = c;
    cloud.add(points);
    layers.push({ geometry, material, points, list: new Uint32Array(0) });
  }

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

  const state = {
    method: 0,
    pointSize: 2,
    onTop: true,
    drawn: 0,
    frames: 0,
    firstFrameMs: null,
    completeMs: null,
    decodeMs: performance.now() - t0,
    dirty: true,
    counts: null,
  };

  function setMethod(k) {
    if (typeof k === 'string') k = methods.findIndex((m) => m.name === k);
    if (!(k >= 0 && k < methods.length)) throw new Error(`no method ${k}`);
    state.method = k;
    const { lists, counts } = classify(n, truth, methods[k].bits, off);
    state.counts = counts;
    for (let c = 0; c < CLASSES; c++) {
      layers[c].list = lists[c];
      layers[c].geometry.setIndex(new THREE.BufferAttribute(lists[c], 1));
    }
    applyDrawRange();
    updatePanel();
    state.dirty = true;
  }

  function applyDrawRange() {
    for (const layer of layers) layer.geometry.setDrawRange(0, countBelow(layer.list, state.drawn));
  }

  function setPointSize(px) {
    state.pointSize = px;
    for (const layer of layers) layer.material.size = px * renderer.getPixelRatio();
    state.dirty = true;
  }

  function setOnTop(on) {
    state.onTop = on;
    for (const layer of layers) {
      layer.material.depthTest = !on;
      layer.material.depthWrite = !on;
      layer.material.needsUpdate = true;
    }
    state.dirty = true;
  }

  function resize() {
    const w = holder.clientWidth || window.innerWidth;
    const h = holder.clientHeight || window.innerHeight;
    renderer.setSize(w, h);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
    state.dirty = true;
  }

  function lookThrough() {
    camera.position.copy(viewCamera.position);
    camera.quaternion.copy(viewCamera.quaternion);
    camera.fov = viewCamera.fov;
    camera.updateProjectionMatrix();
    controls.target.copy(target);
    controls.update();
    camera.quaternion.copy(viewCamera.quaternion);
    helper.visible = false;
    if (helperBox) helperBox.checked = false;
    state.dirty = true;
  }

  function overview() {
    const back = new THREE.Vector3().subVectors(eye, center).normalize();
    const side = new THREE.Vector3().crossVectors(back, new THREE.Vector3(...cam.up)).normalize();
    camera.position.copy(center).addScaledVector(back, eye.distanceTo(center) * 1.6).addScaledVector(side, eye.distanceTo(center) * 0.9);
    controls.target.copy(center);
    controls.update();
    helper.visible = true;
    if (helperBox) helperBox.checked = true;
    state.dirty = true;
  }

  function savePicture() {
    const url = renderer.domElement.toDataURL('image/png');
    const a = el('a', { href: url, download: `pointsight-${data.dataset}-view-${data.view}-${methods[state.method].name}.png` });
    document.body.append(a);
    a.click();
    a.remove();
    return url;
  }

  // Panel.
  let helperBox = null;
  const legend = el('table');
  const scores = el('table');
  function updatePanel() {
    scores.replaceChildren(
      el('tr', {}, el('th', {}, 'method'), el('th', {}, data.score_columns[0]), el('th', {}, data.score_columns[1]), el('th', {}, data.score_columns[2])),
      ...methods.map((m, k) =>
        el(
          'tr',
          { class: k === state.method ? 'method chosen' : 'method', title: m.setting, onclick: () => setMethod(k) },
          el('td', {}, m.name),
          el('td', {}, fmt(m.scores[0])),
          el('td', {}, fmt(m.scores[1])),
          el('td', {}, fmt(m.scores[2])),
        ),
      ),
    );
    select.value = String(state.method);
    const m = methods[state.method];
    setting.textContent = `${m.name}: ${m.setting || 'its defaults'}; ${m.n_visible_total.toLocaleString()} of ${data.n_total.toLocaleString()} points visible; ${fmt(m.seconds, 4)} s`;
    const rows = [];
    for (const c of [TRUE_POSITIVE, FALSE_NEGATIVE, FALSE_POSITIVE, HIDDEN, OFF_SURFACE]) {
      if (c === OFF_SURFACE && !off) continue;
      const sw = el('span', { class: 'swatch', style: `background: rgb(${colors[c].join(',')})` });
      rows.push(el('tr', {}, el('td', {}, sw, CLASS_NAMES[c]), el('td', {}, state.counts ? state.counts[c].toLocaleString() : '')));
    }
    legend.replaceChildren(...rows);
  }
  const select = el(
    'select',
    { onchange: (e) => setMethod(Number(e.target.value)) },
    ...methods.map((m, k) => el('option', { value: String(k) }, m.name)),
  );
  const setting = el('div', { class: 'note' });
  const sizeInput = el('input', { type: 'range', min: '1', max: '10', step: '1', value: '2', oninput: (e) => setPointSize(Number(e.target.value)) });
  const onTopBox = el('input', { type: 'checkbox', onchange: (e) => setOnTop(e.target.checked) });
  onTopBox.checked = true;
  helperBox = el('input', { type: 'checkbox', onchange: (e) => { helper.visible = e.target.checked; state.dirty = true; } });
  helperBox.checked = true;
  panel.append(
    el('h1', {}, data.title),
    el('div', { class: 'note' }, data.note),
    el('label', {}, 'method ', select),
    setting,
    scores,
    el('div', { class: 'note' }, data.score_note),
    legend,
    el('div', { class: 'note' }, 'counts: points of this page in each class'),
    el('label', {}, 'point size ', sizeInput),
    el('label', {}, onTopBox, ' errors on top (no depth test, as renders.png)'),
    el('label', {}, helperBox, " draw the view's camera"),
    el('button', { onclick: lookThrough }, "look through the view's camera"),
    el('button', { onclick: overview }, 'overview'),
    el('button', { onclick: savePicture }, 'save picture'),
    el('div', { class: 'note' }, 'drag: orbit; wheel: zoom; right-drag or shift-drag: pan'),
  );

  // Start.
  window.addEventListener('resize', resize);
  controls.addEventListener('change', () => { state.dirty = true; });
  resize();
  state.drawn = Math.min(n, 1 << 17);
  setMethod(opts.method ? opts.method : 0);
  setPointSize(opts.size ? Number(opts.size) : 2);
  sizeInput.value = String(state.pointSize);
  setOnTop(opts.ontop !== '0');
  onTopBox.checked = state.onTop;
  if (opts.look === '1') lookThrough();
  else overview();

  const pixel = new Uint8Array(4);
  function draw() {
    renderer.render(scene, camera);
    // Reading one pixel waits for the GPU: frame times and the first frame are real.
    const gl = renderer.getContext();
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel);
    state.frames++;
  }
  function tick() {
    if (state.dirty || controls.autoRotate) {
      state.dirty = false;
      if (controls.autoRotate) controls.update();
      draw();
      if (state.firstFrameMs == null) {
        state.firstFrameMs = performance.now();
        window.viewerReady = true;
      }
      if (state.drawn < n) {
        state.drawn = Math.min(n, state.drawn * 4);
        applyDrawRange();
        state.dirty = true;
      } else if (state.completeMs == null) {
        state.completeMs = performance.now();
        window.viewerComplete = true;
      }
    }
    requestAnimationFrame(tick);
  }
  requestAnimationFrame(tick);

  // Frame times while orbiting (OrbitControls' auto-rotation), for measurements.
  function benchmark(frames = 30) {
    return new Promise((resolve) => {
      const times = [];
      controls.autoRotate = true;
      controls.autoRotateSpeed = 6;
      function step() {
        const t = performance.now();
        controls.update();
        draw();
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
  }

  window.pointsight = {
    data: { dataset: data.dataset, view: data.view, n, camera: cam, methods: methods.map(({ name, setting, counts, scores }) => ({ name, setting, counts, scores })) },
    state,
    setMethod,
    setPointSize,
    setOnTop,
    lookThrough,
    overview,
    savePicture,
    benchmark,
    classCounts: () => Array.from(state.counts),
  };
}

try {
  main();
} catch (err) {
  window.viewerError = String(err && err.stack ? err.stack : err);
  document.body.append(Object.assign(document.createElement('pre'), { textContent: `pointsight viewer: ${window.viewerError}` }));
  throw err;
}
