// End-to-end test of `diffreg serve` in a real browser: Debian's chromium, headless, driven by
// playwright-core. Starts the server on a free port with a planar mesh, adds two handles by
// clicking vertices, drags one, checks through the page that the mesh changed, and saves a
// screenshot. Exit code 77 (skipped, with the reason printed) when chromium or playwright-core
// is missing; 1 on failure.
//
//   node serve.e2e.mjs DIFFREG_TOOL MESH OUT_DIR
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const SKIP = 77;
const here = path.dirname(fileURLToPath(import.meta.url));
const [tool, mesh, outDir] = process.argv.slice(2);
if (!tool || !mesh || !outDir) {
  console.error('usage: node serve.e2e.mjs DIFFREG_TOOL MESH OUT_DIR');
  process.exit(2);
}
const chromiumPath = '/usr/bin/chromium';
if (!fs.existsSync(chromiumPath)) {
  console.log(`SKIPPED: ${chromiumPath} is not installed (tools/setup.sh installs it)`);
  process.exit(SKIP);
}
let chromium;
try {
  ({ chromium } = await import(path.join(here, 'node_modules', 'playwright-core', 'index.mjs')));
} catch (error) {
  console.log(`SKIPPED: playwright-core is not installed in ${here}/node_modules ` +
    `(tools/setup.sh test runs npm ci there): ${error.message.split('\n')[0]}`);
  process.exit(SKIP);
}

function check(condition, message) {
  if (!condition) throw new Error(message);
  console.log(`ok: ${message}`);
}

/// Starts the server; resolves with its address once it has printed it.
function startServer(file) {
  const child = spawn(tool, ['serve', '-i', file, '--port', '0'], { stdio: ['ignore', 'pipe', 'pipe'] });
  let stderr = '';
  child.stderr.on('data', (d) => { stderr += d; });
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`no address from diffreg serve within 30 s: ${stderr}`)), 30000);
    let out = '';
    child.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/http:\/\/127\.0\.0\.1:(\d+)\//);
      if (m) { clearTimeout(timer); resolve({ child, url: m[0] }); }
    });
    child.on('exit', (code) => { clearTimeout(timer); reject(new Error(`diffreg serve exited (${code}): ${stderr}`)); });
  });
}

