// The experiments' results pages in a real browser (Debian's headless Chromium): pages written by
// `pointsight tables` from the committed robustness and lod results, opened from disk. Every
// figure draws as many series as its data lists; a series hidden from the legend is gone from
// the picture, a family unticked leaves none of its colour; hovering a point names it (method,
// setting, score with its interval). The landing page `index.html` the same run writes: a row per
// finding, sorted by a click on a heading and filtered by its search box, every link to a file
// that exists, no request off the disk. Skipped (with the reason) only outside CI when Chromium
// is missing.

import assert from 'node:assert/strict';
import { cpSync, existsSync, mkdirSync, readFileSync } from 'node:fs';
import { join } from 'node:path';
import { pathToFileURL } from 'node:url';
import { after, before, test } from 'node:test';

import { REPO, launch, pointsight, scratch, skipReason } from './browser.js';

const skip = skipReason() || false;
let browser;
let dir;

before(async () => {
  if (skip) return;
  dir = scratch();
  // The committed results, redrawn by this build (figures, twins and pages).
  for (const exp of ['robustness', 'lod']) {
    mkdirSync(join(dir, exp));
    for (const f of ['results.csv', 'metadata.json', 'lod.csv', 'builds.csv', 'srn_table.csv']) {
      try {
        cpSync(join(REPO, 'reports', exp, f), join(dir, exp, f));
      } catch {
        // Not every experiment has every file.
      }
    }
  }
  pointsight(['tables', '--reports', dir]);
  browser = await launch();
});
after(async () => {
  if (browser) await browser.close();
});

/** The page's embedded data. */
function dataOf(file) {
  const html = readFileSync(file, 'utf8');
  return JSON.parse(html.match(/<script id="pointsight-data" type="application\/json">(.*?)<\/script>/s)[1]);
}

async function open(file) {
  const page = await browser.newPage({ viewport: { width: 1500, height: 1000 } });
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  await page.goto(pathToFileURL(file).href);
  await page.waitForFunction(() => window.resultsReady === true || window.resultsError, null, { timeout: 60_000 });
  const error = await page.evaluate(() => window.resultsError || null);
  if (error || errors.length) throw new Error(`page error: ${error || errors.join('; ')}`);
  return page;
}

/** The series drawn in figure `fi`: the distinct `ps-series-FI-P-S` classes in its SVGs. */
async function drawn(page, fi) {
  return page.evaluate((fi) => {
    const out = new Set();
    for (const e of document.querySelectorAll(`[class*="ps-series-${fi}-"]`)) {
      for (const c of e.classList) if (c.startsWith(`ps-series-${fi}-`)) out.add(c);
    }
    return [...out].sort();
  }, fi);
}

/** Pixels of the figure `id` within 12 of `rgb` (per channel), from a screenshot. */
async function colourPixels(page, id, rgb) {
  const box = await page.locator(`.figure[data-figure="${id}"] .panels`).boundingBox();
  const png = await page.screenshot({ clip: box });
  return page.evaluate(
    async ([b64, rgb]) => {
      const img = new Image();
      img.src = `data:image/png;base64,${b64}`;
      await img.decode();
      const c = document.createElement('canvas');
      [c.width, c.height] = [img.width, img.height];
      const ctx = c.getContext('2d');
      ctx.drawImage(img, 0, 0);
      const d = ctx.getImageData(0, 0, c.width, c.height).data;
      let n = 0;
      for (let p = 0; p < d.length; p += 4) {
        if (Math.abs(d[p] - rgb[0]) <= 12 && Math.abs(d[p + 1] - rgb[1]) <= 12 && Math.abs(d[p + 2] - rgb[2]) <= 12) n++;
      }
      return n;
    },
    [png.toString('base64'), rgb],
  );
}

const rgbOf = (hex) => [1, 3, 5].map((k) => parseInt(hex.slice(k, k + 2), 16));

