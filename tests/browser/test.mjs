// Headless-Chromium test of the viewer on the sample day (run by tests/browser/run.sh,
// which exports the day and serves the page):
//
//     node test.mjs URL GLB OUT_DIR VIEWER_HTML SCENE_TOML
//
// URL is `daystep view`'s page URL; GLB the same file, for the file:// check; SCENE_TOML the
// scene, for its site (solar noon). Assertions are on screenshot pixels and on what a user
// does (hover, wheel, buttons), so they test what a user sees. glTF frame of the office:
// x east, y up, z = -north; the room is x 0..6, z -8..0, its window in the south wall z = 0.
import { chromium } from 'playwright-core';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import zlib from 'node:zlib';
import { pathToFileURL } from 'node:url';

const [url, glb, outDir, viewerHtml, sceneToml] = process.argv.slice(2);
fs.mkdirSync(outDir, { recursive: true });

const BASE = ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync',
  // A foreign name that resolves to 127.0.0.1, as a DNS-rebinding attacker arranges.
  '--host-resolver-rules=MAP attacker.example 127.0.0.1'];
// Without a GPU, WebGL needs SwiftShader; newer Chromium only allows it when asked.
const FALLBACKS = [[], ['--enable-unsafe-swiftshader'],
  ['--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'], ['--use-gl=swiftshader']];

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
const rgbAt = (img, x, y) => { const i = (y * img.w + x) * img.bpp; return [img.px[i], img.px[i + 1], img.px[i + 2]]; };
const luma = (c) => 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
// Mean luma (0..255 of the encoded values) over a rectangle {x0, y0, x1, y1} (image pixels).
function meanLuma(img, r) {
  let s = 0, n = 0;
  for (let y = r.y0; y < r.y1; y++) for (let x = r.x0; x < r.x1; x++) { s += luma(rgbAt(img, x, y)); n++; }
  return s / n;
}
function meanAbsDiff(a, b) {
  let s = 0;
  for (let i = 0; i < a.px.length; i++) s += Math.abs(a.px[i] - b.px[i]);
  return s / a.px.length;
}

// Solar noon in local standard time (hours) from the site alone: 12 h, less the longitude's
// offset from the zone's meridian (4 min per degree), less the equation of time (Spencer 1971).
function solarNoonH(dayOfYear, longitudeDeg, utcOffsetH) {
  const g = 2 * Math.PI * (dayOfYear - 1) / 365;
  const eotMin = 229.18 * (0.000075 + 0.001868 * Math.cos(g) - 0.032077 * Math.sin(g)
    - 0.014615 * Math.cos(2 * g) - 0.040849 * Math.sin(2 * g));
  return 12 - (longitudeDeg - 15 * utcOffsetH) / 15 - eotMin / 60;
}
const tomlNumber = (text, key) => Number(new RegExp('^' + key + '\\s*=\\s*([-0-9.eE+]+)', 'm').exec(text)[1]);

async function waitReady(page, what) {
  await page.waitForFunction(() => window.__ready === true || window.__error, null, { timeout: 30000 });
  const err = await page.evaluate(() => window.__error);
  if (err) throw new Error(what + ': the viewer says: ' + err);
}

