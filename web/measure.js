// Measures a viewer page in headless Chromium (SwiftShader WebGL, no GPU): the first frame
// and the fully drawn frame after navigation (performance.now(), median over the loads), and
// the median time of a frame while orbiting (OrbitControls' auto-rotation, 60 frames; each
// frame waits for the GPU by reading one pixel back).
//
//   node web/measure.js PAGE.html [LOADS]
//
// Prints one line: page=... bytes=... loads=... first_frame_ms=... complete_ms=...
// frame_ms_median=... frame_ms_min=... frame_ms_max=...

import { statSync } from 'node:fs';

import { launch, openPage } from './test/browser.js';

const [file, loadsArg] = process.argv.slice(2);
if (!file) {
  console.error('usage: node web/measure.js PAGE.html [LOADS]');
  process.exit(2);
}
const loads = Number(loadsArg || 3);
const median = (v) => [...v].sort((a, b) => a - b)[v.length >> 1];
const browser = await launch();
const first = [];
const complete = [];
let frames = null;
for (let k = 0; k < loads; k++) {
  const { page } = await openPage(browser, file, '', { width: 1280, height: 720 });
  const s = await page.evaluate(() => window.pointsight.state);
  first.push(s.firstFrameMs);
  complete.push(s.completeMs);
  if (k === loads - 1) frames = await page.evaluate(() => window.pointsight.benchmark(60));
  await page.close();
}
await browser.close();
console.log(
  `page=${file} bytes=${statSync(file).size} loads=${loads} first_frame_ms=${median(first).toFixed(0)} ` +
    `complete_ms=${median(complete).toFixed(0)} frame_ms_median=${frames.median.toFixed(1)} ` +
    `frame_ms_min=${frames.min.toFixed(1)} frame_ms_max=${frames.max.toFixed(1)}`,
);
