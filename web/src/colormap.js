// Colour maps (256-entry lookup tables) and the colour bar drawn on a 2D canvas (the page's overlay and the
// composed picture of a screenshot or `pflow render`).

// Control points, evenly spaced over [0, 1] (sRGB): matplotlib's viridis and a grey ramp (the patent's scalar
// fields as grey-scale images), a diverging blue-white-red for signed fields, and ten categorical colours.
const STOPS = {
  viridis: ['#440154', '#482878', '#3e4989', '#31688e', '#26828e', '#1f9e89', '#35b779', '#6ece58', '#fde725'],
  grey: ['#000000', '#ffffff'],
  coolwarm: ['#3b4cc0', '#7b9ff9', '#c0d4f5', '#dddddd', '#f2cbb7', '#ee8468', '#b40426'],
  inferno: ['#000004', '#280b54', '#65156e', '#9f2a63', '#d44842', '#f57d15', '#fac127', '#fcffa4'],
};
export const CATEGORICAL = ['#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b', '#e377c2', '#7f7f7f', '#bcbd22', '#17becf'];
export const COLORMAPS = [...Object.keys(STOPS), 'categories'];

function rgb(hex) {
  const v = parseInt(hex.slice(1), 16);
  return [(v >> 16) & 255, (v >> 8) & 255, v & 255];
}

// RGBA bytes, 256 entries.
export function lookupTable(name) {
  const lut = new Uint8Array(256 * 4);
  if (name === 'categories') {
    for (let i = 0; i < 256; ++i) {
      const c = rgb(CATEGORICAL[Math.min(9, Math.floor(i / 25.6))]);
      lut.set([...c, 255], 4 * i);
    }
    return lut;
  }
  const stops = (STOPS[name] || STOPS.viridis).map(rgb);
  for (let i = 0; i < 256; ++i) {
    const t = (i / 255) * (stops.length - 1);
    const k = Math.min(stops.length - 2, Math.floor(t));
    const f = t - k;
    for (let c = 0; c < 3; ++c) lut[4 * i + c] = Math.round(stops[k][c] * (1 - f) + stops[k + 1][c] * f);
    lut[4 * i + 3] = 255;
  }
  return lut;
}

export function cssColor(lut, t) {
  const i = 4 * Math.max(0, Math.min(255, Math.round(t * 255)));
  return `rgb(${lut[i]},${lut[i + 1]},${lut[i + 2]})`;
}

// Up to ~6 round tick values in [min, max].
export function ticks(min, max, count = 5) {
  if (!(max > min)) return [min];
  const raw = (max - min) / count;
  const mag = Math.pow(10, Math.floor(Math.log10(raw)));
  const step = [1, 2, 2.5, 5, 10].map((m) => m * mag).find((s) => s >= raw) || raw;
  const out = [];
  for (let v = Math.ceil(min / step) * step; v <= max + 1e-9 * step; v += step) out.push(Math.abs(v) < 1e-12 * step ? 0 : v);
  return out;
}

export function formatValue(v) {
  if (v === 0) return '0';
  const a = Math.abs(v);
  if (a >= 1e4 || a < 1e-3) return v.toExponential(2).replace('e+', 'e');
  return String(Number(v.toPrecision(4)));
}

// A vertical colour bar: the ramp in [x, x + w] x [y, y + h] (max at the top), ticks and values to its right,
// the label above. `scale` multiplies fonts (1 for the page, larger for big pictures).
export function drawColorBar(ctx, { x, y, w, h, lut, min, max, label, scale = 1, dark = false }) {
  const font = Math.round(13 * scale);
  ctx.save();
  for (let i = 0; i < h; ++i) {
    ctx.fillStyle = cssColor(lut, 1 - i / Math.max(1, h - 1));
    ctx.fillRect(x, y + i, w, 1);
  }
  ctx.strokeStyle = dark ? '#ddd' : '#333';
  ctx.lineWidth = Math.max(1, scale);
  ctx.strokeRect(x, y, w, h);
  ctx.fillStyle = dark ? '#eee' : '#111';
  ctx.font = `${font}px sans-serif`;
  ctx.textBaseline = 'middle';
  for (const v of ticks(min, max)) {
    const ty = y + h - ((v - min) / (max - min || 1)) * h;
    ctx.beginPath();
    ctx.moveTo(x + w, ty);
    ctx.lineTo(x + w + 5 * scale, ty);
    ctx.stroke();
    ctx.fillText(formatValue(v), x + w + 8 * scale, ty);
  }
  ctx.textBaseline = 'bottom';
  ctx.font = `bold ${font}px sans-serif`;
  const right = ctx.canvas.width / (ctx.getTransform().a || 1) - 6 * scale;  // keep the label inside the picture
  ctx.fillText(label, Math.min(x - 4 * scale, right - ctx.measureText(label).width), y - 8 * scale);
  ctx.restore();
}