async function shot(page, name) {
  // Two animation frames: the next one draws the new state, the one after shows it.
  await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
  const png = await page.locator('#gl').screenshot();
  if (name) fs.writeFileSync(path.join(outDir, name), png);
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
// Content-Security-Policy violations and every error the console shows.
const cspViolations = [], consoleErrors = [];
for (const extra of FALLBACKS) {
  run = await launch(extra);
  page = run.ctx.pages()[0] || await run.ctx.newPage();
  const requests = [];
  page.on('request', (r) => requests.push(r.url()));
  page.on('console', (m) => {
    if (m.type() === 'error') consoleErrors.push(m.text());
    if (/Content Security Policy/i.test(m.text())) cspViolations.push(m.text());
  });
  page.on('pageerror', (e) => consoleErrors.push('uncaught: ' + e.message));
  pageResponse = await page.goto(url);
  try { await waitReady(page, url); } catch (e) {
    if (/WebGL/.test(e.message)) {
      console.log('no WebGL with [' + extra.join(' ') + '], trying the next flags');
      consoleErrors.length = 0; cspViolations.length = 0;
      await run.ctx.close(); continue;
    }
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
const box = await page.locator('#gl').boundingBox();
const toImg = (p) => ({ x: Math.round(p.x - box.x), y: Math.round(p.y - box.y) });

// ---- the first view: the frame nearest solar noon, framed on the sensors from inside ----
const st0 = await page.evaluate(() => window.__state());
const toml = fs.readFileSync(sceneToml, 'utf8');
const first = st0.labels[0], day0 = first.slice(0, 10);
const doy = Math.round((Date.UTC(+day0.slice(0, 4), +day0.slice(5, 7) - 1, +day0.slice(8, 10)) - Date.UTC(+day0.slice(0, 4), 0, 1)) / 864e5) + 1;
const noon = solarNoonH(doy, tomlNumber(toml, 'longitude'), tomlNumber(toml, 'utc_offset_h'));
const hourOf = (l) => +l.slice(11, 13) + +l.slice(14, 16) / 60;
let want = 0;
st0.labels.forEach((l, i) => { if (l.startsWith(day0) && Math.abs(hourOf(l) - noon) < Math.abs(hourOf(st0.labels[want]) - noon)) want = i; });
check(st0.frame === want, `opens on the first day's frame nearest solar noon (${noon.toFixed(2)} h local standard time): ${st0.labels[st0.frame]} (want ${st0.labels[want]})`);

const sensors = await page.evaluate(() => window.__visibleSensors());
const nSensors = await page.evaluate(() => window.__state().labels && document.querySelector('#status').textContent);
const total = Number((/(\d+) sensors/.exec(nSensors) || [0, 0])[1]);
check(sensors.length >= 0.5 * total, `the first view sees most sensors: ${sensors.length} of ${total} in view and not hidden`);
// The room region: the rectangle of the visible sensors' images.
const room = { x0: Infinity, y0: Infinity, x1: -Infinity, y1: -Infinity };
for (const s of sensors) {
  const p = toImg(s);
  room.x0 = Math.min(room.x0, p.x); room.y0 = Math.min(room.y0, p.y);
  room.x1 = Math.max(room.x1, p.x + 1); room.y1 = Math.max(room.y1, p.y + 1);
}
const view0 = await shot(page, 'first-view.png');
room.x0 = Math.max(0, room.x0); room.y0 = Math.max(0, room.y0); room.x1 = Math.min(view0.w, room.x1); room.y1 = Math.min(view0.h, room.y1);
const roomText = `x ${room.x0}..${room.x1}, y ${room.y0}..${room.y1}`;
check((room.x1 - room.x0) * (room.y1 - room.y0) >= 0.2 * view0.w * view0.h, `the room region (${roomText}) covers at least 20 % of the image`);
const m0 = meanLuma(view0, room) / 255;
check(m0 >= 0.15 && m0 <= 0.85, `first view, room region ${roomText}: mean ${(100 * m0).toFixed(1)} % of full scale (15..85 %), exposure ${st0.exposureEv.toFixed(2)} EV`);

// ---- cracks: the ground seen from 30 m up, smooth but for the building, where a crack
// between elements lets through what lies behind (the background). A crack pixel is darker than both its neighbours across the line (left and
// right, or above and below) by over 16 levels of luma while those two agree within 6.
// With and without the edge pass.
function cracks(img, r) {
  let n = 0;
  for (let y = r.y0; y < r.y1; y++) for (let x = r.x0; x < r.x1; x++) {
    const c = luma(rgbAt(img, x, y));
    for (const [a, b] of [[rgbAt(img, x - 1, y), rgbAt(img, x + 1, y)], [rgbAt(img, x, y - 1), rgbAt(img, x, y + 1)]]) {
      const la = luma(a), lb = luma(b);
      if (Math.abs(la - lb) <= 6 && la - c > 16 && lb - c > 16) { n++; break; }
    }
  }
  return n;
}
await page.locator('#sensors').uncheck();
await page.evaluate(() => window.__setView([3, 30, 6], [3, 0, -4]));
const withEdges = await shot(page, 'ground_edges_on.png');
await page.evaluate(() => window.__setEdges(false));
const noEdges = await shot(page, 'ground_edges_off.png');
await page.evaluate(() => window.__setEdges(true));
await page.locator('#sensors').check();
await page.click('#inside');
// Open ground west of the building, clear of its walls and of the block's shadow.
const open = { x0: 40, y0: 60, x1: 320, y1: 370 };
const cOn = cracks(withEdges, open), cOff = cracks(noEdges, open);
// The export splits T-junctions (export::tjunction), so there are none even without the
// page's edge pass (before the split: 20 without it, 7 with it).
check(cOn === 0 && cOff === 0, `cracks: single dark pixels on open ground seen from 30 m up (x ${open.x0}..${open.x1}, y ${open.y0}..${open.y1}): ${cOn} with the edge pass, ${cOff} without`);

// ---- falsecolor illuminance: legend bands in the room, and the dots' colours ----
await page.selectOption('#mode', '2');
const legendPng = await page.locator('#legend').screenshot();
fs.writeFileSync(path.join(outDir, 'legend.png'), legendPng);
const legendImg = decodePng(legendPng);
const lg = (await page.evaluate(() => window.__state())).legend;
// The element's screenshot includes its padding; the layout is in canvas pixels.
const pad = await page.evaluate(() => parseFloat(getComputedStyle(document.querySelector('#legend')).paddingTop));
lg.x += pad; lg.top += pad;
// The legend's colour ramp as drawn: row y holds value max·(1 − (y + 0.5)/h).
const ramp = [];
for (let y = 0; y < lg.h; y++) ramp.push(rgbAt(legendImg, lg.x + (lg.w >> 1), lg.top + y));
const rampAt = (v) => {
  const f = Math.min(lg.h - 1, Math.max(0, (1 - v / lg.max) * lg.h - 0.5)), y0 = Math.floor(f), y1 = Math.min(lg.h - 1, y0 + 1), t = f - y0;
  return [0, 1, 2].map((c) => ramp[y0][c] * (1 - t) + ramp[y1][c] * t);
};
await page.locator('#sensors').uncheck();
const fcPlain = await shot(page, 'first-view-falsecolor-surfaces.png');
const bandCount = new Array(lg.bands).fill(0);
let classified = 0, area = 0;
for (let y = room.y0; y < room.y1; y++) for (let x = room.x0; x < room.x1; x++) {
  const c = rgbAt(fcPlain, x, y);
  let best = -1, bd = 3 * 10 * 10;
  ramp.forEach((r, k) => { const d = (r[0] - c[0]) ** 2 + (r[1] - c[1]) ** 2 + (r[2] - c[2]) ** 2; if (d < bd) { bd = d; best = k; } });
  area++;
  if (best < 0) continue;
  classified++;
  bandCount[Math.min(lg.bands - 1, Math.floor((1 - (best + 0.5) / lg.h) * lg.bands))]++;
}
const bands = bandCount.filter((n) => n >= 0.01 * area).length;
check(bands >= 4, `falsecolor illuminance (max ${lg.max} lux): the room region shows ${bands} legend bands with >= 1 % of its pixels each (${bandCount.map((n) => (100 * n / area).toFixed(1) + '%').join(' ')}; ${(100 * classified / area).toFixed(0)} % of pixels on the legend's ramp)`);

await page.locator('#sensors').check();
const fc = await shot(page, 'first-view-falsecolor.png');
// Dots well apart from the others (so no neighbour overlaps them), below the legend's top
// (a value above it clamps), spread over the values.
const apart = sensors.filter((s) => s.lux < lg.max && sensors.every((o) => o === s || Math.hypot(o.x - s.x, o.y - s.y) > 12));
apart.sort((a, b) => a.lux - b.lux);
const picks = [0.1, 0.4, 0.7, 0.95].map((q) => apart[Math.floor(q * (apart.length - 1))]).filter(Boolean);
check(picks.length >= 3, `${apart.length} sensor dots clear of their neighbours to compare with the legend`);
for (const s of picks) {
  await page.mouse.move(s.x, s.y);
  await page.waitForTimeout(50);
  const tip = await page.locator('#tip').textContent();
  const m = /^sensor (\d+): ([\d.]+) lux$/.exec(tip || '');
  const p = toImg(s), got = rgbAt(fc, p.x, p.y);
  const want_ = m ? rampAt(Number(m[2])) : [NaN, NaN, NaN];
  const err = Math.max(...[0, 1, 2].map((c) => Math.abs(got[c] - want_[c])));
  check(m && Number(m[1]) === s.i && err <= 6,
    `sensor dot ${s.i} (tooltip "${tip}"): colour ${got.join(',')} vs the legend's at its value ${want_.map(Math.round).join(',')} (max |difference| ${err.toFixed(1)} <= 6)`);
}

// ---- tooltips only for sensors in sight: from outside the windowless north wall ----
await page.selectOption('#mode', '0');
const st1 = await page.evaluate(() => window.__state());
await page.evaluate(() => window.__setView([3, 1.6, -22], [3, 0.8, -4]));
await shot(page);
const behind = await page.evaluate(() => window.__project([3, 0.8, -4]));
const hidden = [];
for (const [x, z] of [[1, -6], [3, -4], [5, -2], [2, -7]]) {
  const at = await page.evaluate((q) => window.__project(q), [x, 0.8, z]);
  await page.mouse.move(at.x, at.y);
  await page.waitForTimeout(30);
  const tip = await page.locator('#tip').textContent();
  if (tip) hidden.push(tip);
}
check(behind && hidden.length === 0, `from outside the north wall, hovering where sensors lie behind it shows no tooltip (${hidden.length ? hidden.join('; ') : 'none'})`);

// ---- the inside button, and an orbit drag before it ----
await page.mouse.move(box.x + 400, box.y + 300);
await page.mouse.down();
await page.mouse.move(box.x + 480, box.y + 330, { steps: 5 });
await page.mouse.up();
const orbit = await shot(page, 'orbit_drag.png');
await page.click('#inside');
const again = await shot(page, 'inside_again.png');
const dIn = meanAbsDiff(view0, again), dOrbit = meanAbsDiff(view0, orbit);
check(dOrbit > 5 && dIn < 1, `after looking from outside and an orbit drag (mean |difference| ${dOrbit.toFixed(1)}), "inside" returns to the first view (${dIn.toFixed(2)})`);

// ---- zoom towards the cursor ----
const zs = sensors.filter((s) => Math.abs(s.x - box.x - box.width / 2) > 150 && Math.abs(s.y - box.y - box.height / 2) > 50)[0];
await page.mouse.move(zs.x, zs.y);
await page.mouse.wheel(0, -400);
await shot(page);
const after = await page.evaluate((i) => window.__visibleSensors().find((s) => s.i === i), zs.i);
const moved = after ? Math.hypot(after.x - zs.x, after.y - zs.y) : Infinity;
const spread = await page.evaluate(() => { const v = window.__visibleSensors(); return v.length; });
check(moved < 2 && spread < sensors.length, `wheel zoom at sensor ${zs.i}: it stays under the cursor (moved ${moved.toFixed(2)} px) while the view narrows (${spread} of ${sensors.length} sensors still in view)`);
await page.click('#inside');

// ---- automatic exposure per frame, and its lock ----
await page.evaluate(() => window.__setFrame(0));
await waitReady(page, 'frame 0');
const dawn = await shot(page, 'dawn.png');
const st2 = await page.evaluate(() => window.__state());
const mDawn = meanLuma(dawn, room) / 255;
check(st2.exposureEv > st1.exposureEv + 1 && mDawn >= 0.15 && mDawn <= 0.85,
  `auto exposure at ${st2.labels[0]}: ${st2.exposureEv.toFixed(2)} EV (noon ${st1.exposureEv.toFixed(2)} EV), room mean ${(100 * mDawn).toFixed(1)} %`);
await page.locator('#expLock').check();
await page.evaluate((k) => window.__setFrame(k), st0.frame);
const lockedNoon = await shot(page, 'noon_locked.png');
const st3 = await page.evaluate(() => window.__state());
check(st3.exposureEv === st2.exposureEv && meanLuma(lockedNoon, room) > meanLuma(view0, room) + 20,
  `locked, noon keeps the dawn exposure (${st3.exposureEv.toFixed(2)} EV) and is brighter than auto-exposed noon (${(100 * meanLuma(lockedNoon, room) / 255).toFixed(0)} % vs ${(100 * m0).toFixed(0)} %)`);
await page.locator('#expLock').uncheck();

// ---- the slider, walking ----
await page.locator('#frame').fill(String(st0.frame));
const back0 = await shot(page, 'slider_back.png');
const d0 = meanAbsDiff(view0, back0);
check(d0 < 1, `slider back to the noon frame gives the first view again: mean |difference| ${d0.toFixed(2)}`);
await page.locator('#walk').check();
const walk0 = await shot(page, 'walk_start.png');
await page.keyboard.down('KeyW');
await page.waitForTimeout(600);
await page.keyboard.up('KeyW');
const walk1 = await shot(page, 'walk_forward.png');
const dWalk = meanAbsDiff(walk0, walk1);
check(dWalk > 2, `walking forward (W held 0.6 s) changes the view: mean |difference| ${dWalk.toFixed(1)}`);
await page.locator('#walk').uncheck();

await page.waitForTimeout(1200);
const fps = await page.evaluate(() => window.__fps);
console.log(`fps: ${fps} (window.__fps, 800 x 600, ${renderer})`);
check(fps > 0, 'window.__fps is reported');

const foreign = run.requests.filter((u) => !u.startsWith('http://127.0.0.1:'));
check(foreign.length === 0, `no request leaves 127.0.0.1 (${run.requests.length} requests${foreign.length ? ': ' + foreign.join(' ') : ''})`);
check(consoleErrors.length === 0, `the console shows no error (${consoleErrors.length}${consoleErrors.length ? ': ' + consoleErrors.join(' | ') : ''})`);

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

// file:// with the file picker, as opened straight from disk: the same first view.
run = await launch(flags);
page = run.ctx.pages()[0] || await run.ctx.newPage();
const reqs = [];
page.on('request', (r) => reqs.push(r.url()));
await page.goto(pathToFileURL(viewerHtml).href);
await page.setInputFiles('#file', glb);
await waitReady(page, 'file://');
const ff = await shot(page, 'file_first_view.png');
const dff = ff.w === view0.w && ff.h === view0.h ? meanAbsDiff(view0, ff) : Infinity;
check(dff < 1, `file:// page with the file picker draws the same first view as over http: mean |difference| ${dff.toFixed(2)}`);
check(reqs.every((u) => u.startsWith('file:')), `file:// page makes no network request (${reqs.length} requests)`);
await run.ctx.close();

console.log(failed ? `${failed} check(s) failed` : 'all checks passed');
console.log('screenshots: ' + outDir);
process.exit(failed ? 1 : 0);
