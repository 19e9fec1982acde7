// Headless-Chromium test of the viewer (run by tests/browser/run.sh, which serves the page):
//
//     node test.mjs URL GLB OUT_DIR VIEWER_HTML
//
// URL is `daystep view`'s page URL; GLB the same file, for the file:// check. Assertions
// are on screenshot pixels, not on the page's own state, so they test what a user sees.
import { chromium } from 'playwright-core';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import zlib from 'node:zlib';
import { pathToFileURL } from 'node:url';

const [url, glb, outDir, viewerHtml] = process.argv.slice(2);
fs.mkdirSync(outDir, { recursive: true });

const BASE = ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync',
  // A foreign name that resolves to 127.0.0.1, as a DNS-rebinding attacker arranges.
  '--host-resolver-rules=MAP attacker.example 127.0.0.1'];
// Without a GPU, WebGL needs SwiftShader; newer Chromium only allows it when asked.
const FALLBACKS = [[], ['--enable-unsafe-swiftshader'],
  ['--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'], ['--use-gl=swiftshader']];

// The room's centre at standing height looking east (glTF frame): the window wall (z = 0)
// is on the right of the image, the back wall (z = -8) on the left.
const EYE = [3, 1.5, -4], TARGET = [6, 1.5, -4];

function decodePng(buf) {
  let off = 8, w = 0, h = 0, type = 0;
  const idat = [];
  while (off < buf.length) {
    const len = buf.readUInt32BE(off), kind = buf.toString('ascii', off + 4, off + 8);
    const data = buf.subarray(off + 8, off + 8 + len);
    if (kind === 'IHDR') {
      w = data.readUInt32BE(0); h = data.readUInt32BE(4); type = data[9];
      if (data[8] !== 8 || data[12] !== 0) throw new Error('PNG: only 8-bit, non-interlaced');
    } else if (kind === 'IDAT') idat.push(data);
    off += 12 + len;
  }
  const bpp = type === 6 ? 4 : type === 2 ? 3 : 0;
  if (!bpp) throw new Error('PNG colour type ' + type);
  const raw = zlib.inflateSync(Buffer.concat(idat)), stride = w * bpp;
  const px = Buffer.alloc(h * stride);
  for (let y = 0; y < h; y++) {
    const f = raw[y * (stride + 1)], src = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    for (let x = 0; x < stride; x++) {
      const a = x >= bpp ? px[y * stride + x - bpp] : 0, b = y ? px[(y - 1) * stride + x] : 0;
      const c = x >= bpp && y ? px[(y - 1) * stride + x - bpp] : 0;
      let p;
      if (f === 0) p = 0; else if (f === 1) p = a; else if (f === 2) p = b; else if (f === 3) p = (a + b) >> 1;
      else { const q = a + b - c, pa = Math.abs(q - a), pb = Math.abs(q - b), pc = Math.abs(q - c); p = pa <= pb && pa <= pc ? a : pb <= pc ? b : c; }
      px[y * stride + x] = (src[x] + p) & 255;
    }
  }
  return { w, h, bpp, px };
}

// Mean Rec. 709 luma (of the encoded values, 0..255) over columns [x0, x1) of the image.
function meanLuma(img, x0, x1) {
  let s = 0, n = 0;
  for (let y = 0; y < img.h; y++) for (let x = Math.floor(x0 * img.w); x < Math.floor(x1 * img.w); x++) {
    const i = (y * img.w + x) * img.bpp;
    s += 0.2126 * img.px[i] + 0.7152 * img.px[i + 1] + 0.0722 * img.px[i + 2]; n++;
  }
  return s / n;
}
function meanAbsDiff(a, b) {
  let s = 0;
  for (let i = 0; i < a.px.length; i++) s += Math.abs(a.px[i] - b.px[i]);
  return s / a.px.length;
}

async function waitReady(page, what) {
  await page.waitForFunction(() => window.__ready === true || window.__error, null, { timeout: 30000 });
  const err = await page.evaluate(() => window.__error);
  if (err) throw new Error(what + ': the viewer says: ' + err);
}

async function shot(page, name) {
  // Two animation frames: the next one draws the new state, the one after shows it.
  await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
  const png = await page.locator('#gl').screenshot();
  fs.writeFileSync(path.join(outDir, name), png);
  return decodePng(png);
}

async function launch(extra) {
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'daystep-chromium-'));
  const ctx = await chromium.launchPersistentContext(dir, {
    executablePath: '/usr/bin/chromium', headless: true, args: [...BASE, ...extra],
    viewport: { width: 800, height: 600 }, deviceScaleFactor: 1,
  });
  return { ctx, dir };
}

