// The jobs and nodes tables: the list polled every few seconds, running jobs' progress live from their event
// streams (at most MAX_STREAMS at once: a browser keeps six connections to one server).
import { api, el, formatRate, formatSeconds, formatBytes } from './api.js';

const MAX_STREAMS = 4;
const ACTIVE = new Set(['building', 'queued', 'starting', 'running', 'cancelling', 'requeued']);

function deviceText(job) {
  const d = job.devices || [];
  if (!d.length) return '';
  const nodes = new Set(d.map((x) => x.node));
  return `${d.length} ${d[0].kind}${d.length > 1 ? 's' : ''} on ${[...nodes].join(', ')}`;
}

export class JobsTable {
  constructor(root, { onOpen }) {
    this.root = root;
    this.onOpen = onOpen;
    this.jobs = new Map();
    this.streams = new Map();
    this.all = false;
    this.armed = null;  // the job whose cancel button asks for confirmation
    this.error = el('div', { class: 'error', id: 'jobs-error' });
    this.body = el('tbody');
    const allBox = el('input', { type: 'checkbox', id: 'jobs-all', onchange: (e) => { this.all = e.target.checked; this.refresh(); } });
    root.append(
      el('div', { class: 'toolbar' }, el('label', {}, allBox, ' finished jobs too')),
      this.error,
      el('table', { id: 'jobs-table', class: 'table' },
        el('thead', {}, el('tr', {}, ...['job', 'name', 'state', 'owner', 'particles', 'devices', 'step', 'progress', 'rate [particle-steps/s]', 'ETA', ''].map((h) => el('th', {}, h)))),
        this.body));
  }

  async refresh() {
    try {
      const list = await api.jobs(this.all);
      this.error.textContent = '';
      this.jobs = new Map(list.map((j) => [j.id, j]));
      this.render();
      this.followStreams();
    } catch (e) {
      this.error.textContent = `jobs: ${e.message}`;
      if (e.status === 401 || e.status === 403) throw e;
    }
  }

  followStreams() {
    const running = [...this.jobs.values()].filter((j) => ACTIVE.has(j.state)).slice(0, MAX_STREAMS).map((j) => j.id);
    for (const [id, s] of this.streams)
      if (!running.includes(id)) {
        s.close();
        this.streams.delete(id);
      }
    for (const id of running)
      if (!this.streams.has(id))
        this.streams.set(id, api.events(id, (event) => {
          if (!event.job) return;
          this.jobs.set(event.job.id, event.job);
          this.render();
        }, () => {}));
  }

  close() {
    for (const s of this.streams.values()) s.close();
    this.streams.clear();
  }

  // Rows are kept and updated in place (a row rebuilt under the pointer would swallow a click).
  render() {
    this.rows = this.rows || new Map();
    const jobs = [...this.jobs.values()].sort((a, b) => (b.submitted_at || 0) - (a.submitted_at || 0) || (a.id < b.id ? 1 : -1));
    for (const [id, row] of this.rows) if (!this.jobs.has(id)) (row.tr.remove(), this.rows.delete(id));
    jobs.forEach((j, index) => {
      let row = this.rows.get(j.id);
      if (!row) {
        row = { cells: Array.from({ length: 11 }, () => el('td')) };
        row.tr = el('tr', { 'data-job': j.id, class: 'job-row', onclick: () => this.onOpen(j.id) }, ...row.cells);
        row.cells[0].className = 'mono';
        for (const k of [4, 6, 8, 9]) row.cells[k].className = 'num';
        row.state = el('span');
        row.reason = el('div', { class: 'reason' });
        row.cells[2].append(row.state, row.reason);
        row.fill = el('div', { class: 'progress-fill' });
        row.bar = el('div', { class: 'progress' }, row.fill);
        row.percent = el('span', { class: 'progress-text' });
        row.cells[7].className = 'progress-cell';
        row.cells[7].append(row.bar, row.percent);
        row.cancel = el('button', { class: 'cancel', id: `cancel-${j.id}`, onclick: (e) => this.cancel(e, j.id) });
        this.rows.set(j.id, row);
      }
      if (this.body.children[index] !== row.tr) this.body.insertBefore(row.tr, this.body.children[index] || null);
      const p = j.progress || {};
      const active = ACTIVE.has(j.state);
      const fraction = p.total_steps > 0 ? Math.min(1, p.step / p.total_steps) : j.state === 'succeeded' ? 1 : 0;
      const text = (k, t) => { if (row.cells[k].textContent !== t) row.cells[k].textContent = t; };
      row.tr.dataset.state = j.state;
      text(0, j.id);
      text(1, j.name || '');
      row.state.className = `state state-${j.state}`;
      row.state.textContent = j.state;
      row.reason.textContent = j.reason || '';
      text(3, j.owner || '');
      text(4, (j.particles || 0).toLocaleString('en-US'));
      text(5, deviceText(j));
      text(6, p.total_steps ? `${p.step} / ${p.total_steps}` : '');
      row.bar.dataset.fraction = fraction.toFixed(4);
      row.fill.style.width = `${(100 * fraction).toFixed(1)}%`;
      row.percent.textContent = `${(100 * fraction).toFixed(1)} %`;
      text(8, active ? formatRate(p.particle_steps_per_s) : '');
      text(9, active && p.eta_s > 0 ? formatSeconds(p.eta_s) : '');
      row.cancel.textContent = this.armed === j.id ? 'confirm cancel' : 'cancel';
      if (active && !row.cancel.isConnected) row.cells[10].append(row.cancel);
      if (!active && row.cancel.isConnected) row.cancel.remove();
    });
  }

  async cancel(event, id) {
    event.stopPropagation();
    if (this.armed !== id) {
      this.armed = id;  // a second click confirms
      this.render();
      return;
    }
    this.armed = null;
    try {
      const job = await api.cancel(id);
      this.jobs.set(job.id, job);
      this.render();
    } catch (e) {
      this.error.textContent = `cancel ${id}: ${e.message}`;
    }
  }
}

export async function renderNodes(root) {
  const nodes = await api.nodes();
  const rows = [];
  for (const n of nodes)
    for (const d of n.devices || [])
      rows.push(el('tr', { 'data-node': n.node },
        el('td', {}, n.node, n.lost ? el('span', { class: 'state state-failed' }, ' lost') : null),
        el('td', {}, `${d.kind} ${d.index}`),
        el('td', {}, d.name || ''),
        el('td', {}, el('span', { class: `state state-${d.state}` }, d.state)),
        el('td', { class: 'num' }, d.memory_total_bytes ? `${formatBytes(d.memory_used_bytes)} / ${formatBytes(d.memory_total_bytes)}` : ''),
        el('td', { class: 'num' }, d.utilization !== undefined ? `${Math.round(100 * d.utilization)} %` : ''),
        el('td', { class: 'num' }, d.temperature_c ? `${d.temperature_c} °C` : ''),
        el('td', { class: 'mono' }, d.job || '')));
  root.replaceChildren(el('table', { id: 'nodes-table', class: 'table' },
    el('thead', {}, el('tr', {}, ...['node', 'device', 'name', 'state', 'memory', 'load', 'temperature', 'job'].map((h) => el('th', {}, h)))),
    el('tbody', {}, ...rows)));
}
