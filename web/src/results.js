// pointsight's results page: one experiment's figures, drawn with Observable Plot from their
// JSON twins (the very data and styles the PNGs are drawn from; crates/harness/src/output/
// figure.rs and style.rs), in one self-contained HTML file that opens from disk.
//
// Hovering a point names it (method, setting, the score with its interval, seconds); clicking a
// legend entry hides that series in the figure (again: shows it); the family filter hides
// families in every figure. Context series (the other families, grey) follow the filter too.
//
// For tests, `window.pointsightResults` exposes the data and the state, and every mark of a
// series carries the class `ps-series-F-P-S` (figure, panel, series indices in the data).

import * as Plot from '@observablehq/plot';

import { markerFill, swatch, symbolOf } from './swatch.js';

const CSS = `
html, body { margin: 0; font: 14px/1.4 system-ui, sans-serif; color: #222; background: #fff; }
main { max-width: 1500px; margin: 0 auto; padding: 12px 20px 40px; }
h1 { font-size: 20px; margin: 4px 0 6px; }
h2 { font-size: 16px; margin: 26px 0 6px; }
.note { color: #555; font-size: 13px; margin: 4px 0; }
nav a { margin-right: 14px; }
#ps-families { position: sticky; top: 0; background: #fafafa; border: 1px solid #ddd;
  padding: 6px 10px; margin: 10px 0; z-index: 2; }
#ps-families label { margin-right: 12px; white-space: nowrap; display: inline-block; }
#ps-families button { margin-right: 6px; }
.figure { display: flex; gap: 14px; align-items: flex-start; }
.panels { display: flex; flex-wrap: wrap; gap: 4px 10px; flex: 1; min-width: 0; }
.panel h3 { font-size: 13px; font-weight: 600; margin: 4px 0 0 50px; }
.legend { width: 280px; flex: none; font-size: 13px; }
.legend .entry { display: flex; align-items: center; gap: 6px; cursor: pointer; padding: 1px 2px;
  border-radius: 3px; user-select: none; }
.legend .entry:hover { background: #eef3ff; }
.legend .entry.off { opacity: 0.35; text-decoration: line-through; }
.legend .key { color: #555; font-size: 12px; }
.files { font-size: 12px; color: #555; }
.ylabel { font-size: 11px; color: #333; margin: 2px 0 0 8px; }
.figure-notes { font-size: 12px; color: #555; margin: 4px 0; }
`;

/** An element with attributes (`on...`: listeners) and children. */
function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k.startsWith('on')) e.addEventListener(k.slice(2), v);
    else e.setAttribute(k, v);
  }
  for (const c of children) e.append(c);
  return e;
}

/** A number in a few significant digits. */
function num(v) {
  if (v == null || !Number.isFinite(v)) return '–';
  const a = Math.abs(v);
  if (a === 0) return '0';
  if (a >= 1e4 || a < 1e-3) return v.toExponential(2);
  return Number(v.toPrecision(4)).toString();
}

/** A tick label as the PNG prints it (format_number in figure/draw.rs): "0.05", "2.5", "40k", "3M". */
export function tickNumber(v) {
  const a = Math.abs(v);
  const trim = (t) => (t.includes('.') ? t.replace(/0+$/, '').replace(/\.$/, '') : t);
  if (a === 0) return '0';
  if (a >= 1e6) return `${(v / 1e6).toFixed(0)}M`;
  if (a >= 1e4) return `${(v / 1e3).toFixed(0)}k`;
  if (a >= 100) return v.toFixed(0);
  if (a >= 1) return trim(v.toFixed(2));
  if (a >= 1e-3) return trim(v.toFixed(4));
  return v.toExponential(0);
}

/** Seconds with their unit: "0.4 s", "12 ms", "100 µs", "20 ns". */
export function tickSeconds(v) {
  const a = Math.abs(v);
  const short = (x) => Number(x.toPrecision(3)).toString();
  if (a === 0) return '0 s';
  if (a >= 0.1) return `${short(v)} s`;
  if (a >= 1e-3) return `${short(v * 1e3)} ms`;
  if (a >= 1e-6) return `${short(v * 1e6)} µs`;
  return `${short(v * 1e9)} ns`;
}

