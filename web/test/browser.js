// Helpers of the viewer's browser tests and measurements: Debian's headless Chromium driven by
// playwright-core, pages made by the pointsight binary, pixel counts read back from the canvas.

import { spawnSync } from 'node:child_process';
import { existsSync, mkdtempSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';

import { chromium } from 'playwright-core';

export const REPO = resolve(dirname(fileURLToPath(import.meta.url)), '../..');
export const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';
export const BIN = process.env.POINTSIGHT_BIN || join(REPO, 'target/debug/pointsight');

/** Why the browser tests cannot run here, or null; under CI=true a missing browser fails. */
export function skipReason() {
  if (existsSync(CHROMIUM)) return null;
  const why = `${CHROMIUM} is missing (scripts/browser.sh installs it)`;
  if (process.env.CI === 'true') throw new Error(`CI=true and ${why}`);
  return why;
}

/** Headless Chromium with software WebGL (SwiftShader), a fresh profile (playwright's own). */
export async function launch() {
  return chromium.launch({
    executablePath: CHROMIUM,
    headless: true,
    args: [
      '--no-sandbox',
      '--use-angle=swiftshader',
      '--enable-unsafe-swiftshader',
      '--disable-background-networking',
      '--disable-component-update',
      '--disable-sync',
      '--no-first-run',
    ],
  });
}

/** A fresh scratch folder. */
export function scratch() {
  return mkdtempSync(join(tmpdir(), 'pointsight-viewer-'));
}

/** Runs `pointsight ARGS` in the repository; its stdout, or throws with its stderr. */
export function pointsight(args) {
  if (!existsSync(BIN)) throw new Error(`${BIN} is missing: cargo build -p harness (or set POINTSIGHT_BIN)`);
  const r = spawnSync(BIN, args, { cwd: REPO, encoding: 'utf8', maxBuffer: 1 << 26 });
  if (r.status !== 0) throw new Error(`pointsight ${args.join(' ')} failed:\n${r.stderr}`);
  return r.stdout;
}

/** Opens a page from disk (file://) at the camera's image size; resolves when fully drawn. */
export async function openPage(browser, file, fragment, viewport) {
  const page = await browser.newPage({ viewport });
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  const t = Date.now();
  await page.goto(`${pathToFileURL(file).href}#${fragment}`);
  await page.waitForFunction(() => window.viewerComplete === true || window.viewerError, null, { timeout: 60_000 });
  const wall = Date.now() - t;
  const error = await page.evaluate(() => window.viewerError || null);
  if (error || errors.length) throw new Error(`page error: ${error || errors.join('; ')}`);
  return { page, wall };
}

/** Shows method `name` and waits until the viewer has drawn it. */
export async function showMethod(page, name) {
  const f = await page.evaluate((n) => {
    const before = window.pointsight.state.frames;
    window.pointsight.setMethod(n);
    return before;
  }, name);
  await page.waitForFunction((k) => window.pointsight.state.frames > k && !window.pointsight.state.dirty, f);
}

/**
 * The canvas's pixels (read through a 2D canvas, independent of the viewer's code): counts of
 * the exact colours asked, and a mask of the non-white pixels as a string of 0/1.
 */
export async function pixels(page, colors) {
  return page.evaluate((colors) => {
    const gl = document.querySelector('#ps-canvas canvas');
    const c = document.createElement('canvas');
    c.width = gl.width;
    c.height = gl.height;
    const ctx = c.getContext('2d');
    ctx.drawImage(gl, 0, 0);
    const d = ctx.getImageData(0, 0, c.width, c.height).data;
    const counts = Object.fromEntries(Object.keys(colors).map((k) => [k, 0]));
    const mask = new Uint8Array(c.width * c.height);
    for (let p = 0; p < c.width * c.height; p++) {
      const [r, g, b] = [d[4 * p], d[4 * p + 1], d[4 * p + 2]];
      if (r !== 255 || g !== 255 || b !== 255) mask[p] = 1;
      for (const [k, v] of Object.entries(colors)) {
        if (Math.abs(r - v[0]) <= 2 && Math.abs(g - v[1]) <= 2 && Math.abs(b - v[2]) <= 2) counts[k]++;
      }
    }
    return { width: c.width, height: c.height, counts, mask: Array.from(mask).join('') };
  }, colors);
}

/** The non-white mask of a PNG file, decoded by the browser. */
export async function pngMask(page, pngBase64) {
  return page.evaluate(async (b64) => {
    const img = new Image();
    img.src = `data:image/png;base64,${b64}`;
    await img.decode();
    const c = document.createElement('canvas');
    c.width = img.width;
    c.height = img.height;
    const ctx = c.getContext('2d');
    ctx.drawImage(img, 0, 0);
    const d = ctx.getImageData(0, 0, c.width, c.height).data;
    let s = '';
    for (let p = 0; p < c.width * c.height; p++) {
      s += d[4 * p] !== 255 || d[4 * p + 1] !== 255 || d[4 * p + 2] !== 255 ? '1' : '0';
    }
    return { width: c.width, height: c.height, mask: s };
  }, pngBase64);
}

/** The mask grown by a disc of `r` pixels. */
export function dilate(mask, w, h, r) {
  const out = new Uint8Array(w * h);
  for (let y = 0; y < h; y++) {
    for (let x = 0; x < w; x++) {
      if (mask[y * w + x] !== '1') continue;
      for (let dy = -r; dy <= r; dy++) {
        for (let dx = -r; dx <= r; dx++) {
          const [u, v] = [x + dx, y + dy];
          if (dx * dx + dy * dy <= r * r && u >= 0 && v >= 0 && u < w && v < h) out[v * w + u] = 1;
        }
      }
    }
  }
  return out;
}

/** Intersection over union of two 0/1 arrays. */
export function iou(a, b) {
  let inter = 0;
  let union = 0;
  for (let i = 0; i < a.length; i++) {
    if (a[i] && b[i]) inter++;
    if (a[i] || b[i]) union++;
  }
  return union === 0 ? 1 : inter / union;
}
