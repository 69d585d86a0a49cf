// End-to-end test of `ragdoll view` in a real browser: Debian's Chromium, driven by
// playwright-core (its own browser download cannot work here).
//
//   node .ci/viewer_e2e.mjs BIN [CHARACTER_FILE] [--shots DIR]
//
// Starts BIN view on the character (the built-in humanoid when none is given) on a free
// port, opens the printed URL, and checks with the server's state (GET /api/state) and
// screenshots that:
//   1. the page draws with WebGL2 and receives frames; it shows t = 0, paused, until Play;
//   2. a mouse drag on an arm lifts it while held (the soft pin pulls it up);
//   3. a charge placed by clicking the ground, then "Detonate", throws the character
//      (its centre of mass moves), and the screenshots before and after differ;
//   4. Save writes the spec, and a second Save asks before replacing it; Reset goes back
//      to t = 0, paused;
//   5. malformed and hostile WebSocket messages are dropped with a log line each, the
//      connection that sent them keeps working, and an oversized one closes only its own
//      connection: the server survives all of it; a request naming another host (DNS
//      rebinding) is refused.
import { spawn } from 'node:child_process';
import { existsSync, mkdtempSync, mkdirSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { request as httpRequest } from 'node:http';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { chromium } from 'playwright-core';

const args = process.argv.slice(2);
const shotsAt = args.indexOf('--shots');
let shots = null;
if (shotsAt >= 0) { shots = args[shotsAt + 1]; args.splice(shotsAt, 2); }
const [bin, file] = args;
if (!bin) {
  console.error('usage: node .ci/viewer_e2e.mjs BIN [CHARACTER_FILE] [--shots DIR]');
  process.exit(2);
}
shots = shots || mkdtempSync(join(tmpdir(), 'ragdoll-view-'));
mkdirSync(shots, { recursive: true });
const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';

let passed = 0, failed = 0;
function check(ok, what, detail = '') {
  if (ok) { passed++; console.log(`ok   ${what}${detail ? `: ${detail}` : ''}`); }
  else { failed++; console.log(`FAIL ${what}${detail ? `: ${detail}` : ''}`); }
  return ok;
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// ------------------------------------------------------------------ the server
const saveDir = mkdtempSync(join(tmpdir(), 'ragdoll-view-save-'));
const serverArgs = ['view', ...(file ? [file] : []), '--port', '0', '--no-open', '--save-dir', saveDir];
const server = spawn(bin, serverArgs, { stdio: ['ignore', 'pipe', 'pipe'] });
let stdout = '', stderr = '', exited = null;
server.stdout.on('data', (d) => { stdout += d; });
server.stderr.on('data', (d) => { stderr += d; });
server.on('exit', (code, signal) => { exited = { code, signal }; });

let browser = null;
async function finish() {
  if (browser) await browser.close().catch(() => {});
  if (exited === null) server.kill('SIGTERM');
  writeFileSync(join(shots, 'server.log'), stderr);
  rmSync(saveDir, { recursive: true, force: true });
  console.log(`screenshots and server log in ${shots}`);
  console.log(`viewer e2e: ${passed} passed, ${failed} failed`);
  process.exit(failed === 0 ? 0 : 1);
}
process.on('unhandledRejection', async (e) => {
  check(false, 'the test ran to the end', String(e && e.stack || e));
  await finish();
});

let url = null;
for (let i = 0; i < 300 && !url && exited === null; i++) {
  const m = stdout.match(/http:\/\/127\.0\.0\.1:(\d+)\//);
  if (m) url = m[0];
  else await sleep(100);
}
if (!check(url !== null, 'the server prints its URL', url || `stdout: ${stdout} stderr: ${stderr}`)) await finish();
check(!url.endsWith(':0/'), 'the URL shows the port picked for --port 0', url);

async function state() {
  const r = await fetch(`${url}api/state`);
  if (!r.ok) throw new Error(`GET /api/state: ${r.status}`);
  return r.json();
}
const com = (s) => s.ragdolls[0].centre_of_mass;
const dist = (a, b) => Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);

// ------------------------------------------------------------------ the page
browser = await chromium.launch({
  executablePath: CHROMIUM,
  args: ['--headless', '--no-sandbox', '--no-first-run', '--disable-background-networking',
    '--disable-component-update', '--disable-sync', '--disable-quic',
    '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
});
const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
const pageErrors = [];
page.on('pageerror', (e) => pageErrors.push(String(e)));
page.on('console', (m) => { if (m.type() === 'error') pageErrors.push(m.text()); });
await page.goto(url);
await page.waitForFunction(() => window.viewer && window.viewer.ready && window.viewer.drawn > 3,
  null, { timeout: 30000 }).catch(() => {});
const info = await page.evaluate(() => ({
  ready: window.viewer.ready, webgl: window.viewer.webgl, glError: window.viewer.glError,
  frames: window.viewer.frames, drawn: window.viewer.drawn || 0,
}));
check(info.ready && info.frames > 0, 'the page connects and receives the scene and frames', JSON.stringify(info));
if (!check(info.webgl && info.drawn > 0, 'the page draws with WebGL2', info.glError || '')) await finish();

// The simulation waits at t = 0, paused, until Play: nothing has fallen yet.
const shown = async () => page.evaluate(() => ({
  time: document.getElementById('time').textContent,
  play: document.getElementById('play').textContent,
  t: window.viewer.frame.t, playing: window.viewer.frame.playing,
}));
let s = await state();
const first = await shown();
await sleep(1500);
const later = await shown();
const s2 = await state();
check(first.t === 0 && !first.playing && first.time.startsWith('0.00 s') && first.play === 'Play',
  'the page opens at t = 0, paused, with a Play button', JSON.stringify(first));
check(later.t === 0 && later.time.startsWith('0.00 s') && s.time_s === 0 && s2.time_s === 0 && !s2.playing,
  'it stays at t = 0 until Play', `after 1.5 s the page shows ${later.time}, the server ${s2.time_s} s`);
await page.screenshot({ path: join(shots, '0-paused-at-start.png') });
await page.click('#play');
await sleep(300);
s = await state();
check(s.playing && s.time_s > 0, 'Play starts the simulation', `t = ${s.time_s.toFixed(2)} s`);

// Let the character fall and come to rest.
for (let i = 0; i < 100; i++) {
  const a = com(s);
  await sleep(300);
  s = await state();
  if (s.time_s > 2.5 && dist(a, com(s)) < 0.01) break;
}
check(s.time_s > 2.5, 'the simulation runs in real time', `t = ${s.time_s.toFixed(2)} s`);
await page.screenshot({ path: join(shots, '1-settled.png') });

// ------------------------------------------------------------------ drag an arm
const names = s.ragdolls[0].bodies.map((b) => b.name);
const candidates = ['hand_l', 'hand_r', 'forearm_l', 'forearm_r', 'upper_arm_l', 'upper_arm_r', 'head']
  .map((n) => names.indexOf(n)).filter((i) => i >= 0);
let grab = null;
for (const b of candidates.length ? candidates : names.map((_, i) => i)) {
  const at = await page.evaluate((b) => window.viewer.project(window.viewer.bodyPosition(0, b)), b);
  const hit = await page.evaluate(([x, y]) => window.viewer.pickAt(x, y), [at.x, at.y]);
  if (hit && hit.body === b) { grab = { body: b, at }; break; }
}
if (!check(grab !== null, 'an arm (or the head) is visible under the mouse')) await finish();
const before = (await state()).ragdolls[0].bodies[grab.body].position;
await page.mouse.move(grab.at.x, grab.at.y);
await page.mouse.down();
for (let i = 1; i <= 20; i++) {
  await page.mouse.move(grab.at.x, grab.at.y - 9 * i);
  await sleep(30);
}
await sleep(1500);
s = await state();
const held = s.ragdolls[0].bodies[grab.body].position;
check(s.dragging, 'the server holds a drag while the button is down');
await page.screenshot({ path: join(shots, '2-dragging.png') });
await page.mouse.up();
check(held[1] - before[1] > 0.3,
  `dragging ${names[grab.body]} up by the mouse lifts it`,
  `height ${before[1].toFixed(2)} m → ${held[1].toFixed(2)} m`);
await sleep(300);
s = await state();
check(!s.dragging, 'releasing the button ends the drag');
await sleep(1500);

// ------------------------------------------------------------------ blast by clicks
s = await state();
const c0 = com(s);
// Clear of the character: a click that lands on one of its limbs grabs the limb instead
// (a charge 0.67 m from the centre of mass landed on a hand once in CI).
const charge = [c0[0] + 1.1, 0, c0[2] + 0.5];
// The camera follows the character; while it still eases toward it, a point projected
// now is elsewhere by the time of the click: hold the camera still first.
await page.evaluate(() => { document.getElementById('follow').checked = false; });
await sleep(200);
const click = await page.evaluate((p) => window.viewer.project(p), charge);
await page.mouse.click(click.x, click.y);
const placed = await page.evaluate(() => window.viewer.blastAt);
await page.evaluate(() => { document.getElementById('follow').checked = true; });
check(placed && Math.hypot(placed[0] - charge[0], placed[2] - charge[2]) < 0.05,
  'a click on the ground places the charge there', JSON.stringify(placed));
check(await page.isEnabled('#detonate'), 'the Detonate button is enabled once a charge is placed');
await page.evaluate(() => {
  const set = (id, v) => {
    const el = document.getElementById(id);
    el.value = v;
    el.dispatchEvent(new Event('input'));
  };
  set('tnt', 20); set('height', 0.3); set('delay', 0);
});
const shotBefore = await page.screenshot({ path: join(shots, '3-before-blast.png') });
const t0 = (await state()).time_s;
await page.click('#detonate');
let farthest = 0, highest = c0[1], shotAfter = null;
for (let i = 0; i < 40; i++) {
  await sleep(50);
  s = await state();
  farthest = Math.max(farthest, dist(com(s), c0));
  highest = Math.max(highest, com(s)[1]);
  if (!shotAfter && s.time_s > t0 + 0.35) shotAfter = await page.screenshot({ path: join(shots, '4-after-blast.png') });
}
check(farthest > 1.0, 'the blast throws the character', `its centre of mass moved ${farthest.toFixed(2)} m, rose to ${highest.toFixed(2)} m`);
check(s.events >= 1, 'the server recorded the blast as an event', `events = ${s.events}`);
const changed = await page.evaluate(async ([a, b]) => {
  const load = (b64) => new Promise((res, rej) => {
    const img = new Image();
    img.onload = () => res(img);
    img.onerror = rej;
    img.src = `data:image/png;base64,${b64}`;
  });
  const [ia, ib] = await Promise.all([load(a), load(b)]);
  const px = (img) => {
    const c = document.createElement('canvas');
    c.width = img.width; c.height = img.height;
    const g = c.getContext('2d');
    g.drawImage(img, 0, 0);
    return g.getImageData(0, 0, c.width, c.height).data;
  };
  const da = px(ia), db = px(ib);
  let n = 0;
  for (let i = 0; i < da.length; i += 4) {
    if (Math.abs(da[i] - db[i]) + Math.abs(da[i + 1] - db[i + 1]) + Math.abs(da[i + 2] - db[i + 2]) > 40) n++;
  }
  return n / (da.length / 4);
}, [shotBefore.toString('base64'), (shotAfter || shotBefore).toString('base64')]);
check(changed > 0.005, 'the screenshots before and after the blast differ',
  `${(changed * 100).toFixed(1)} % of pixels changed`);

// ------------------------------------------------------------------ save, reset
const notice = () => page.evaluate(() => document.getElementById('notice').textContent);
const waitNotice = async (re) => {
  for (let i = 0; i < 50; i++) {
    const n = await notice();
    if (re.test(n)) return n;
    await sleep(100);
  }
  return notice();
};
const saved = join(saveDir, `${file ? file.split('/').pop().replace(/\.[^.]*$/, '') : 'humanoid'}.spec.toml`);
await page.click('#save');
let n = await waitNotice(/saved/);
check(existsSync(saved) && /saved/.test(n), 'Save writes the spec into --save-dir', n);
writeFileSync(saved, '# edited by hand\n');
let asked = null;
page.once('dialog', async (d) => { asked = d.message(); await d.dismiss(); });
await page.click('#save');
n = await waitNotice(/not saved/);
check(asked !== null && asked.includes('.spec.toml') && readFileSync(saved, 'utf8') === '# edited by hand\n',
  'a second Save asks before replacing the file, and "no" keeps it', `${asked} / ${n}`);
page.once('dialog', async (d) => { asked = d.message(); await d.accept(); });
await page.click('#save');
n = await waitNotice(/^saved/);
check(readFileSync(saved, 'utf8').includes('[[bodies]]'), '"yes" replaces it', n);
await page.click('#reset');
await sleep(500);
const afterReset = await shown();
s = await state();
check(s.time_s === 0 && !s.playing && s.events === 0 && afterReset.time.startsWith('0.00 s'),
  'Reset goes back to t = 0, paused, with no events', `${afterReset.time}, events ${s.events}`);

// ------------------------------------------------------------------ hostile messages
const dropsBefore = (stderr.match(/dropped/g) || []).length;
const hostile = await page.evaluate(async () => {
  const open = () => new Promise((res, rej) => {
    const w = new WebSocket(`ws://${location.host}/ws`);
    w.onopen = () => res(w);
    w.onerror = () => rej(new Error('cannot connect'));
  });
  const w = await open();
  let closed = false;
  w.onclose = () => { closed = true; };
  const bad = [
    'not json at all',
    '{"type":"launch_missiles"}',
    '{"type":"pause","extra":1}',
    '{"type":"blast","position":[1e39,0,0],"tnt_kg":5,"delay_s":0}',
    '{"type":"blast","position":[0,0,0],"tnt_kg":-5,"delay_s":0}',
    '{"type":"drag_start","ragdoll":0,"body":999,"local":[0,0,0],"target":[0,1,0]}',
    '{"type":"drag_start","ragdoll":7,"body":0,"local":[0,0,0],"target":[0,1,0]}',
    '{"type":"edit_body","ragdoll":0,"body":0,"radius_m":0.1,"length_m":0.2,"center_m":[0,0,0],"mass_kg":NaN}',
    '{"type":"edit_joint","ragdoll":0,"joint":0,"min_deg":10,"max_deg":-10}',
    '{"type":"scrub","time_s":-1}',
    `{"type":"pause","pad":"${'x'.repeat(100000)}"}`,
  ];
  for (const m of bad) w.send(m);
  w.send(new Uint8Array([1, 2, 3, 4]));
  // Still connected, and a good message on the same socket still works.
  w.send('{"type":"pause"}');
  await new Promise((r) => setTimeout(r, 500));
  const pausedOk = !closed;
  w.send('{"type":"play"}');
  // A message over the WebSocket layer's limit closes that one connection.
  const w2 = await open();
  const closedBig = new Promise((r) => { w2.onclose = () => r(true); setTimeout(() => r(false), 5000); });
  w2.send('x'.repeat(2 * 1024 * 1024));
  return { sent: bad.length + 1, stillOpen: pausedOk, bigClosed: await closedBig };
});
await sleep(300);
const drops = (stderr.match(/dropped/g) || []).length - dropsBefore;
check(drops === hostile.sent, 'every malformed or hostile message is dropped with a log line',
  `${drops} of ${hostile.sent} logged`);
check(hostile.stillOpen, 'the connection that sent them stays open');
check(hostile.bigClosed, 'a 2 MiB message closes only its own connection');
// Every new connection started the simulation over (as a reload does): play again. The
// button toggles by the last frame the page saw, so wait for the page to see the restart
// (paused) before pressing it, and for it to see the simulation playing after.
const seen = (playing) => page
  .waitForFunction((p) => window.viewer.frame && window.viewer.frame.playing === p, playing, { timeout: 5000 })
  .catch(() => {});
await seen(false);
await page.click('#play');
await seen(true);
await sleep(300);
const a = await state();
await sleep(500);
const b = await state();
check(exited === null && b.time_s > a.time_s, 'the server survives and keeps simulating',
  `t ${a.time_s.toFixed(2)} → ${b.time_s.toFixed(2)} s`);
// DNS rebinding: the page of a name that now points at 127.0.0.1 names itself in Host.
const port = new URL(url).port;
const statusFor = (host) => new Promise((res) => {
  const req = httpRequest({ host: '127.0.0.1', port, path: '/api/state', headers: { Host: host } },
    (r) => { r.resume(); res(r.statusCode); });
  req.on('error', (e) => res(String(e)));
  req.end();
});
const evil = await statusFor(`evil.example:${port}`);
const own = await statusFor(`localhost:${port}`);
check(evil === 421 && own === 200 && /refused a request .* for host "evil\.example/.test(stderr),
  'a request naming another host is refused with a log line', `evil.example ${evil}, localhost ${own}`);
const stillDrawing = await page.evaluate(() => window.viewer.connected);
check(stillDrawing, "the page's own connection is unaffected");
check(pageErrors.length === 0, 'the page logged no errors', pageErrors.join(' | '));
await finish();