/** True when an axis counts seconds (its label says so). */
export function isSeconds(axis) {
  return /\bseconds\b|\(s\)/i.test(axis.label || '');
}

/** Plot options for a numeric axis: our tick labels; on a log axis ticks at the powers of ten
 * inside `domain` when there are two or more (else Plot's, labelled alike). */
export function numericTicks(axis, domain) {
  const format = isSeconds(axis) ? tickSeconds : tickNumber;
  if (!axis.log || !domain) return { tickFormat: format };
  const [lo, hi] = domain.map(Math.log10);
  const powers = [];
  for (let k = Math.ceil(lo - 1e-9); k <= Math.floor(hi + 1e-9); k++) powers.push(10 ** k);
  return powers.length >= 2 ? { ticks: powers, tickFormat: format } : { tickFormat: format };
}

/** The places of a front's numbers 1, 2, ... around its rings at `rings` (pixels, radius
 * `ring`), `size`-pixel text of width `widthOf(text)`: each the first box, at growing distance
 * and in eight directions (above first), that overlaps no ring and no number placed before it;
 * one beyond the first distance stands apart, with a leader line (as the PNG's, figure/draw.rs). */
export function frontLabels(rings, ring, size, widthOf) {
  const overlap = (a, b) => a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3];
  const obstacles = rings.map(([x, y]) => [x - ring, y - ring, x + ring, y + ring]);
  const dirs = [[0, -1], [0, 1], [1, 0], [-1, 0], [0.7, -0.7], [-0.7, -0.7], [0.7, 0.7], [-0.7, 0.7]];
  const placed = [];
  return rings.map(([x, y], k) => {
    const w = widthOf(String(k + 1)) + 2;
    const h = size;
    for (let step = 0; step < 8; step++) {
      const d = ring + 2 + step * (h + 2);
      for (const [ux, uy] of dirs) {
        const c = [x + ux * (d + w / 2), y + uy * (d + h / 2)];
        const b = [c[0] - w / 2, c[1] - h / 2, c[0] + w / 2, c[1] + h / 2];
        if (!placed.concat(obstacles).some((o) => overlap(o, b))) {
          placed.push(b);
          return { centre: c, leader: step > 0 };
        }
      }
    }
    const c = [x, y - ring - 2 - h / 2];
    placed.push([c[0] - w / 2, c[1] - h / 2, c[0] + w / 2, c[1] + h / 2]);
    return { centre: c, leader: false };
  });
}

/** Numbers the rings of a front drawn in `plot` (its points `pts`), placed by frontLabels. */
function numberFront(plot, pts, className, ring) {
  const sx = plot.scale('x');
  const sy = plot.scale('y');
  if (!sx || !sy) return;
  const rings = pts.map((p) => [sx.apply(p.x), sy.apply(p.y)]);
  const size = 11;
  const places = frontLabels(rings, ring, size, (t) => 6.5 * t.length);
  const ns = 'http://www.w3.org/2000/svg';
  const g = document.createElementNS(ns, 'g');
  g.setAttribute('class', `${className} ps-front-numbers`);
  places.forEach((place, k) => {
    const [x, y] = rings[k];
    if (place.leader) {
      const line = document.createElementNS(ns, 'line');
      const [dx, dy] = [place.centre[0] - x, place.centre[1] - y];
      const len = Math.max(Math.hypot(dx, dy), 1e-9);
      line.setAttribute('x1', x + (dx / len) * ring);
      line.setAttribute('y1', y + (dy / len) * ring);
      line.setAttribute('x2', place.centre[0] - (dx / len) * size * 0.6);
      line.setAttribute('y2', place.centre[1] - (dy / len) * size * 0.6);
      line.setAttribute('stroke', '#787878');
      g.append(line);
    }
    const text = document.createElementNS(ns, 'text');
    text.setAttribute('x', place.centre[0]);
    text.setAttribute('y', place.centre[1]);
    text.setAttribute('text-anchor', 'middle');
    text.setAttribute('dominant-baseline', 'central');
    text.setAttribute('font-size', size);
    text.textContent = String(k + 1);
    g.append(text);
  });
  const svg = plot.tagName === 'svg' ? plot : plot.querySelector('svg');
  if (svg) svg.append(g);
}

