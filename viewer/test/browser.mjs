// Real-browser test of the viewer: headless Chromium (Debian's /usr/bin/chromium, driven by
// playwright-core) opens BASE_URL/viewer?job=JOB_ID, waits until the job's GLB has loaded
// through three.js' GLTFLoader, fails on any console error, page error or failed request,
// shows only the shells (drill holes and samples toggled off), takes a screenshot and checks
// by pixels that the bodies are visible, then toggles the shells off and checks that the
// view is empty. Then checks the grade–tonnage chart beside the bodies: its points carry
// the summary's figures, its curves are drawn (a PNG of it, OUT-chart.png, for the CI log),
// and the legend shows the first body's tonnes.
//
// Usage: node viewer/test/browser.mjs BASE_URL JOB_ID OUT.png
// Environment: CHROMIUM (default /usr/bin/chromium), VIEWER_TIMEOUT_MS (default 120000).
import { mkdtemp, rm, writeFile } from 'node:fs/promises';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { chromium } from 'playwright-core';

const [base, jobId, outPng] = process.argv.slice(2);
if (!base || !jobId || !outPng) {
  console.error('usage: node viewer/test/browser.mjs BASE_URL JOB_ID OUT.png');
  process.exit(2);
}
const executablePath = process.env.CHROMIUM ?? '/usr/bin/chromium';
const timeout = Number(process.env.VIEWER_TIMEOUT_MS ?? 120000);
// The viewer's clear colour (viewer.js BACKGROUND).
const BACKGROUND = [0x1d, 0x21, 0x26];
const MIN_BODY_SHARE = 0.02;
const MAX_EMPTY_SHARE = 0.002;

// Decodes a screenshot with the browser's own PNG decoder and counts the pixels that differ
// from the background.
async function countModelPixels(page, png) {
  const { total, differing } = await page.evaluate(
    async ({ b64, background }) => {
      const image = new Image();
      image.src = `data:image/png;base64,${b64}`;
      await image.decode();
      const c = document.createElement('canvas');
      c.width = image.width;
      c.height = image.height;
      const ctx = c.getContext('2d');
      ctx.drawImage(image, 0, 0);
      const { data } = ctx.getImageData(0, 0, c.width, c.height);
      let count = 0;
      for (let i = 0; i < data.length; i += 4) {
        const d = Math.max(
          Math.abs(data[i] - background[0]),
          Math.abs(data[i + 1] - background[1]),
          Math.abs(data[i + 2] - background[2]),
        );
        if (d > 24) count += 1;
      }
      return { total: c.width * c.height, differing: count };
    },
    { b64: png.toString('base64'), background: BACKGROUND },
  );
  return { total, differing, share: differing / total };
}

