// `pflow render`'s page: loaded by headless Chromium from the CLI's one-shot loopback server, it draws one
// snapshot with the viewer's own code and posts the composed PNG back. Options come in the query string:
//   key (the server's secret path), width, height, view, color, colormap, min, max, clip (AXIS=VALUE),
//   slice (AXIS=VALUE), field, streamlines=1, particles=0|1, title; or plot=1 (the time series as charts, `pflow
//   plot`) with series (comma-separated names to keep).
import { fetchArrays } from './arrays.js';
import { Viewer } from './viewer.js';
import { seriesPanels, drawPlots } from './plot.js';

const q = new URLSearchParams(location.search);
const key = q.get('key') || '';

async function report(path, body, type, timing = '') {
  await fetch(`/${path}/${key}`, { method: 'POST', body, headers: { 'Content-Type': type, 'X-Render-Timing': timing } });
}

function axisValue(text, what) {
  const m = /^([xyz])=(.+)$/.exec(text || '');
  if (!m || !Number.isFinite(Number(m[2]))) throw new Error(`${what} '${text}': AXIS=VALUE with AXIS x, y or z and VALUE in m`);
  return { axis: m[1], value: Number(m[2]) };
}

async function main() {
  const width = Number(q.get('width') || 1600), height = Number(q.get('height') || 1000);
  const canvas = document.getElementById('view');
  canvas.width = width;
  canvas.height = height;
  const t0 = performance.now();
  const snapshot = await fetchArrays(`/data/${key}`);
  const t1 = performance.now();
  if (q.get('plot') === '1') return plot(snapshot, width, height, t0, t1);
  // Many particles: one point sprite each (a software renderer spends its time on vertices); few: quads, which have
  // no size limit when a particle fills much of the picture.
  const many = (snapshot.particles.position ? snapshot.particles.position.rows : 0) > 20000;
  const viewer = new Viewer(canvas, { width, height, pixelRatio: 1, legendScale: width / 1200, sprites: q.get('sprites') || (many ? 'points' : 'quads') });
  viewer.setSnapshot(snapshot);
  viewer.viewName = q.get('view') || viewer.defaultView();
  if (q.get('color')) viewer.setColor({ key: q.get('color') });
  if (q.get('colormap')) viewer.color.userMap = true, viewer.setColor({ colormap: q.get('colormap') });
  if (q.get('min') !== null || q.get('max') !== null) {
    const [lo, hi] = viewer.colorRange();
    viewer.setColor({ range: [q.get('min') !== null ? Number(q.get('min')) : lo, q.get('max') !== null ? Number(q.get('max')) : hi] });
  }
  if (q.get('clip')) viewer.setClip(axisValue(q.get('clip'), 'clip'));
  if (q.get('slice')) {
    const s = axisValue(q.get('slice'), 'slice');
    viewer.setSlice({ ...s, field: q.get('field') || 'solid_fraction', streamlines: q.get('streamlines') === '1',
      colormap: q.get('slice_colormap') || 'grey' });
    // Walls between the camera and the slice would veil it: cut them away on the camera's side.
    if (!q.get('clip')) {
      const toward = { side: ['x', false], front: ['y', true], top: ['z', false] }[viewer.viewName];
      if (toward && toward[0] === s.axis) viewer.setClip({ axis: s.axis, value: s.value, below: toward[1], surfacesOnly: true });
    }
  }
  if (q.get('particles') === '0') viewer.setParticlesVisible(false);
  viewer.setView(viewer.viewName);
  const picture = viewer.compose(q.get('title') || 'pflow');
  const t2 = performance.now();
  const blob = await new Promise((resolve) => picture.toBlob(resolve, 'image/png'));
  const t3 = performance.now();
  await report('result', blob, 'image/png', `data ${(t1 - t0).toFixed(0)} ms, draw ${(t2 - t1).toFixed(0)} ms, png ${(t3 - t2).toFixed(0)} ms`);
}

async function plot(snapshot, width, height, t0, t1) {
  const canvas = document.createElement('canvas');
  canvas.width = width;
  canvas.height = height;
  const only = (q.get('series') || '').split(',').filter((x) => x);
  const panels = seriesPanels(snapshot.probes, only);
  if (only.length && !panels.length)
    throw new Error(`no series named ${only.join(', ')} (have: ${Object.keys(snapshot.probes || {}).filter((n) => n !== 'time').join(', ') || 'none'})`);
  drawPlots(canvas.getContext('2d'), width, height, panels, `${q.get('title') || 'pflow'}: time series`);
  const t2 = performance.now();
  const blob = await new Promise((resolve) => canvas.toBlob(resolve, 'image/png'));
  await report('result', blob, 'image/png', `data ${(t1 - t0).toFixed(0)} ms, draw ${(t2 - t1).toFixed(0)} ms, png ${(performance.now() - t2).toFixed(0)} ms`);
}

main().catch((e) => report('error', String(e && e.message ? e.message : e), 'text/plain'));