/** A legend identity: series with equal keys are one entry (the same method and variant). */
export function seriesKey(s) {
  return `${s.method}|${s.family}|${s.variant}|${s.label}`;
}

/** The range of `values` padded by 5 %, as the PNG's axes (log: in decades). */
function padded(values, log) {
  const v = values.filter((x) => Number.isFinite(x) && (!log || x > 0)).map((x) => (log ? Math.log10(x) : x));
  if (!v.length) return undefined;
  let lo = Math.min(...v);
  let hi = Math.max(...v);
  if (lo === hi) {
    const d = log ? 0.5 : Math.max(Math.abs(lo), 1e-3) * 0.05;
    [lo, hi] = [lo - d, hi + d];
  } else {
    const d = (hi - lo) * 0.05;
    [lo, hi] = [lo - d, hi + d];
  }
  return log ? [10 ** lo, 10 ** hi] : [lo, hi];
}

/** The hover text of point `p` of series `s` in figure `fig`. */
export function tipText(fig, s, p) {
  const lines = [s.context ? `${s.label} (context)` : s.label];
  if (p.name) lines.push(p.name);
  const setting = p.setting || s.setting;
  if (setting) lines.push(`setting: ${setting.replaceAll(';', ' ')}`);
  const x = fig.x.categories ? fig.x.categories[Math.round(p.x)] : num(p.x);
  lines.push(`${fig.x.label}: ${x}`);
  const interval = p.y_lo != null ? ` [${num(p.y_lo)}, ${num(p.y_hi)}]${fig.interval ? ` (${fig.interval})` : ''}` : '';
  lines.push(`${fig.y.label}: ${num(p.y)}${interval}`);
  if (p.seconds != null) lines.push(`seconds: ${tickSeconds(p.seconds)}`);
  return lines.join('\n');
}