let failed = 0;
function check(ok, text) { console.log((ok ? 'ok   ' : 'FAIL ') + text); if (!ok) failed++; }

let run = null, page = null, flags = null, pageResponse = null;
// Content-Security-Policy violations the page reports (Chromium logs each on the console).
const cspViolations = [];
for (const extra of FALLBACKS) {
  run = await launch(extra);
  page = run.ctx.pages()[0] || await run.ctx.newPage();
  const requests = [];
  page.on('request', (r) => requests.push(r.url()));
  page.on('console', (m) => {
    if (m.type() === 'error') console.log('page console: ' + m.text());
    if (/Content Security Policy/i.test(m.text())) cspViolations.push(m.text());
  });
  pageResponse = await page.goto(url);
  try { await waitReady(page, url); } catch (e) {
    if (/WebGL/.test(e.message)) { console.log('no WebGL with [' + extra.join(' ') + '], trying the next flags'); await run.ctx.close(); continue; }
    throw e;
  }
  flags = extra;
  run.requests = requests;
  break;
}
if (!flags) { console.log('FAIL no WebGL under any SwiftShader flag'); process.exit(1); }
const renderer = await page.evaluate(() => {
  const gl = document.createElement('canvas').getContext('webgl2') || document.createElement('canvas').getContext('webgl');
  const d = gl && gl.getExtension('WEBGL_debug_renderer_info');
  return (gl instanceof WebGL2RenderingContext ? 'WebGL2, ' : 'WebGL1, ') + (d ? gl.getParameter(d.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER));
});
console.log('chromium flags: ' + [...BASE, ...flags].join(' '));
console.log('renderer: ' + renderer);

// A real file's first frame can be dawn: BASE_FRAME (run.sh --frame K) picks the frame the
// checks start from.
const K = Number(process.env.BASE_FRAME || 0);
await page.evaluate(([e, t]) => window.__setView(e, t), [EYE, TARGET]);
await page.evaluate((k) => window.__setFrame(k), K);
await waitReady(page, 'view');
const f0 = await shot(page, 'frame0.png');
const back = meanLuma(f0, 0, 1 / 3), window_ = meanLuma(f0, 2 / 3, 1);
check(window_ > back * 1.3 && window_ - back > 15,
  `window side brighter than the back: mean luma right third ${window_.toFixed(1)} vs left third ${back.toFixed(1)} (ratio ${(window_ / back).toFixed(2)})`);

// The other frame: the next one in the test file; in a real day, the first (morning
// against the chosen one).
const OTHER = process.env.BASE_FRAME === undefined ? K + 1 : 0;
await page.evaluate((k) => window.__setFrame(k), OTHER);
await waitReady(page, 'frame 1');
const label = await page.locator('#frameLabel').textContent();
const f1 = await shot(page, 'frame1.png');
const diff = meanAbsDiff(f0, f1);
check(diff > 5, `frame 1 differs from frame 0: mean |difference| ${diff.toFixed(1)} per channel (label "${label}")`);

// The slider itself, as a user moves it, back to frame 0.
await page.locator('#frame').fill(String(K));
const back0 = await shot(page, 'frame0_slider.png');
const d0 = meanAbsDiff(f0, back0);
check(d0 < 1, `slider back to frame 0 gives frame 0's image again: mean |difference| ${d0.toFixed(2)}`);

await page.selectOption('#mode', '1');
const fc = await shot(page, 'falsecolor.png');
const legend = await page.locator('#legend').isVisible();
check(meanAbsDiff(f0, fc) > 5 && legend, `falsecolor mode changes the image and shows the legend (${legend})`);
await page.selectOption('#mode', '0');

// Hover the sensor at (5.5 m east, 3.5 m north, 0.8 m) = sensor 3 * 6 + 5 = 23 in the
// test file (frame 0: 2400 lux x falloff(3.5)), and read the tooltip.
const at = await page.evaluate(() => window.__project([5.5, 0.8, -3.5]));
await page.mouse.move(at.x + 2, at.y + 1);
await page.waitForTimeout(100);
const tip = await page.locator('#tip').textContent();
if (process.env.BASE_FRAME === undefined) {
  check(tip === 'sensor 23: 809 lux', `hovering sensor 23 shows its frame-0 value, 809 lux: "${tip}"`);
} else {
  check(/^sensor \d+: [\d.]+ lux$/.test(tip || ''), `hovering a sensor near (5.5, 0.8, -3.5) shows its value: "${tip}"`);
}

