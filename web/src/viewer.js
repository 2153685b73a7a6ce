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
import { lodMain } from './lod.js';
import { el, fmt, fragmentOptions, linksOf, makeStage, nameCell } from './stage.js';

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

function main(data) {
  const t0 = performance.now();
  const opts = fragmentOptions();
  const n = data.n;
  const positions = positionsOf(data.positions, n);
  const truth = bitsOf(data.truth);
  const off = bitsOf(data.off);
  const methods = data.methods.map((m) => ({ ...m, bits: bitsOf(m.visible) }));
  const colors = [data.colors.hidden, data.colors.tp, data.colors.fn, data.colors.fp, data.colors.off];

  const stage = makeStage(data, opts);
  const { panel, renderer, cloud } = stage;
  const position = new THREE.BufferAttribute(positions, 3, true);
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
  const cam = data.camera;

  const state = {
    method: 0,
    pointSize: 2,
    onTop: true,
    drawn: 0,
    firstFrameMs: null,
    completeMs: null,
    decodeMs: performance.now() - t0,
    counts: null,
    // The stage's frame count and whether a frame is due (the tests wait on both).
    get frames() {
      return stage.frames;
    },
    get dirty() {
      return stage.dirty;
    },
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
    stage.dirty = true;
  }

  function applyDrawRange() {
    for (const layer of layers) layer.geometry.setDrawRange(0, countBelow(layer.list, state.drawn));
  }

  function setPointSize(px) {
    state.pointSize = px;
    for (const layer of layers) layer.material.size = px * renderer.getPixelRatio();
    stage.dirty = true;
  }

  function setOnTop(on) {
    state.onTop = on;
    for (const layer of layers) {
      layer.material.depthTest = !on;
      layer.material.depthWrite = !on;
      layer.material.needsUpdate = true;
    }
    stage.dirty = true;
  }

  const savePicture = () => stage.savePicture(`pointsight-${data.dataset}-view-${data.view}-${methods[state.method].name}`);

  // Panel.
  const legend = el('table');
  const scores = el('table');
  function updatePanel() {
    scores.replaceChildren(
      el('tr', {}, el('th', {}, 'method'), el('th', {}, data.score_columns[0]), el('th', {}, data.score_columns[1]), el('th', {}, data.score_columns[2])),
      ...methods.map((m, k) =>
        el(
          'tr',
          { class: k === state.method ? 'method chosen' : 'method', title: m.setting, onclick: () => setMethod(k) },
          nameCell(m, data.markers),
          el('td', {}, fmt(m.scores[0])),
          el('td', {}, fmt(m.scores[1])),
          el('td', {}, fmt(m.scores[2])),
        ),
      ),
    );
    select.value = String(state.method);
    const m = methods[state.method];
    setting.textContent = `${m.name}: ${m.setting || 'its defaults'}; ${m.n_visible_total.toLocaleString()} of ${data.n_total.toLocaleString()} points visible; ${fmt(m.seconds, 4)} s${m.timing ? ` (${m.timing})` : ''}`;
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
  panel.append(
    el('h1', {}, data.title),
    el('div', { class: 'note' }, data.note),
    ...[linksOf(data)].filter(Boolean),
    el('label', {}, 'method ', select),
    setting,
    scores,
    el('div', { class: 'note' }, data.score_note),
    legend,
    el('div', { class: 'note' }, 'counts: points of this page in each class'),
    el('label', {}, 'point size ', sizeInput),
    el('label', {}, onTopBox, ' errors on top (no depth test, as renders.png)'),
    ...stage.cameraControls(savePicture),
  );

  // Start.
  stage.resize();
  state.drawn = Math.min(n, 1 << 17);
  setMethod(opts.method ? opts.method : 0);
  setPointSize(opts.size ? Number(opts.size) : 2);
  sizeInput.value = String(state.pointSize);
  setOnTop(opts.ontop !== '0');
  onTopBox.checked = state.onTop;
  if (opts.look === '1') stage.lookThrough();
  else stage.overview();

  stage.loop(() => {
    if (state.firstFrameMs == null) {
      state.firstFrameMs = performance.now();
      window.viewerReady = true;
    }
    if (state.drawn < n) {
      state.drawn = Math.min(n, state.drawn * 4);
      applyDrawRange();
      stage.dirty = true;
    } else if (state.completeMs == null) {
      state.completeMs = performance.now();
      window.viewerComplete = true;
    }
  });

  window.pointsight = {
    data: { dataset: data.dataset, view: data.view, n, camera: cam, methods: methods.map(({ name, setting, counts, scores }) => ({ name, setting, counts, scores })) },
    state,
    setMethod,
    setPointSize,
    setOnTop,
    lookThrough: stage.lookThrough,
    overview: stage.overview,
    savePicture,
    benchmark: stage.benchmark,
    classCounts: () => Array.from(state.counts),
  };
}

try {
  const data = JSON.parse(document.getElementById('pointsight-data').textContent);
  if (data.kind === 'lod') lodMain(data);
  else main(data);
} catch (err) {
  window.viewerError = String(err && err.stack ? err.stack : err);
  document.body.append(Object.assign(document.createElement('pre'), { textContent: `pointsight viewer: ${window.viewerError}` }));
  throw err;
}
