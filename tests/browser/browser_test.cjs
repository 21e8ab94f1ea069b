#!/usr/bin/env node
// Browser tests of the web viewer: Debian's Chromium, headless, driven by puppeteer-core (from web/node_modules;
// no browser is downloaded), against the real local stack (deploy/local/start.sh: TLS between the services, tokens)
// that the ctest fixture starts once. Usage:
//   browser_test.cjs setup|teardown STATE_DIR       start / stop the stack (fixture)
//   browser_test.cjs SCENARIO STATE_DIR             one scenario (below), exit 0 when it holds
// Environment: PFLOW_SRC (the source tree), PFLOW_BIN (build/bin), PFLOW_CHROMIUM (default /usr/bin/chromium).
'use strict';
const { execFileSync, spawnSync } = require('node:child_process');
const fs = require('node:fs');
const net = require('node:net');
const path = require('node:path');

const SRC = process.env.PFLOW_SRC || path.resolve(__dirname, '../..');
const BIN = process.env.PFLOW_BIN || path.join(SRC, 'build/bin');
const CHROMIUM = process.env.PFLOW_CHROMIUM || '/usr/bin/chromium';
const [, , scenario, stateDir] = process.argv;
const STATE = path.join(stateDir || '/tmp/pflow-browser', 'stack.json');
const SHORT_SCENE = path.join(SRC, 'tests/data/browser_scene.yaml');
const LONG_SCENE = path.join(SRC, 'tests/data/service_long_scene.yaml');

