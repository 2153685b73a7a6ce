// The page's embedded data (written by `pointsight view`, crates/harness/src/view/page.rs):
// base64 decoding, bitsets, and each method's classes against the reference.
//
// Layout (every array in the page's point order, a seeded shuffle whose prefixes are uniform
// subsamples): `positions`: little-endian uint16 x, y, z per point, quantised over `box`;
// bitsets: bit i is bit (i & 7) of byte (i >> 3).

/** Bytes of a base64 string. */
export function bytesOf(b64) {
  const text = atob(b64);
  const out = new Uint8Array(text.length);
  for (let i = 0; i < text.length; i++) out[i] = text.charCodeAt(i);
  return out;
}

/** A bitset of n bits from base64; null stays null. */
export function bitsOf(b64) {
  return b64 == null ? null : bytesOf(b64);
}

/** Bit i of a bitset. */
export function bit(bits, i) {
  return (bits[i >> 3] >> (i & 7)) & 1;
}

/** The quantised positions (uint16, 3 per point). */
export function positionsOf(b64, n) {
  const bytes = bytesOf(b64);
  if (bytes.length !== 6 * n) {
    throw new Error(`positions: expected ${6 * n} bytes, got ${bytes.length}`);
  }
  // Little-endian on every browser platform pointsight targets; copy to be aligned.
  return new Uint16Array(bytes.buffer, bytes.byteOffset, 3 * n);
}

/** Class numbers, in drawing order (renders.png draws hidden first, false positives last). */
export const HIDDEN = 0;
export const TRUE_POSITIVE = 1;
export const FALSE_NEGATIVE = 2;
export const FALSE_POSITIVE = 3;
export const OFF_SURFACE = 4;
export const CLASSES = 5;

/**
 * Per class, the indices (ascending) of the points in it for one method: `visible` against
 * `truth`; points flagged in `off` form their own class whatever the method says.
 */
export function classify(n, truth, visible, off) {
  const counts = new Uint32Array(CLASSES);
  const cls = new Uint8Array(n);
  for (let i = 0; i < n; i++) {
    let c;
    if (off && bit(off, i)) c = OFF_SURFACE;
    else {
      const t = bit(truth, i);
      const v = bit(visible, i);
      c = t ? (v ? TRUE_POSITIVE : FALSE_NEGATIVE) : v ? FALSE_POSITIVE : HIDDEN;
    }
    cls[i] = c;
    counts[c]++;
  }
  const lists = Array.from(counts, (k) => new Uint32Array(k));
  const fill = new Uint32Array(CLASSES);
  for (let i = 0; i < n; i++) {
    const c = cls[i];
    lists[c][fill[c]++] = i;
  }
  return { lists, counts };
}

/** Entries of a sorted index list below m (binary search): the prefix drawn of it. */
export function countBelow(list, m) {
  let lo = 0;
  let hi = list.length;
  while (lo < hi) {
    const mid = (lo + hi) >> 1;
    if (list[mid] < m) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}