test('every figure draws the series its data lists', { skip }, async () => {
  for (const exp of ['robustness', 'lod']) {
    const file = join(dir, exp, 'results.html');
    const data = dataOf(file);
    assert.ok(data.figures.length >= 2, `${exp}: ${data.figures.length} figures`);
    const page = await open(file);
    for (const [fi, fig] of data.figures.entries()) {
      const listed = fig.panels.reduce((n, p) => n + p.series.length, 0);
      const got = await drawn(page, fi);
      assert.equal(got.length, listed, `${exp}/${fig.id}: ${got.length} series drawn, ${listed} in the data`);
    }
    await page.screenshot({ path: join(dir, `${exp}-results.png`), fullPage: false });
    await page.close();
  }
});

test('a series hidden from the legend is gone from the picture', { skip }, async () => {
  const file = join(dir, 'robustness', 'results.html');
  const data = dataOf(file);
  const fi = data.figures.findIndex((f) => f.id.startsWith('f1_noise_'));
  assert.ok(fi >= 0, 'no noise figure');
  const fig = data.figures[fi];
  const page = await open(file);
  const before = await drawn(page, fi);
  // The first legend entry, clicked as a reader would.
  const entry = page.locator(`.figure[data-figure="${fig.id}"] .legend .entry`).first();
  const key = await entry.getAttribute('data-key');
  await entry.click();
  const owned = [];
  fig.panels.forEach((p, pi) =>
    p.series.forEach((s, si) => {
      if (`${s.method}|${s.family}|${s.variant}|${s.label}` === key) owned.push(`ps-series-${fi}-${pi}-${si}`);
    }),
  );
  assert.ok(owned.length >= 1, `no series has key ${key}`);
  const after = await drawn(page, fi);
  assert.equal(after.length, before.length - owned.length, `${key}: ${before.length} → ${after.length}`);
  for (const c of owned) assert.ok(!after.includes(c), `${c} is still drawn`);
  // A click again brings it back.
  await entry.click();
  assert.equal((await drawn(page, fi)).length, before.length);

  // A family unticked: none of its colour is left in the picture (its own panel and its grey
  // context copies alike).
  const s = fig.panels.flatMap((p) => p.series).find((x) => !x.context && x.family === 'raycast');
  assert.ok(s, 'raycast is in the noise figure');
  const rgb = rgbOf(s.style.color);
  const present = await colourPixels(page, fig.id, rgb);
  assert.ok(present > 100, `raycast's colour covers only ${present} pixels`);
  await page.locator('#ps-families input[data-family="raycast"]').uncheck();
  const left = await colourPixels(page, fig.id, rgb);
  // pcu-raycast, the peer of raycast, shares its colour: untick it too.
  await page.locator('#ps-families input[data-family="pcu-raycast"]').uncheck();
  const none = await colourPixels(page, fig.id, rgb);
  console.log(`raycast's colour: ${present} px, ${left} px without raycast, ${none} px without pcu-raycast too`);
  assert.ok(left < present, `${left} >= ${present}`);
  assert.equal(none, 0, `${none} pixels of raycast's colour left`);
  await page.close();
});