function fail(message) {
  throw new Error(message);
}
function check(condition, message) {
  if (!condition) fail(message);
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

function freePort() {
  return new Promise((resolve) => {
    const s = net.createServer();
    s.listen(0, '127.0.0.1', () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
  });
}

// --- the stack --------------------------------------------------------------------------------------------------

function stackEnv(state) {
  const env = { ...process.env, PFLOW_CONFIG: state.config, OMPI_ALLOW_RUN_AS_ROOT: '1', OMPI_ALLOW_RUN_AS_ROOT_CONFIRM: '1', OMP_WAIT_POLICY: 'passive' };
  for (const k of ['PFLOW_TOKEN', 'PFLOW_CA', 'PFLOW_INSECURE', 'PFLOW_MANAGER', 'PFLOW_BACKEND']) delete env[k];
  return env;
}

async function setup(dir) {
  fs.rmSync(dir, { recursive: true, force: true });
  fs.mkdirSync(dir, { recursive: true });
  const ports = { PFLOW_MANAGER_PORT: await freePort(), PFLOW_FRONTEND_PORT: await freePort(), PFLOW_BACKEND_PORT: await freePort(),
    PFLOW_AGENT_PORT: await freePort(), PFLOW_WEB_PORT: await freePort() };
  const env = { ...process.env, ...Object.fromEntries(Object.entries(ports).map(([k, v]) => [k, String(v)])), PFLOW_LOCAL: dir,
    PFLOW_BIN: BIN, PFLOW_NO_USER_CONFIG: '1', PFLOW_NODE: 'browser-node', OMP_WAIT_POLICY: 'passive' };
  const r = spawnSync(path.join(SRC, 'deploy/local/start.sh'), [], { env, encoding: 'utf8' });
  process.stdout.write(r.stdout + r.stderr);
  check(r.status === 0, `start.sh failed (${r.status})`);
  const state = { dir, web: `http://127.0.0.1:${ports.PFLOW_WEB_PORT}`, config: path.join(dir, 'config.yaml'),
    token: fs.readFileSync(path.join(dir, 'admin.token'), 'utf8').trim() };
  let up = false;
  for (let i = 0; i < 100 && !up; ++i) {  // pflow-web answers
    try {
      up = (await fetch(`${state.web}/index.html`)).ok;
    } catch (_) { /* not yet */ }
    if (!up) await sleep(100);
  }
  check(up, `pflow-web does not serve the page at ${state.web} (log: ${dir}/logs/web.log)`);
  fs.writeFileSync(path.join(dir, 'stack.json'), JSON.stringify(state));
}

function teardown(dir) {
  spawnSync(path.join(SRC, 'deploy/local/stop.sh'), [], { env: { ...process.env, PFLOW_LOCAL: dir }, stdio: 'inherit' });
}

function pflow(state, ...args) {
  return execFileSync(path.join(BIN, 'pflow'), args, { env: stackEnv(state), encoding: 'utf8' });
}
const pflowJson = (state, ...args) => JSON.parse(pflow(state, ...args, '--json'));

async function waitJob(state, id, states, seconds) {
  const end = Date.now() + 1000 * seconds;
  for (;;) {
    const job = pflowJson(state, 'job', id);
    if (states.includes(job.state)) return job;
    check(Date.now() < end, `job ${id} is ${job.state}, not ${states.join('/')} after ${seconds} s`);
    await sleep(300);
  }
}

// A finished job with snapshots: the one an earlier scenario made, or a new one.
async function finishedJob(state) {
  const jobs = pflowJson(state, 'jobs', '--all');
  const done = jobs.find((j) => j.name === 'browser-short' && j.state === 'succeeded');
  if (done) return done.id;
  const job = pflowJson(state, 'submit', SHORT_SCENE, '--name', 'browser-short');
  await waitJob(state, job.id, ['succeeded'], 180);
  return job.id;
}

// --- the browser ------------------------------------------------------------------------------------------------

async function browser() {
  const puppeteer = require(path.join(SRC, 'web/node_modules/puppeteer-core'));
  const args = ['--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--window-size=1400,900'];
  if (process.getuid && process.getuid() === 0) args.push('--no-sandbox');  // Chromium refuses its sandbox to root
  return puppeteer.launch({ executablePath: CHROMIUM, headless: true, args, defaultViewport: { width: 1400, height: 900 } });
}

async function signedIn(b, state, hash = '#jobs') {
  const page = await b.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  page.pageErrors = errors;
  await page.goto(`${state.web}/${hash}`);
  await page.waitForSelector('#token');
  await page.type('#token', state.token);
  await page.click('#login-button');
  if (state.token === state.realToken || !state.realToken) await page.waitForSelector('#sign-out', { timeout: 15000 });  // signed in: the page routed
  return page;
}

// Statistics of the 3-D canvas's pixels: how many differ from the background, and a coarse signature.
async function canvasStats(page) {
  return page.evaluate(() => {
    const src = document.getElementById('view-canvas');
    const c = document.createElement('canvas');
    c.width = src.width;
    c.height = src.height;
    const ctx = c.getContext('2d');
    ctx.drawImage(src, 0, 0);
    const d = ctx.getImageData(0, 0, c.width, c.height).data;
    const bg = [d[0], d[1], d[2]];
    let differ = 0, sum = 0;
    const hist = new Array(16).fill(0);
    for (let i = 0; i < d.length; i += 4) {
      const off = Math.abs(d[i] - bg[0]) + Math.abs(d[i + 1] - bg[1]) + Math.abs(d[i + 2] - bg[2]);
      if (off > 30) differ++;
      sum += d[i] + 2 * d[i + 1] + 3 * d[i + 2];
      hist[(d[i] >> 6) * 4 + (d[i + 2] >> 6)]++;
    }
    return { pixels: d.length / 4, differ, fraction: differ / (d.length / 4), sum, hist };
  });
}

function histDistance(a, b) {
  let s = 0;
  for (let i = 0; i < a.hist.length; ++i) s += Math.abs(a.hist[i] - b.hist[i]);
  return s / a.pixels;
}

async function openView(page, state, id) {
  await page.goto(`${state.web}/#job/${id}`);
  await page.waitForSelector('#view[data-state="ready"]', { timeout: 60000 });
}

// --- scenarios ------------------------------------------------------------------------------------------------

const scenarios = {
  // A running job is listed with state, owner and a progress bar that moves.
  async live_progress(state) {
    const job = pflowJson(state, 'submit', LONG_SCENE, '--name', 'browser-long');
    const b = await browser();
    try {
      await waitJob(state, job.id, ['running'], 120);
      const page = await signedIn(b, state);
      const row = `tr[data-job="${job.id}"]`;
      await page.waitForSelector(`${row}[data-state="running"]`, { timeout: 30000 });
      const fraction = () => page.$eval(`${row} .progress`, (e) => Number(e.dataset.fraction));
      await page.waitForFunction((sel) => Number(document.querySelector(`${sel} .progress`).dataset.fraction) > 0, { timeout: 30000 }, row);
      const first = await fraction();
      await page.waitForFunction((sel, f) => Number(document.querySelector(`${sel} .progress`).dataset.fraction) > f, { timeout: 30000 }, row, first);
      const second = await fraction();
      const owner = await page.$eval(`${row} td:nth-child(4)`, (e) => e.textContent);
      check(owner === 'admin', `owner shown as '${owner}'`);
      console.log(`progress bar moved from ${first} to ${second}`);
      check(page.pageErrors.length === 0, `page errors: ${page.pageErrors.join('; ')}`);
    } finally {
      await b.close();
      try { pflow(state, 'cancel', job.id); } catch (_) { /* already over */ }
      await waitJob(state, job.id, ['cancelled', 'failed', 'succeeded'], 60);
    }
  },

  // Cancel from the page (two clicks): the job ends cancelled and the page says so.
  async cancel(state) {
    const job = pflowJson(state, 'submit', LONG_SCENE, '--name', 'browser-cancel');
    const b = await browser();
    try {
      await waitJob(state, job.id, ['running'], 120);
      const page = await signedIn(b, state);
      await page.waitForSelector(`#cancel-${job.id}`, { timeout: 30000 });
      await page.click(`#cancel-${job.id}`);
      await page.waitForFunction((id) => document.getElementById(`cancel-${id}`)?.textContent === 'confirm cancel', {}, job.id);
      await page.click(`#cancel-${job.id}`);
      const ended = await waitJob(state, job.id, ['cancelled'], 60);
      console.log(`job ${job.id}: ${ended.state}`);
      await page.waitForSelector(`#jobs-all`);
      await page.click('#jobs-all');
      await page.waitForSelector(`tr[data-job="${job.id}"][data-state="cancelled"]`, { timeout: 20000 });
    } finally {
      await b.close();
      try { pflow(state, 'cancel', job.id); } catch (_) { /* cancelled already */ }
    }
  },

  // The 3-D canvas draws particles and walls: not the empty background, and different at two time-slider positions.
  async canvas_draws(state) {
    const id = await finishedJob(state);
    const b = await browser();
    try {
      const page = await signedIn(b, state);
      await openView(page, state, id);
      const last = await canvasStats(page);
      const lastStep = await page.$eval('#view', (e) => e.dataset.step);
      check(last.fraction > 0.02, `the canvas is nearly empty: ${(100 * last.fraction).toFixed(2)} % of pixels differ from the background`);
      await page.$eval('#time-slider', (e) => { e.value = '0'; e.dispatchEvent(new Event('input')); });
      await page.waitForFunction((s) => document.getElementById('view').dataset.step !== s && document.getElementById('view').dataset.state === 'ready', {}, lastStep);
      const first = await canvasStats(page);
      const d = histDistance(first, last);
      console.log(`drawn: ${(100 * last.fraction).toFixed(1)} % (last step ${lastStep}), ${(100 * first.fraction).toFixed(1)} % (step 0); histogram distance ${d.toFixed(4)}`);
      check(first.sum !== last.sum && d > 0.002, 'the first and the last snapshot look the same');
      const surfaces = await page.$$eval('#surfaces input', (l) => l.length);
      check(surfaces >= 1, 'no surface listed');
      check(page.pageErrors.length === 0, `page errors: ${page.pageErrors.join('; ')}`);
    } finally {
      await b.close();
    }
  },

  // Colour by another field changes the picture; a range and a slice too.
  async color_by(state) {
    const id = await finishedJob(state);
    const b = await browser();
    try {
      const page = await signedIn(b, state);
      await openView(page, state, id);
      const options = await page.$$eval('#color-by option', (l) => l.map((o) => o.value));
      check(options.includes('speed') && options.includes('height'), `colour-by offers ${options.join(', ')}`);
      await page.select('#color-by', 'speed');
      const speed = await canvasStats(page);
      await page.select('#color-by', 'height');
      const height = await canvasStats(page);
      const d = histDistance(speed, height);
      console.log(`speed vs height: histogram distance ${d.toFixed(4)}`);
      check(d > 0.005, 'colouring by height looks like colouring by speed');
      const legend = await page.evaluate(() => {
        const o = document.getElementById('view-overlay');
        const d = o.getContext('2d').getImageData(0, 0, o.width, o.height).data;
        let n = 0;
        for (let i = 3; i < d.length; i += 4) if (d[i] > 0) n++;
        return n;
      });
      check(legend > 1000, 'no colour bar drawn');
      await page.click('#slice-on');
      await page.waitForFunction(() => document.querySelectorAll('#slice-field option').length > 0 && document.getElementById('view').dataset.state === 'ready', { timeout: 30000 });
      await sleep(300);
      const sliced = await canvasStats(page);
      check(histDistance(sliced, height) > 0.002, 'the grid slice changed nothing');
      check(page.pageErrors.length === 0, `page errors: ${page.pageErrors.join('; ')}`);
    } finally {
      await b.close();
    }
  },

  // The time series of a finished job drawn over the view (DEM series: kinetic energy, contacts, ...).
  async plots(state) {
    const id = await finishedJob(state);
    const b = await browser();
    try {
      const page = await signedIn(b, state);
      await openView(page, state, id);
      await page.click('#plots');
      await page.waitForSelector('#view[data-plots="ready"]', { timeout: 30000 });
      const drawn = await page.evaluate(() => {
        const o = document.getElementById('view-overlay');
        const d = o.getContext('2d').getImageData(0, 0, o.width, o.height).data;
        let opaque = 0, blue = 0;
        for (let i = 0; i < d.length; i += 4) {
          if (d[i + 3] > 200) opaque++;
          if (Math.abs(d[i] - 0x1f) < 30 && Math.abs(d[i + 1] - 0x77) < 30 && Math.abs(d[i + 2] - 0xb4) < 30) blue++;
        }
        return { opaque: opaque / (d.length / 4), blue: blue / (d.length / 4) };
      });
      console.log(`plots: ${(100 * drawn.opaque).toFixed(1)} % opaque, ${(100 * drawn.blue).toFixed(2)} % curve pixels`);
      check(drawn.opaque > 0.9, 'the charts do not cover the view');
      check(drawn.blue > 0.001, 'no curve drawn');
      check(page.pageErrors.length === 0, `page errors: ${page.pageErrors.join('; ')}`);
    } finally {
      await b.close();
    }
  },

  // A wrong token is refused: the sign-in form says so and no job is listed; the API answers 401 without one.
  async wrong_token(state) {
    const b = await browser();
    try {
      const page = await signedIn(b, { ...state, token: 'pflow_' + '0'.repeat(64), realToken: state.token });
      await page.waitForFunction(() => (document.getElementById('login-error')?.textContent || '').includes('refused'), { timeout: 15000 });
      const text = await page.$eval('#login-error', (e) => e.textContent);
      check(!(await page.$('#jobs-table')), 'jobs listed with a wrong token');
      const r = await fetch(`${state.web}/api/jobs`);
      check(r.status === 401, `GET /api/jobs without a token: ${r.status}`);
      console.log(`refused: ${text}`);
    } finally {
      await b.close();
    }
  },

  // The nodes tab lists the agent's node and its devices with their state.
  async nodes(state) {
    const b = await browser();
    try {
      const page = await signedIn(b, state, '#nodes');
      await page.waitForSelector('#nodes-table tr[data-node="browser-node"]', { timeout: 15000 });
      const cells = await page.$$eval('#nodes-table tr[data-node="browser-node"] td', (l) => l.map((c) => c.textContent));
      check(/free|busy/.test(cells[3]), `device state '${cells[3]}'`);
      console.log(`node row: ${cells.join(' | ')}`);
    } finally {
      await b.close();
    }
  },
};

// Not a test: pictures of the page for docs/display.md (OUT_DIR = the 4th argument).
async function screenshots(state, out) {
  fs.mkdirSync(out, { recursive: true });
  const id = await finishedJob(state);
  const long = pflowJson(state, 'submit', LONG_SCENE, '--name', 'drum-demo');
  const b = await browser();
  try {
    await waitJob(state, long.id, ['running'], 120);
    const page = await signedIn(b, state);
    await page.waitForSelector(`tr[data-job="${long.id}"] .progress`);
    await page.click('#jobs-all');
    await sleep(4000);
    await page.screenshot({ path: path.join(out, 'viewer-jobs.png') });
    await openView(page, state, id);
    await sleep(500);
    await page.screenshot({ path: path.join(out, 'viewer-job.png') });
    await page.click('#clip-on');
    await page.click('#slice-on');
    await page.waitForFunction(() => document.querySelectorAll('#slice-field option').length > 0, { timeout: 30000 });
    await page.click('#streamlines');
    await sleep(800);
    await page.screenshot({ path: path.join(out, 'viewer-slice.png') });
    await page.click('#plots');
    await page.waitForSelector('#view[data-plots="ready"]', { timeout: 30000 });
    await page.screenshot({ path: path.join(out, 'viewer-plots.png') });
    await page.goto(`${state.web}/#nodes`);
    await page.waitForSelector('#nodes-table');
    await page.screenshot({ path: path.join(out, 'viewer-nodes.png') });
  } finally {
    await b.close();
    pflow(state, 'cancel', long.id);
  }
}

(async () => {
  try {
    if (scenario === 'setup') return await setup(stateDir);
    if (scenario === 'screenshots') return await screenshots(JSON.parse(fs.readFileSync(STATE, 'utf8')), process.argv[4]);
    if (scenario === 'teardown') return teardown(stateDir);
    const run = scenarios[scenario];
    if (!run) fail(`unknown scenario '${scenario}' (have: ${Object.keys(scenarios).join(', ')})`);
    const state = JSON.parse(fs.readFileSync(STATE, 'utf8'));
    const t0 = Date.now();
    await run(state);
    console.log(`${scenario}: passed in ${((Date.now() - t0) / 1000).toFixed(1)} s`);
  } catch (e) {
    console.error(`${scenario}: FAILED: ${e.stack || e}`);
    process.exitCode = 1;
  }
})();
