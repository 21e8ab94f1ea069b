// Time series as line charts on a 2D canvas: a DEM run's series (kinetic energy, contacts, coordination, the mass
// past each flow plane and its rate) and an SPH run's probes and gauges (backend/store/DemSeries.h, ProbeSeries.h).
// Used by the page's plots and by `pflow plot` (render.js in headless Chromium).
import { CATEGORICAL, ticks, formatValue } from './colormap.js';

const LABELS = {
  kinetic_energy: 'kinetic energy',
  contacts: 'particle contacts',
  wall_contacts: 'wall contacts',
  coordination: 'coordination number',
};

// Panels from a probes table ({time: Field, name: Field, ...}): one per series, numbered probes of one unit (P1..P8,
// H1..H4) together, and the rate of each mass_past series (central differences) after it. `only`: names to keep.
export function seriesPanels(probes, only = []) {
  if (!probes || !probes.time) return [];
  const time = probes.time.values;
  const names = Object.keys(probes).filter((n) => n !== 'time' && (!only.length || only.includes(n) || only.some((o) => n.startsWith(`${o}`))));
  const panels = [];
  const groups = new Map();
  for (const name of names) {
    const f = probes[name];
    // Together in one panel: numbered probes of one unit (P1..P8), and a surface's force or torque components.
    const numbered = /^([A-Za-z]+)[0-9]+$/.exec(name);
    const load = /^(force|torque)_([xyz]):(.+)$/.exec(name);
    if (numbered || load) {
      const key = numbered ? `${numbered[1]}|${f.unit}` : `${load[1]}|${load[3]}`;
      if (!groups.has(key)) {
        const panel = { title: numbered ? `${numbered[1]} probes` : `${load[1]} on ${load[3]}`, unit: f.unit, time, lines: [] };
        groups.set(key, panel);
        panels.push(panel);
      }
      groups.get(key).lines.push({ name: numbered ? name : load[2], y: f.values });
      continue;
    }
    const plane = /^mass_past:(.+)$/.exec(name);
    panels.push({ title: plane ? `mass past ${plane[1]}` : LABELS[name] || name, unit: f.unit, time, lines: [{ name, y: f.values }] });
    if (plane && time.length > 2) {
      const rate = new Float32Array(time.length);
      for (let i = 0; i < time.length; ++i) {
        const a = Math.max(0, i - 1), b = Math.min(time.length - 1, i + 1);
        rate[i] = time[b] > time[a] ? (f.values[b] - f.values[a]) / (time[b] - time[a]) : 0;
      }
      panels.push({ title: `mass flow through ${plane[1]}`, unit: 'kg/s', time, lines: [{ name: `rate:${plane[1]}`, y: rate }] });
    }
  }
  // A panel with nothing to show (a surface nothing touched: zero or no value throughout) is left out.
  const shows = (y) => y.some((v) => Number.isFinite(v) && v !== 0);
  return panels.filter((p) => p.lines.some((l) => shows(l.y)));
}

function extent(arrays) {
  let lo = Infinity, hi = -Infinity;
  for (const a of arrays)
    for (let i = 0; i < a.length; ++i)
      if (Number.isFinite(a[i])) (lo = Math.min(lo, a[i])), (hi = Math.max(hi, a[i]));
  if (!(hi >= lo)) return [0, 1];
  if (hi === lo) return lo === 0 ? [0, 1] : [lo - 0.1 * Math.abs(lo), hi + 0.1 * Math.abs(hi)];
  const pad = 0.05 * (hi - lo);
  return [lo >= 0 && lo - pad < 0 ? 0 : lo - pad, hi + pad];
}