function main(data) {
  const style = document.createElement('style');
  style.textContent = CSS;
  document.head.append(style);
  const shapes = data.markers;
  const figures = data.figures;
  const state = {
    // Per figure, the legend keys hidden by a click.
    hidden: figures.map(() => new Set()),
    // Families hidden by the filter.
    familiesOff: new Set(),
    renders: 0,
  };

  const families = [];
  for (const f of figures) {
    for (const p of f.panels) {
      for (const s of p.series) if (!s.context && !families.includes(s.family)) families.push(s.family);
    }
  }

  const main = el('main');
  document.body.append(main);
  main.append(el('h1', {}, data.title));
  if (data.note) main.append(el('div', { class: 'note' }, data.note));
  const nav = el('nav', { class: 'note' });
  for (const l of data.links || []) nav.append(el('a', { href: l.href }, l.label));
  main.append(nav);

  // The family filter.
  const filter = el('div', { id: 'ps-families' }, el('b', {}, 'families: '));
  const boxes = new Map();
  const setAll = (on) => {
    for (const [f, box] of boxes) {
      box.checked = on;
      if (on) state.familiesOff.delete(f);
      else state.familiesOff.add(f);
    }
    drawAll();
  };
  filter.append(el('button', { onclick: () => setAll(true) }, 'all'), el('button', { onclick: () => setAll(false) }, 'none'));
  for (const f of families) {
    const box = el('input', { type: 'checkbox', 'data-family': f });
    box.checked = true;
    box.addEventListener('change', () => {
      if (box.checked) state.familiesOff.delete(f);
      else state.familiesOff.add(f);
      drawAll();
    });
    boxes.set(f, box);
    filter.append(el('label', {}, box, ` ${f}`));
  }
  if (families.length > 1) main.append(filter);

  const holders = figures.map((fig, fi) => {
    const panels = el('div', { class: 'panels' });
    const legend = el('div', { class: 'legend' });
    main.append(
      el('h2', { id: fig.id }, fig.title),
      el('div', { class: 'figure', 'data-figure': fig.id }, panels, legend),
      ...(fig.notes || []).map((n) => el('div', { class: 'figure-notes' }, n)),
      el('div', { class: 'files' }, 'data: ', el('a', { href: `${fig.id}.json` }, `${fig.id}.json`), ' · picture: ', el('a', { href: fig.png }, fig.png)),
    );
    return { panels, legend, fi };
  });

  const shown = (fi, s) => !state.hidden[fi].has(seriesKey(s)) && !state.familiesOff.has(s.family);

  function drawLegend(fig, fi, legend) {
    legend.replaceChildren();
    const seen = new Set();
    const fronts = [];
    let context = false;
    for (const p of fig.panels) {
      for (const s of p.series) {
        if (s.context) {
          context = true;
          continue;
        }
        const key = seriesKey(s);
        if (seen.has(key)) continue;
        seen.add(key);
        if (s.draw === 'front') fronts.push(s);
        const entry = el('div', { class: 'entry', 'data-key': key, title: 'click: hide or show' }, swatch(s.style, shapes), el('span', {}, s.label));
        if (!shown(fi, s)) entry.classList.add('off');
        entry.addEventListener('click', () => {
          if (state.hidden[fi].has(key)) state.hidden[fi].delete(key);
          else state.hidden[fi].add(key);
          draw(fi);
        });
        legend.append(entry);
      }
    }
    if (context) {
      legend.append(el('div', { class: 'key' }, swatch({ color: '#bbbbbb', marker: 'dot', fill: 'filled', dasharray: [] }, shapes), ' other families (context)'));
    }
    for (const s of fronts) {
      s.points.forEach((p, k) => legend.append(el('div', { class: 'key' }, `${k + 1} ${p.name || ''}`)));
    }
  }

  function draw(fi) {
    const fig = figures[fi];
    const { panels, legend } = holders[fi];
    const categorical = Array.isArray(fig.x.categories);
    const all = fig.panels.flatMap((p) => p.series.flatMap((s) => s.points));
    const xDomain = categorical ? [-0.5, fig.x.categories.length - 0.5] : padded(all.flatMap((p) => [p.x, p.x_lo, p.x_hi]), fig.x.log);
    const yDomain = padded(all.flatMap((p) => [p.y, p.y_lo, p.y_hi]), fig.y.log);
    const single = fig.panels.length <= 1;
    const width = single ? 1000 : fig.panels.length <= 2 ? 480 : fig.panels.length <= 4 ? 420 : 330;
    const height = single ? 520 : fig.panels.length <= 2 ? 340 : fig.panels.length <= 4 ? 300 : 250;
    panels.replaceChildren();
    fig.panels.forEach((panel, pi) => {
      const marks = [];
      const tips = [];
      // Front series: numbered after the plot is drawn, placed apart from each other.
      const fronts = [];
      const own = panel.series.filter((s) => !s.context && shown(fi, s));
      let dodge = 0;
      panel.series.forEach((s, si) => {
        if (!shown(fi, s)) return;
        const className = `ps-series ps-series-${fi}-${pi}-${si}`;
        const line = s.draw === 'line' || s.draw === 'front';
        let dx = 0;
        if (categorical && !s.context) {
          const slot = Math.min(0.8 / Math.max(own.length, 1), 0.12);
          dx = (dodge - (own.length - 1) / 2) * slot;
          dodge++;
        }
        const pts = s.points.map((p) => ({ ...p, x: p.x + dx }));
        if (s.context) {
          if (line) marks.push(Plot.line(pts, { x: 'x', y: 'y', stroke: '#bbbbbb', strokeWidth: 1, className }));
          else marks.push(Plot.dot(pts, { x: 'x', y: 'y', r: 2, fill: '#bbbbbb', className }));
          return;
        }
        const st = s.style;
        const bars = pts.filter((p) => p.y_lo != null);
        if (bars.length) marks.push(Plot.ruleX(bars, { x: 'x', y1: 'y_lo', y2: 'y_hi', stroke: st.color, strokeOpacity: 0.55, className }));
        const xbars = pts.filter((p) => p.x_lo != null);
        if (xbars.length) marks.push(Plot.ruleY(xbars, { y: 'y', x1: 'x_lo', x2: 'x_hi', stroke: st.color, strokeOpacity: 0.55, className }));
        if (line) {
          marks.push(Plot.line(pts, { x: 'x', y: 'y', stroke: st.color, strokeWidth: 2, strokeDasharray: (st.dasharray || []).join(','), className }));
        }
        marks.push(
          Plot.dot(pts, {
            x: 'x',
            y: 'y',
            symbol: symbolOf(shapes, st.marker),
            r: st.marker === 'ring' ? 7 : single ? 4.5 : 3.5,
            fill: markerFill(st),
            stroke: st.color,
            strokeWidth: st.fill === 'hollow' || st.marker === 'ring' ? 2 : 1,
            className,
          }),
        );
        if (s.draw === 'front') fronts.push({ pts, className });
        for (const p of s.points) tips.push({ x: p.x + dx, y: p.y, text: tipText(fig, s, p) });
      });
      // The figure's vertical rules (LOD budgets, say) inside the x range, labelled at the top.
      const rules = (fig.rules || []).filter((r) => !xDomain || (r.x > xDomain[0] && r.x < xDomain[1]));
      if (rules.length) {
        marks.unshift(
          Plot.ruleX(rules, { x: 'x', stroke: '#787878', strokeDasharray: '5,3', className: 'ps-rule' }),
          Plot.text(rules, { x: 'x', text: 'label', frameAnchor: 'top', rotate: 90, textAnchor: 'start', dx: -5, dy: 4, fill: '#464646', fontSize: 10, className: 'ps-rule-label' }),
        );
      }
      marks.push(Plot.tip(tips, Plot.pointer({ x: 'x', y: 'y', title: 'text', lineWidth: 60, maxRadius: 30 })));
      const plot = Plot.plot({
        width,
        height,
        marginLeft: 60,
        marginBottom: 44,
        style: { fontSize: '11px', overflow: 'visible' },
        x: {
          type: fig.x.log ? 'log' : 'linear',
          domain: xDomain,
          label: fig.x.label,
          labelAnchor: 'center',
          labelArrow: 'none',
          grid: true,
          ...(categorical ? { ticks: fig.x.categories.map((_, k) => k), tickFormat: (k) => fig.x.categories[k] ?? '' } : numericTicks(fig.x, xDomain)),
        },
        // The y axis' description stands above the plot (wrapped, never clipped).
        y: { type: fig.y.log ? 'log' : 'linear', domain: yDomain, label: null, grid: true, ...numericTicks(fig.y, yDomain) },
        marks,
      });
      for (const f of fronts) numberFront(plot, f.pts, f.className, single ? 7 : 5.6);
      const holder = el('div', { class: 'panel', 'data-panel': String(pi) });
      if (panel.title) holder.append(el('h3', {}, panel.title));
      holder.append(el('div', { class: 'ylabel', style: `max-width: ${width}px` }, `↑ ${fig.y.label}`));
      holder.append(plot);
      panels.append(holder);
    });
    drawLegend(fig, fi, legend);
    state.renders++;
  }

  function drawAll() {
    figures.forEach((_, fi) => draw(fi));
  }

  drawAll();
  // Jump to a figure named in the fragment (#ID), now that it exists.
  if (location.hash) document.getElementById(decodeURIComponent(location.hash.slice(1)))?.scrollIntoView();

  window.pointsightResults = {
    data,
    state,
    families,
    seriesKey,
    /** Hides or shows legend entry `key` of figure `fi`, as a click does. */
    toggle(fi, key) {
      if (state.hidden[fi].has(key)) state.hidden[fi].delete(key);
      else state.hidden[fi].add(key);
      draw(fi);
    },
  };
  window.resultsReady = true;
}

try {
  main(JSON.parse(document.getElementById('pointsight-data').textContent));
} catch (err) {
  window.resultsError = String(err && err.stack ? err.stack : err);
  document.body.append(Object.assign(document.createElement('pre'), { textContent: `pointsight results: ${window.resultsError}` }));
  throw err;
}