let server = null, context = null;
const userDataDir = fs.mkdtempSync(path.join(os.tmpdir(), 'diffreg-e2e-chromium-'));
let failed = false;
try {
  fs.mkdirSync(outDir, { recursive: true });
  // The mesh with one more vertex far away that no face uses: kept, numbered last, and never
  // part of the view's frame (it used to shrink the mesh to a dot).
  const served = path.join(outDir, 'stray' + path.extname(mesh));
  fs.writeFileSync(served, fs.readFileSync(mesh, 'utf8').replace(/\n?$/, '\nv 1000000 0 0\n'));
  server = await startServer(served);
  console.log(`server: ${server.url}`);
  context = await chromium.launchPersistentContext(userDataDir, {
    executablePath: chromiumPath,
    headless: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync'],
    viewport: { width: 1360, height: 820 },
  });
  const page = context.pages()[0] || await context.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  await page.goto(server.url);
  await page.waitForSelector('body[data-ready="true"]', { timeout: 30000 });
  const rest = await page.evaluate(() => window.diffreg.positions());
  check(rest.length > 0 && rest.length % 3 === 0, `the page loaded ${rest.length / 3} vertices`);
  {
    const a = await page.evaluate(() => window.diffreg.screen(0));
    const b = await page.evaluate(() => window.diffreg.screen(32));
    check(Math.abs(b.x - a.x) > 600, `the bar fills the view (${Math.round(Math.abs(b.x - a.x))} px long)`);
  }

  // bar.obj numbering: corner (i, j) is vertex 33 j + i; the left end middle is 66, the right
  // end middle 98.
  const left = 66, right = 98;
  const clickVertex = async (v, shift = false) => {
    const p = await page.evaluate((k) => window.diffreg.screen(k), v);
    if (shift) await page.keyboard.down('Shift');
    await page.mouse.click(p.x, p.y);
    if (shift) await page.keyboard.up('Shift');
    await page.evaluate(() => window.diffreg.idle());
  };
  await clickVertex(left);
  await clickVertex(33, true);  // shift-click adds to the selected (new) handle
  await clickVertex(right);
  let state = await page.evaluate(() => window.diffreg.state());
  check(state.handles.length === 2, 'two handles made by clicking');
  check(state.handles[0].vertices.includes(left) && state.handles[0].vertices.includes(33),
    'shift-click added vertex 33 to the first handle');
  check(state.handles[1].vertices.includes(right), 'the second handle holds the clicked vertex');

  // Drag the right handle upwards in small steps, as a user would.
  const from = await page.evaluate((k) => window.diffreg.screen(k), right);
  await page.mouse.move(from.x, from.y);
  await page.mouse.down();
  for (let i = 1; i <= 20; ++i) await page.mouse.move(from.x - 6 * i, from.y - 13 * i);
  await page.mouse.up();
  await page.evaluate(() => window.diffreg.idle());
  // The last move may still be on its way when the button goes up; wait for the final state.
  await page.waitForFunction(() => {
    const s = window.diffreg.state();
    return s && s.computed_version === s.version;
  }, null, { timeout: 30000 });
  await page.evaluate(() => window.diffreg.idle());
  const moved = await page.evaluate(() => window.diffreg.positions());
  state = await page.evaluate(() => window.diffreg.state());
  const dy = moved[3 * right + 1] - rest[3 * right + 1];
  check(dy > 0.5, `the dragged handle moved up by ${dy.toFixed(3)}`);
  const handleVertices = new Set([left, 33, right]);
  let largest = 0;
  for (let v = 0; v < rest.length / 3; ++v) {
    if (handleVertices.has(v)) continue;
    const d = Math.hypot(moved[3 * v] - rest[3 * v], moved[3 * v + 1] - rest[3 * v + 1]);
    largest = Math.max(largest, d);
  }
  check(largest > 0.5, `the free vertices followed (largest displacement ${largest.toFixed(3)})`);
  check(moved.every((x, i) => i % 3 !== 2 || x === rest[i]), 'planar: every vertex stayed in its plane');
  check(state.update.solved && state.update.deformation_work === 'solve',
    `the drag re-solved without refactoring (last update: ${state.update.deformation_work})`);
  const shown = await page.locator('#m-dmax').textContent();
  check(shown && shown !== '\u2013' && Number(shown) > 0, `D_max is shown (${shown})`);

  await page.mouse.move(20, 20);
  await page.keyboard.press('f');  // fit the view to the deformed shape
  const shot = path.join(outDir, 'serve-e2e.png');
  await page.screenshot({ path: shot });
  check(fs.statSync(shot).size > 10000, `screenshot saved: ${shot}`);
  // Saving: the three download links answer with their files.
  for (const [id, type] of [['save-handles', 'application/json'], ['save-ply', 'application/octet-stream'],
    ['save-png', 'image/png']]) {
    const href = await page.getAttribute(`#${id}`, 'href');
    const res = await page.request.get(new URL(href, server.url).href);
    check(res.status() === 200 && res.headers()['content-type'].startsWith(type) &&
      (res.headers()['content-disposition'] || '').includes('attachment'), `${id} downloads ${type}`);
  }
  // Delete the selected (dragged) handle with the Delete key.
  await page.keyboard.press('Delete');
  await page.evaluate(() => window.diffreg.idle());
  state = await page.evaluate(() => window.diffreg.state());
  check(state.handles.length === 1 && !state.handles[0].vertices.includes(right),
    'Delete removed the selected handle');
  check(errors.length === 0, `no errors in the page${errors.length ? ': ' + errors.join('; ') : ''}`);
} catch (error) {
  failed = true;
  console.error(`FAILED: ${error.stack || error.message}`);
} finally {
  if (context) await context.close().catch(() => {});
  if (server) {
    const exited = new Promise((resolve) => server.child.on('exit', resolve));
    server.child.kill('SIGTERM');
    await Promise.race([exited, new Promise((resolve) => setTimeout(resolve, 5000))]);
    if (server.child.exitCode === null) server.child.kill('SIGKILL');
  }
  fs.rmSync(userDataDir, { recursive: true, force: true });
}
process.exit(failed ? 1 : 0);