// One chart in [x, y, w, h] of the context.
export function drawPanel(ctx, panel, { x, y, w, h, scale = 1 }) {
  const font = Math.round(13 * scale);
  const left = x + 70 * scale, right = x + w - 16 * scale, top = y + 34 * scale, bottom = y + h - 40 * scale;
  const [t0, t1] = extent([panel.time]);
  const [v0, v1] = extent(panel.lines.map((l) => l.y));
  const px = (t) => left + ((t - t0) / (t1 - t0 || 1)) * (right - left);
  const py = (v) => bottom - ((v - v0) / (v1 - v0 || 1)) * (bottom - top);
  ctx.save();
  ctx.fillStyle = '#fff';
  ctx.fillRect(x, y, w, h);
  ctx.strokeStyle = '#c9ced6';
  ctx.lineWidth = Math.max(1, scale);
  ctx.font = `${font}px sans-serif`;
  ctx.fillStyle = '#333';
  ctx.textAlign = 'center';
  ctx.textBaseline = 'top';
  const xTicks = Math.max(2, Math.min(6, Math.floor((right - left) / (90 * scale))));
  const yTicks = Math.max(2, Math.min(6, Math.floor((bottom - top) / (45 * scale))));
  for (const t of ticks(t0, t1, xTicks)) {
    ctx.beginPath();
    ctx.moveTo(px(t), top);
    ctx.lineTo(px(t), bottom);
    ctx.stroke();
    ctx.fillText(formatValue(t), px(t), bottom + 6 * scale);
  }
  ctx.fillText('time [s]', (left + right) / 2, bottom + 22 * scale);
  ctx.textAlign = 'right';
  ctx.textBaseline = 'middle';
  for (const v of ticks(v0, v1, yTicks)) {
    ctx.beginPath();
    ctx.moveTo(left, py(v));
    ctx.lineTo(right, py(v));
    ctx.stroke();
    ctx.fillText(formatValue(v), left - 6 * scale, py(v));
  }
  ctx.strokeStyle = '#555';
  ctx.strokeRect(left, top, right - left, bottom - top);
  ctx.textAlign = 'left';
  ctx.textBaseline = 'bottom';
  ctx.font = `bold ${font}px sans-serif`;
  ctx.fillText(`${panel.title}${panel.unit ? ` [${panel.unit}]` : ''}`, left, top - 8 * scale);
  panel.lines.forEach((line, k) => {
    ctx.strokeStyle = CATEGORICAL[k % CATEGORICAL.length];
    ctx.lineWidth = 1.8 * scale;
    ctx.beginPath();
    let pen = false;
    for (let i = 0; i < panel.time.length; ++i) {
      const v = line.y[i];
      if (!Number.isFinite(v)) {
        pen = false;
        continue;
      }
      if (pen) ctx.lineTo(px(panel.time[i]), py(v));
      else ctx.moveTo(px(panel.time[i]), py(v));
      pen = true;
    }
    ctx.stroke();
    if (panel.lines.length > 1) {  // a legend at the right
      ctx.font = `${font}px sans-serif`;
      ctx.fillStyle = CATEGORICAL[k % CATEGORICAL.length];
      ctx.textAlign = 'right';
      ctx.fillText(line.name, right - 8 * scale, top + (18 + 16 * k) * scale);
    }
  });
  ctx.restore();
}

// Every panel in a grid over the whole context, under a title line.
export function drawPlots(ctx, width, height, panels, title, { scale = width / 1200 } = {}) {
  ctx.save();
  ctx.fillStyle = '#f3f4f6';
  ctx.fillRect(0, 0, width, height);
  ctx.fillStyle = '#111';
  ctx.font = `bold ${Math.round(20 * scale)}px sans-serif`;
  ctx.textBaseline = 'top';
  ctx.fillText(title, 24 * scale, 16 * scale);
  ctx.restore();
  const head = 56 * scale;
  if (!panels.length) {
    ctx.font = `${Math.round(16 * scale)}px sans-serif`;
    ctx.fillStyle = '#555';
    ctx.fillText('no time series stored for this run', 24 * scale, head + 20 * scale);
    return;
  }
  const cols = panels.length <= 1 ? 1 : panels.length <= 4 ? 2 : panels.length <= 9 ? 3 : 4;
  const rows = Math.ceil(panels.length / cols);
  const gap = 12 * scale;
  const w = (width - gap * (cols + 1)) / cols, h = (height - head - gap * (rows + 1)) / rows;
  panels.forEach((p, k) => {
    const c = k % cols, r = Math.floor(k / cols);
    drawPanel(ctx, p, { x: gap + c * (w + gap), y: head + gap + r * (h + gap), w, h, scale: Math.min(scale, 1.4, h / 220) });
  });
}