test('hovering a point names it', { skip }, async () => {
  const file = join(dir, 'lod', 'results.html');
  const data = dataOf(file);
  const fi = data.figures.findIndex((f) => f.id.startsWith('psnr_vs_points_'));
  assert.ok(fi >= 0, 'no PSNR figure');
  const fig = data.figures[fi];
  const page = await open(file);
  // Every marker's centre on the screen, with its series and point.
  const dots = await page.evaluate((fi) => {
    const out = [];
    for (const g of document.querySelectorAll(`g[aria-label="dot"][class*="ps-series-${fi}-"]`)) {
      const cls = [...g.classList].find((c) => c.startsWith(`ps-series-${fi}-`));
      [...g.querySelectorAll('path, circle')].forEach((e, k) => {
        const r = e.getBoundingClientRect();
        out.push({ cls, k, x: r.x + r.width / 2, y: r.y + r.height / 2 });
      });
    }
    return out;
  }, fi);
  // A marker with no other within 25 px: the one the pointer will be nearest to.
  const lone = dots.find((d) => dots.every((o) => o === d || Math.hypot(o.x - d.x, o.y - d.y) > 25));
  assert.ok(lone, `no isolated point among ${dots.length}`);
  const [, , pi, si] = lone.cls.split('-').slice(1).map(Number);
  const s = fig.panels[pi].series[si];
  const p = s.points[lone.k];
  await page.mouse.move(lone.x, lone.y);
  await page.waitForFunction(() => {
    const t = document.querySelector('g[aria-label="tip"]');
    return t && t.textContent.length > 0;
  });
  const text = await page.evaluate(() => document.querySelector('g[aria-label="tip"]').textContent);
  console.log(`hover over ${s.label} point ${lone.k}: ${text}`);
  assert.ok(text.includes(s.label), `tip ${text} does not name ${s.label}`);
  const setting = (p.setting || s.setting).replaceAll(';', ' ');
  assert.ok(text.includes(setting), `tip ${text} lacks the setting ${setting}`);
  assert.ok(text.includes(Number(p.y.toPrecision(4)).toString()), `tip ${text} lacks the score ${p.y}`);
  assert.ok(text.includes('seconds'), `tip ${text} lacks the time`);
  await page.screenshot({ path: join(dir, 'lod-hover.png') });
  await page.close();
});

test('the LOD curves mark every budget with a labelled rule; ticks print "0.05" and seconds with their unit', { skip }, async () => {
  const file = join(dir, 'lod', 'results.html');
  const data = dataOf(file);
  const page = await open(file);
  for (const [fi, fig] of data.figures.entries()) {
    if (!fig.id.startsWith('psnr_vs_points_')) continue;
    assert.deepEqual(
      fig.rules.map((r) => r.label),
      ['1 %', '2 %', '5 %', '10 %', '20 %', '30 %'],
      `${fig.id}: rules`,
    );
    const labels = await page.evaluate((id) => {
      const fig = document.querySelector(`.figure[data-figure="${id}"]`);
      return {
        rules: fig.querySelectorAll('g[aria-label="rule"].ps-rule line').length,
        texts: [...fig.querySelectorAll('g[aria-label="text"].ps-rule-label text')].map((t) => t.textContent),
      };
    }, fig.id);
    // Every panel draws every rule inside the data's x range (a budget below the fewest points
    // drawn, or above the most, may fall outside the padded axis and is then not drawn).
    const xs = fig.panels.flatMap((p) => p.series.flatMap((s) => s.points.map((q) => q.x)));
    const [lo, hi] = [Math.min(...xs), Math.max(...xs)];
    const inside = fig.rules.filter((r) => r.x >= lo && r.x <= hi);
    assert.ok(inside.length >= 3, `${fig.id}: ${inside.length} budgets inside ${lo}..${hi}`);
    assert.ok(
      labels.rules >= inside.length * fig.panels.length && labels.rules <= 6 * fig.panels.length,
      `${fig.id}: ${labels.rules} rule lines for ${inside.length} budgets inside the data, ${fig.panels.length} panels`,
    );
    for (const r of inside) assert.ok(labels.texts.includes(r.label), `${fig.id}: no label ${r.label} in ${labels.texts}`);
    void fi;
  }
  // Tick labels: no middle dot, no SI suffix on seconds.
  const ticks = await page.evaluate(() => [...document.querySelectorAll('g[aria-label$="tick label"] text')].map((t) => t.textContent));
  assert.ok(ticks.length > 20, `${ticks.length} tick labels`);
  for (const t of ticks) assert.ok(!/·|\d[mun]$/.test(t), `tick label ${t}`);
  const timeFig = data.figures.find((f) => f.id.startsWith('time_vs_points_'));
  const timeTicks = await page.evaluate(
    (id) => [...document.querySelectorAll(`.figure[data-figure="${id}"] g[aria-label="y-axis tick label"] text`)].map((t) => t.textContent),
    timeFig.id,
  );
  assert.ok(timeTicks.length >= 2 && timeTicks.every((t) => / (s|ms|µs|ns)$/.test(t)), `seconds ticks ${timeTicks}`);
  // The y axis' description is printed whole above the plots.
  const ylabels = await page.evaluate((id) => [...document.querySelectorAll(`.figure[data-figure="${id}"] .ylabel`)].map((e) => e.textContent), timeFig.id);
  assert.ok(ylabels.length >= 1 && ylabels.every((t) => t.includes(timeFig.y.label)), `y labels ${ylabels}`);
  await page.close();
});

