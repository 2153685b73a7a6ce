// pointsight's level-of-detail page: the full-detail cloud and each LOD method's selection
// for one view at a distance, each splat a disc of its own world radius (three.js).
//
// Data (written by `pointsight view --lod`, crates/harness/src/view/lod.rs): per method,
// `centers` (little-endian uint16 x, y, z per splat, quantised over `box`), `radii` (uint16
// over [0, `rmax`]) and `colors` (uint8 RGB, shaded by the harness for the view's eye). Each
// method is one THREE.Points with a ShaderMaterial whose point size is the splat's projected
// diameter, 2 r · (height / (2 tan(fov / 2))) / depth pixels, at least one pixel, and whose
// fragments outside the disc are discarded: splat::render's rule, so the picture through the
// view's camera is the harness's render of the selection. Depth-tested, as splat::render is.
//
// `window.pointsight` exposes the state and actions for tests; the URL's fragment sets the
// start: #method=NAME&look=1&panel=0.

import * as THREE from 'three';

import { bytesOf } from './data.js';
import { el, fmt, fragmentOptions, linksOf, makeStage, nameCell } from './stage.js';

const VERTEX = `
attribute float radius;
attribute vec3 splatColor;
uniform float rmax;
uniform float pxPerUnit;
varying vec3 vColor;
void main() {
  vec4 mv = modelViewMatrix * vec4(position, 1.0);
  gl_Position = projectionMatrix * mv;
  gl_PointSize = max(1.0, 2.0 * radius * rmax * pxPerUnit / -mv.z);
  vColor = splatColor;
}
`;

const FRAGMENT = `
varying vec3 vColor;
void main() {
  vec2 d = gl_PointCoord - vec2(0.5);
  if (dot(d, d) > 0.25) discard;
  gl_FragColor = vec4(vColor, 1.0);
}
`;

/** A typed view of a base64 array of `count` `Type` values. */
function arrayOf(b64, Type, count, what) {
  const bytes = bytesOf(b64);
  if (bytes.length !== count * Type.BYTES_PER_ELEMENT) {
    throw new Error(`${what}: expected ${count * Type.BYTES_PER_ELEMENT} bytes, got ${bytes.length}`);
  }
  return new Type(bytes.buffer, bytes.byteOffset, count);
}

export function lodMain(data) {
  const t0 = performance.now();
  const opts = fragmentOptions();
  const uniforms = { rmax: { value: data.rmax }, pxPerUnit: { value: 1 } };
  const stage = makeStage(data, opts, () => {
    const h = stage.renderer.getDrawingBufferSize(new THREE.Vector2()).y;
    uniforms.pxPerUnit.value = h / (2 * Math.tan(THREE.MathUtils.degToRad(stage.camera.fov) / 2));
  });
  const { panel, cloud } = stage;
  const methods = data.methods.map((m) => {
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(arrayOf(m.centers, Uint16Array, 3 * m.n, `${m.name} centres`), 3, true));
    geometry.setAttribute('radius', new THREE.BufferAttribute(arrayOf(m.radii, Uint16Array, m.n, `${m.name} radii`), 1, true));
    geometry.setAttribute('splatColor', new THREE.BufferAttribute(arrayOf(m.colors, Uint8Array, 3 * m.n, `${m.name} colours`), 3, true));
    const material = new THREE.ShaderMaterial({ vertexShader: VERTEX, fragmentShader: FRAGMENT, uniforms });
    const points = new THREE.Points(geometry, material);
    points.frustumCulled = false;
    points.visible = false;
    cloud.add(points);
    return { ...m, points };
  });

  const state = {
    method: 0,
    firstFrameMs: null,
    completeMs: null,
    decodeMs: performance.now() - t0,
    get frames() {
      return stage.frames;
    },
    get dirty() {
      return stage.dirty;
    },
  };

  const table = el('table');
  const setting = el('div', { class: 'note' });
  function setMethod(k) {
    if (typeof k === 'string') k = methods.findIndex((m) => m.name === k);
    if (!(k >= 0 && k < methods.length)) throw new Error(`no method ${k}`);
    state.method = k;
    methods.forEach((m, j) => { m.points.visible = j === k; });
    const m = methods[k];
    setting.textContent = `${m.name}: ${m.setting || 'its defaults'}; ${m.n_total.toLocaleString()} splats${m.n < m.n_total ? ` (${m.n.toLocaleString()} on this page)` : ''}`;
    table.replaceChildren(
      el('tr', {}, el('th', {}, 'method'), el('th', {}, 'splats'), el('th', {}, 'PSNR dB'), el('th', {}, 'select s')),
      ...methods.map((o, j) =>
        el(
          'tr',
          { class: j === k ? 'method chosen' : 'method', title: o.setting, onclick: () => setMethod(j) },
          nameCell(o, data.markers),
          el('td', {}, o.n_total.toLocaleString()),
          el('td', {}, o.psnr == null ? 'ref.' : fmt(o.psnr, 2)),
          el('td', {}, fmt(o.seconds, 4)),
        ),
      ),
    );
    select.value = String(k);
    stage.dirty = true;
  }
  const select = el(
    'select',
    { onchange: (e) => setMethod(Number(e.target.value)) },
    ...methods.map((m, k) => el('option', { value: String(k) }, m.name)),
  );
  const savePicture = () => stage.savePicture(`pointsight-${data.dataset}-view-${data.view}-lod-${methods[state.method].name}`);
  panel.append(
    el('h1', {}, data.title),
    el('div', { class: 'note' }, data.note),
    ...[linksOf(data)].filter(Boolean),
    el('label', {}, 'method ', select),
    setting,
    table,
    el('div', { class: 'note' }, 'PSNR: the selection rendered by splat::render against the full detail, at the view\'s camera; click a row to show that method.'),
    ...stage.cameraControls(savePicture),
  );

  stage.resize();
  setMethod(opts.method ? opts.method : 0);
  if (opts.look === '1') stage.lookThrough();
  else stage.overview();
  stage.loop(() => {
    if (state.firstFrameMs == null) {
      state.firstFrameMs = performance.now();
      state.completeMs = state.firstFrameMs;
      window.viewerReady = true;
      window.viewerComplete = true;
    }
  });

  window.pointsight = {
    data: {
      kind: 'lod',
      dataset: data.dataset,
      view: data.view,
      distance: data.distance,
      camera: data.camera,
      methods: methods.map(({ name, setting, n, n_total, psnr, covered_px }) => ({ name, setting, n, n_total, psnr, covered_px })),
    },
    state,
    setMethod,
    lookThrough: stage.lookThrough,
    overview: stage.overview,
    savePicture,
    benchmark: stage.benchmark,
  };
}