// Orbit: a drag rotates the view; walk: holding W moves the eye.
const box = await page.locator('#gl').boundingBox();
await page.mouse.move(box.x + 400, box.y + 200);
await page.mouse.down();
await page.mouse.move(box.x + 480, box.y + 230, { steps: 5 });
await page.mouse.up();
const orbit = await shot(page, 'orbit_drag.png');
const dOrbit = meanAbsDiff(f0, orbit);
check(dOrbit > 5, `an orbit drag changes the view: mean |difference| ${dOrbit.toFixed(1)}`);
await page.locator('#walk').check();
const walk0 = await shot(page, 'walk_start.png');
await page.keyboard.down('KeyW');
await page.waitForTimeout(600);
await page.keyboard.up('KeyW');
const walk1 = await shot(page, 'walk_forward.png');
const dWalk = meanAbsDiff(walk0, walk1);
check(dWalk > 2, `walking forward (W held 0.6 s) changes the view: mean |difference| ${dWalk.toFixed(1)}`);

await page.waitForTimeout(2500);
const fps = await page.evaluate(() => window.__fps);
console.log(`fps: ${fps} (window.__fps, 800 x 600, ${renderer})`);
check(fps > 0, 'window.__fps is reported');

const foreign = run.requests.filter((u) => !u.startsWith(new URL(url).origin + '/'));
check(foreign.length === 0, `no request leaves the server's origin (${run.requests.length} requests${foreign.length ? ': ' + foreign.join(' ') : ''})`);

// The server's protections, as the browser sees them (docs/viewer-server.md).
const h = pageResponse.headers();
check(/script-src 'sha256-/.test(h['content-security-policy'] || '') && h['x-content-type-options'] === 'nosniff',
  `the page comes with its Content-Security-Policy and nosniff (${h['content-security-policy']})`);
check(cspViolations.length === 0, `the page runs under its Content-Security-Policy with no violation (${cspViolations.length}${cspViolations.length ? ': ' + cspViolations[0] : ''})`);
const glbName = new URL(url).searchParams.get('glb');
const rebound = 'http://attacker.example:' + new URL(url).port;
// The attacker's page, once its name resolves to 127.0.0.1, fetches the model same-origin.
const attacker = await run.ctx.newPage();
const rPage = await attacker.goto(rebound + '/?glb=' + encodeURIComponent(glbName));
const stolen = await attacker.evaluate((p) => fetch(p).then(async (r) => r.status + ', ' + (await r.arrayBuffer()).byteLength + ' bytes'),
  '/' + encodeURIComponent(glbName));
check(rPage.status() === 403 && stolen.startsWith('403'),
  `DNS rebinding: ${rebound} (resolving to 127.0.0.1) gets ${rPage.status()} for the page and ${stolen} for the model`);
// From that foreign origin, a direct cross-origin fetch of the model cannot be read.
const crossRead = await attacker.evaluate((u) => fetch(u).then((r) => r.arrayBuffer())
  .then((b) => 'read ' + b.byteLength + ' bytes', (e) => 'refused: ' + e.message), new URL(url).origin + '/' + glbName);
check(crossRead.startsWith('refused'), `another origin cannot read the model with fetch (${crossRead})`);
await run.ctx.close();

// file:// with the file picker, as opened straight from disk.
run = await launch(flags);
page = run.ctx.pages()[0] || await run.ctx.newPage();
const reqs = [];
page.on('request', (r) => reqs.push(r.url()));
await page.goto(pathToFileURL(viewerHtml).href);
await page.setInputFiles('#file', glb);
await waitReady(page, 'file://');
await page.evaluate(([e, t]) => window.__setView(e, t), [EYE, TARGET]);
await page.evaluate((k) => window.__setFrame(k), K);
await waitReady(page, 'file:// view');
const ff = await shot(page, 'file_frame0.png');
const dff = ff.w === f0.w && ff.h === f0.h ? meanAbsDiff(f0, ff) : Infinity;
check(dff < 1, `file:// page with the file picker draws the same frame 0 as over http: mean |difference| ${dff.toFixed(2)}`);
check(reqs.every((u) => u.startsWith('file:')), `file:// page makes no network request (${reqs.length} requests)`);
await run.ctx.close();

console.log(failed ? `${failed} check(s) failed` : 'all checks passed');
console.log('screenshots: ' + outDir);
process.exit(failed ? 1 : 0);
