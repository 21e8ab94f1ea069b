// pflow-web's HTTP API (docs/viewer.md) with the user's token, kept in this browser tab only (sessionStorage).
import { fetchArrays } from './arrays.js';

const KEY = 'pflow-token';

export const token = {
  get: () => sessionStorage.getItem(KEY) || '',
  set: (t) => sessionStorage.setItem(KEY, t),
  clear: () => sessionStorage.removeItem(KEY),
};

export class ApiError extends Error {
  constructor(message, status, code) {
    super(message);
    this.status = status;
    this.code = code;
  }
}

function headers() {
  const t = token.get();
  return t ? { Authorization: `Bearer ${t}` } : {};
}

async function request(method, path) {
  const r = await fetch(path, { method, headers: headers() });
  let body = null;
  try {
    body = await r.json();
  } catch (_) { /* not JSON */ }
  if (!r.ok) throw new ApiError((body && body.error) || r.statusText, r.status, body && body.code);
  return body;
}

const id = (s) => encodeURIComponent(s);

export const api = {
  jobs: (all) => request('GET', `/api/jobs${all ? '?all=1' : ''}`),
  job: (job) => request('GET', `/api/jobs/${id(job)}`),
  cancel: (job) => request('POST', `/api/jobs/${id(job)}/cancel`),
  nodes: () => request('GET', '/api/nodes'),
  snapshots: (job) => request('GET', `/api/jobs/${id(job)}/snapshots`),
  snapshot: (job, step, { fields = [], grid = false, geometry = false } = {}) => {
    const q = new URLSearchParams();
    if (fields.length) q.set('fields', fields.join(','));
    if (grid) q.set('grid', '1');
    if (geometry) q.set('geometry', '1');
    return fetchArrays(`/api/jobs/${id(job)}/snapshots/${step}?${q}`, headers());
  },
  series: (job) => fetchArrays(`/api/jobs/${id(job)}/series`, headers()),
  // Server-sent events of a job (EventSource sends no headers: the token goes in the query, over loopback or TLS).
  events: (job, onEvent, onError) => {
    // Closed when the job has ended or the server says why not (EventSource would reconnect forever).
    const source = new EventSource(`/api/jobs/${id(job)}/events?token=${encodeURIComponent(token.get())}`);
    source.onmessage = (e) => {
      const event = JSON.parse(e.data);
      onEvent(event);
      if (event.job && ['succeeded', 'failed', 'cancelled'].includes(event.job.state)) source.close();
    };
    source.addEventListener('error', (e) => {
      if (!e.data) return;  // a dropped connection: EventSource reconnects
      source.close();
      onError(JSON.parse(e.data));
    });
    return source;
  },
};

export function formatRate(r) {
  if (!(r > 0)) return '';
  const units = [[1e9, 'G'], [1e6, 'M'], [1e3, 'k']];
  for (const [v, u] of units) if (r >= v) return `${(r / v).toFixed(r >= 10 * v ? 0 : 1)} ${u}`;
  return r.toFixed(0);
}

export function formatSeconds(s) {
  if (!(s >= 0) || !Number.isFinite(s)) return '';
  if (s < 60) return `${Math.round(s)} s`;
  if (s < 3600) return `${Math.floor(s / 60)} min ${Math.round(s % 60)} s`;
  return `${Math.floor(s / 3600)} h ${Math.round((s % 3600) / 60)} min`;
}

export function formatBytes(b) {
  if (!(b > 0)) return '0';
  const u = ['B', 'KiB', 'MiB', 'GiB', 'TiB'];
  const k = Math.min(u.length - 1, Math.floor(Math.log(b) / Math.log(1024)));
  return `${(b / Math.pow(1024, k)).toFixed(k ? 1 : 0)} ${u[k]}`;
}

// An element with text (never HTML: names and messages come from users).
export function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === undefined || v === null || v === false) continue;
    if (k.startsWith('on')) e.addEventListener(k.slice(2), v);
    else if (k === 'text') e.textContent = v;
    else e.setAttribute(k, v === true ? '' : v);
  }
  for (const c of children) if (c !== null && c !== undefined) e.append(c instanceof Node ? c : document.createTextNode(String(c)));
  return e;
}