const problems = [];
const userDataDir = await mkdtemp(join(tmpdir(), 'wellmesh-chromium-'));
let context;
try {
  context = await chromium.launchPersistentContext(userDataDir, {
    executablePath,
    headless: true,
    viewport: { width: 1200, height: 800 },
    args: [
      '--headless',
      '--no-sandbox',
      '--disable-gpu',
      '--disable-quic',
      '--no-first-run',
      '--disable-background-networking',
      '--disable-component-update',
      '--disable-sync',
      // WebGL through the software rasterizer: there is no GPU.
      '--use-angle=swiftshader',
      '--enable-unsafe-swiftshader',
    ],
  });
  const page = context.pages()[0] ?? (await context.newPage());
  page.on('console', (msg) => {
    if (msg.type() === 'error') problems.push(`console error: ${msg.text()}`);
  });
  page.on('pageerror', (err) => problems.push(`page error: ${err.message}`));
  page.on('requestfailed', (req) => problems.push(`request failed: ${req.url()} ${req.failure()?.errorText}`));
  page.on('response', (res) => {
    if (res.status() >= 400) problems.push(`HTTP ${res.status()} for ${res.url()}`);
  });

  const url = `${base.replace(/\/$/, '')}/viewer?job=${encodeURIComponent(jobId)}`;
  await page.goto(url, { waitUntil: 'load', timeout });
  await page.waitForFunction(
    () => window.wellmeshViewer?.loaded || window.wellmeshViewer?.error,
    null,
    { timeout, polling: 250 },
  );
  const state = await page.evaluate(() => ({ ...window.wellmeshViewer }));
  if (state.error) problems.push(`viewer error: ${state.error}`);
  if (!state.loaded) problems.push('the GLB did not load');
  if (!(state.meshes > 0)) problems.push(`no meshes in the scene (${state.meshes})`);
  // Let a few frames render after the load.
  await page.waitForTimeout(500);

  // Only the shells: hide drill holes and samples, so the pixels counted are the bodies'.
  const layers = page.locator('#layer-list li');
  const shellBoxes = [];
  for (let i = 0; i < (await layers.count()); i += 1) {
    const item = layers.nth(i);
    const box = item.locator('input[type=checkbox]');
    if ((await item.innerText()).trim().startsWith('shell')) shellBoxes.push(box);
    else await box.setChecked(false);
  }
  if (shellBoxes.length === 0) problems.push('no shell layers in the layer list');

  const canvas = page.locator('#canvas');
  const modelShare = async () => {
    await page.waitForTimeout(300);
    const png = await canvas.screenshot({ timeout });
    return { png, ...(await countModelPixels(page, png)) };
  };
  const shown = await modelShare();
  await writeFile(outPng, shown.png);
  console.log(
    `viewer: ${state.meshes} meshes; ${shown.differing} of ${shown.total} pixels ` +
      `(${(100 * shown.share).toFixed(1)}%) show the shells; screenshot ${outPng}`,
  );
  if (shown.share < MIN_BODY_SHARE) {
    problems.push(`blank view: only ${(100 * shown.share).toFixed(2)}% of pixels show the shells`);
  }
  // Toggling every shell off must leave the background: the pixels were the bodies'.
  for (const box of shellBoxes) await box.setChecked(false);
  const hidden = await modelShare();
  console.log(`with the shells toggled off: ${(100 * hidden.share).toFixed(2)}% of pixels differ`);
  if (hidden.share > MAX_EMPTY_SHARE) {
    problems.push(`toggling the shells off left ${(100 * hidden.share).toFixed(2)}% of pixels drawn`);
  }
  for (const box of shellBoxes) await box.setChecked(true);

  // The grade–tonnage chart beside the bodies: drawn, a PNG of it for the CI log, and the
  // figures of the summary in the chart's points and the legend.
  const results = await page.evaluate(async (id) => {
    const r = await fetch(`/jobs/${encodeURIComponent(id)}/results`);
    return r.json();
  }, jobId);
  const rows = results.summary?.report?.grade_tonnage ?? [];
  if (results.chart?.href) {
    await page.waitForFunction(() => window.wellmeshViewer?.chart, null, { timeout, polling: 250 });
    const chartPng = outPng.replace(/\.png$/, '') + '-chart.png';
    const png = await page.locator('#chart').screenshot({ timeout });
    await writeFile(chartPng, png);
    const svg = await page.evaluate(async (href) => (await fetch(href)).text(), results.chart.href);
    const points = [...svg.matchAll(/<circle class="point"[^>]*>/g)].map((m) => m[0]);
    const attr = (el, name) => {
      const found = el.match(new RegExp(` ${name}="([^"]*)"`));
      return found ? Number(found[1]) : null;
    };
    if (points.length !== rows.length) {
      problems.push(`the chart has ${points.length} points, the summary ${rows.length} cut-offs`);
    }
    rows.forEach((row, i) => {
      const el = points[i] ?? '';
      const left = row.tonnes ?? row.volume_m3;
      const leftAttr = row.tonnes == null ? 'data-volume' : 'data-tonnes';
      if (attr(el, 'data-cutoff') !== row.cutoff || attr(el, leftAttr) !== left) {
        problems.push(`chart point ${i} is not the summary's cut-off ${row.cutoff}: ${el}`);
      }
      if (row.mean_grade != null && attr(el, 'data-grade') !== row.mean_grade) {
        problems.push(`chart point ${i}: grade ${attr(el, 'data-grade')} vs ${row.mean_grade}`);
      }
    });
    // The chart is drawn: its series' colours are on the screenshot.
    const drawn = await page.evaluate(async (b64) => {
      const image = new Image();
      image.src = `data:image/png;base64,${b64}`;
      await image.decode();
      const c = document.createElement('canvas');
      c.width = image.width;
      c.height = image.height;
      const ctx = c.getContext('2d');
      ctx.drawImage(image, 0, 0);
      const { data } = ctx.getImageData(0, 0, c.width, c.height);
      let blue = 0;
      let orange = 0;
      for (let i = 0; i < data.length; i += 4) {
        const [r, g, b] = [data[i], data[i + 1], data[i + 2]];
        if (b > 150 && r < 90 && g > 90 && g < 160) blue += 1;
        if (r > 190 && g > 70 && g < 130 && b < 60) orange += 1;
      }
      return { blue, orange };
    }, png.toString('base64'));
    console.log(`chart: ${points.length} points, ${drawn.blue} tonnes and ${drawn.orange} grade pixels; ${chartPng}`);
    if (drawn.blue < 50 || drawn.orange < 50) problems.push(`the chart shows no curves (${JSON.stringify(drawn)})`);
    // Tonnes and grade per body in the legend.
    const legend = await page.locator('#legend-rows').innerText();
    const body = results.summary.shells?.[0]?.bodies?.[0]?.resource;
    if (body?.tonnes != null) {
      const shown = body.tonnes.toLocaleString('en', { maximumFractionDigits: 0 });
      if (!legend.includes(shown)) problems.push(`the legend does not show body 1's ${shown} t`);
    }
  } else if (rows.length) {
    problems.push('the summary has a grade–tonnage curve but the results no chart');
  }
} catch (err) {
  problems.push(`browser test: ${err.message}`);
} finally {
  await context?.close();
  await rm(userDataDir, { recursive: true, force: true });
}
for (const p of problems) console.error(p);
console.log(problems.length ? '0 passed, 1 failed' : '1 passed, 0 failed');
process.exit(problems.length ? 1 : 0);
