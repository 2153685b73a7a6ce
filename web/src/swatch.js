// A method's visual identity as the harness gives it (crates/harness/src/output/style.rs): a
// style {color, marker, fill, dash, dasharray} and the marker shapes as polygons, both passed
// in the page's data, never tabled here. Used by the results pages (figures and legends) and
// by the 3D viewer pages (a swatch beside each method's name).

const SVG = 'http://www.w3.org/2000/svg';

/** An SVG element with attributes. */
export function svgEl(tag, attrs = {}) {
  const e = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  return e;
}

/** The SVG path data of `marker`'s polygon (from `shapes`) at radius `r` about (cx, cy). */
export function markerPath(shapes, marker, r, cx = 0, cy = 0) {
  const poly = shapes[marker] || shapes.circle;
  return `${poly.map(([u, v], k) => `${k ? 'L' : 'M'}${(cx + u * r).toFixed(2)},${(cy + v * r).toFixed(2)}`).join('')}Z`;
}

/** The fill of a marker of `style`: white when hollow (a peer) or a ring. */
export function markerFill(style) {
  return style.fill === 'hollow' || style.marker === 'ring' ? 'white' : style.color;
}

/**
 * A d3 symbol type drawing `marker`'s polygon, for Observable Plot's dot mark: `size` is the
 * area Plot asks for, the polygon is scaled to the radius of a circle of that area.
 */
export function symbolOf(shapes, marker) {
  const poly = shapes[marker] || shapes.circle;
  return {
    draw(context, size) {
      const r = Math.sqrt(size / Math.PI);
      poly.forEach(([u, v], k) => (k ? context.lineTo(u * r, v * r) : context.moveTo(u * r, v * r)));
      context.closePath();
    },
  };
}

/** A 36 × 14 swatch: the style's line (with its dash) and its marker (14 × 14: the marker). */
export function swatch(style, shapes, { line = true } = {}) {
  // Without the line: the marker alone, at the same size.
  const svg = line
    ? svgEl('svg', { width: 36, height: 14, viewBox: '0 0 36 14', class: 'ps-swatch' })
    : svgEl('svg', { width: 14, height: 14, viewBox: '11 0 14 14', class: 'ps-swatch' });
  if (line) {
    svg.append(
      svgEl('line', {
        x1: 2,
        y1: 7,
        x2: 34,
        y2: 7,
        stroke: style.color,
        'stroke-width': 2,
        'stroke-dasharray': (style.dasharray || []).join(' '),
      }),
    );
  }
  svg.append(
    svgEl('path', {
      d: markerPath(shapes, style.marker, 4.5, 18, 7),
      fill: markerFill(style),
      stroke: style.color,
      'stroke-width': style.fill === 'hollow' ? 2 : 1,
    }),
  );
  return svg;
}