test('the landing page lists, sorts and filters the findings and links only to files that exist', { skip }, async () => {
  const file = join(dir, 'index.html');
  const page = await browser.newPage({ viewport: { width: 1500, height: 1000 } });
  const errors = [];
  const offDisk = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  page.on('request', (r) => {
    if (!r.url().startsWith('file:')) offDisk.push(r.url());
  });
  await page.goto(pathToFileURL(file).href);
  await page.waitForFunction(() => window.landingReady === true, null, { timeout: 30_000 });
  assert.deepEqual(errors, []);

  // One row per finding (findings.csv has no line breaks inside its fields).
  const csv = readFileSync(join(dir, 'findings.csv'), 'utf8').trim().split('\n');
  const rows = page.locator('#findings-table tbody tr');
  const n = await rows.count();
  assert.ok(n >= 10, `${n} findings`);
  assert.equal(n, csv.length - 1);

  // Every link resolves: a file of the folder, or an element of the page.
  const hrefs = await page.evaluate(() => [...document.querySelectorAll('a[href]')].map((a) => a.getAttribute('href')));
  for (const h of hrefs) {
    if (h.startsWith('#')) {
      assert.ok(await page.locator(`[id="${h.slice(1)}"]`).count(), `no element for ${h}`);
    } else {
      assert.ok(existsSync(join(dir, decodeURIComponent(h.split('#')[0]))), `${h} is missing`);
    }
  }
  // A row of one dataset links the figure of that dataset.
  const links = await page.evaluate(() =>
    [...document.querySelectorAll('#findings-table tbody tr')].map((r) => [r.cells[1].textContent, r.querySelector('a.figure').getAttribute('href')]),
  );
  const lod = links.find(([c]) => c.startsWith('bunny-69451 at distance'));
  assert.ok(lod, 'no LOD finding on bunny-69451');
  assert.match(lod[1], /^lod\/psnr_vs_points_bunny-69451\.png$/);
  // The experiments that ran link their interactive pages; one card per method with results.
  for (const exp of ['robustness', 'lod']) {
    assert.equal(await page.locator(`li[data-experiment="${exp}"] a.results`).count(), 1, exp);
  }
  for (const m of ['qsplat', 'random', 'raycast']) {
    assert.equal(await page.locator(`article[data-method="${m}"]`).count(), 1, `no card for ${m}`);
  }

  // A click on the value's heading sorts by it, a second click the other way.
  const values = () =>
    page.evaluate(() =>
      [...document.querySelectorAll('#findings-table tbody tr')].map((r) => parseFloat(r.cells[6].getAttribute('data-sort'))),
    );
  const heading = page.locator('#findings-table thead th', { hasText: 'value' });
  await heading.click();
  const up = await values();
  assert.deepEqual(up, [...up].sort((a, b) => a - b));
  await heading.click();
  const down = await values();
  assert.deepEqual(down, [...down].sort((a, b) => b - a));
  assert.notDeepEqual(up, down);

  // The filter keeps the rows that contain its text.
  await page.locator('#filter').fill('qsplat');
  const kept = await page.evaluate(() =>
    [...document.querySelectorAll('#findings-table tbody tr')].filter((r) => !r.hidden).map((r) => r.textContent.toLowerCase()),
  );
  assert.ok(kept.length >= 1 && kept.length < n, `${kept.length} of ${n} kept`);
  assert.ok(kept.every((t) => t.includes('qsplat')));
  assert.equal(await page.locator('#shown').textContent(), `${kept.length} of ${n} findings shown`);
  await page.screenshot({ path: join(dir, 'landing.png'), fullPage: false });
  assert.deepEqual(offDisk, [], 'requests off the disk');
  await page.close();
});
