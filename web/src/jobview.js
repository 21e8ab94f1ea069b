// A job's 3-D view: the snapshot at the time slider (play, or follow a running job), coloured by any field, with
// range, colour map, clip plane, grid-field slice and streamlines, per-surface visibility, fixed views and a
// screenshot. The view element carries data-state (loading, ready, error) and data-step for scripts and tests.
import { api, el } from './api.js';
import { Viewer, VIEWS } from './viewer.js';
import { COLORMAPS } from './colormap.js';
import { seriesPanels, drawPlots } from './plot.js';

const CACHE = 6;  // snapshots kept for playing back and forth

export class JobView {
  constructor(root, jobId) {
    this.root = root;
    this.job = jobId;
    this.steps = [];
    this.cache = new Map();
    this.index = -1;
    this.follow = true;
    this.playing = null;
    this.geometryLoaded = false;
    this.build();
    this.viewer = new Viewer(this.canvas, { interactive: true, legendScale: 0.9, pixelRatio: Math.min(2, window.devicePixelRatio || 1),
      width: this.stage.clientWidth, height: this.stage.clientHeight });
    this.viewer.controls.addEventListener('change', () => this.drawLegend());
    this.resizer = new ResizeObserver(() => this.resize());
    this.resizer.observe(this.stage);
    this.stream = api.events(jobId, (e) => this.onEvent(e), () => {});
    this.listSnapshots();
  }

  build() {
    this.canvas = el('canvas', { id: 'view-canvas' });
    this.overlay = el('canvas', { id: 'view-overlay' });
    this.status = el('div', { class: 'view-status', id: 'view-status' });
    this.stage = el('div', { class: 'stage', id: 'view', 'data-state': 'loading' }, this.canvas, this.overlay, this.status);
    const select = (id, options, onchange) => el('select', { id, onchange }, ...options.map(([v, t]) => el('option', { value: v }, t)));
    this.title = el('h2', { id: 'view-title' }, `job ${this.job}`);
    this.colorBy = select('color-by', [], () => {
      this.min.value = this.max.value = '';  // a range belongs to its field
      this.recolor();
    });
    this.colormap = select('colormap', [['', 'by field'], ...COLORMAPS.map((m) => [m, m])], () => this.recolor());
    this.min = el('input', { id: 'range-min', type: 'number', step: 'any', placeholder: 'min', onchange: () => this.recolor() });
    this.max = el('input', { id: 'range-max', type: 'number', step: 'any', placeholder: 'max', onchange: () => this.recolor() });
    const autoRange = el('button', { onclick: () => { this.min.value = ''; this.max.value = ''; this.recolor(); } }, 'auto');
    this.slider = el('input', { id: 'time-slider', type: 'range', min: 0, max: 0, step: 1, value: 0, oninput: () => this.seek(Number(this.slider.value), false) });
    this.timeText = el('span', { id: 'time-text', class: 'mono' });
    this.play = el('button', { id: 'play', onclick: () => this.togglePlay() }, 'play');
    this.followBox = el('input', { type: 'checkbox', id: 'follow', checked: true, onchange: (e) => { this.follow = e.target.checked; } });
    this.clipOn = el('input', { type: 'checkbox', id: 'clip-on', onchange: () => this.applyClip() });
    this.clipAxis = select('clip-axis', [['y', 'y'], ['x', 'x'], ['z', 'z']], () => this.applyClip(true));
    this.clipValue = el('input', { type: 'range', id: 'clip-value', min: 0, max: 1000, value: 500, oninput: () => this.applyClip() });
    this.sliceOn = el('input', { type: 'checkbox', id: 'slice-on', onchange: () => this.applySlice(true) });
    this.sliceAxis = select('slice-axis', [['y', 'y'], ['x', 'x'], ['z', 'z']], () => this.applySlice());
    this.sliceValue = el('input', { type: 'range', id: 'slice-value', min: 0, max: 1000, value: 500, oninput: () => this.applySlice() });
    this.sliceField = select('slice-field', [], () => this.applySlice());
    this.sliceMap = select('slice-colormap', COLORMAPS.filter((m) => m !== 'categories').map((m) => [m, m]), () => this.applySlice());
    this.sliceMap.value = 'grey';
    this.streamBox = el('input', { type: 'checkbox', id: 'streamlines', onchange: () => this.applySlice() });
    this.particlesBox = el('input', { type: 'checkbox', id: 'particles-on', checked: true, onchange: (e) => { this.viewer.setParticlesVisible(e.target.checked); this.redraw(); } });
    this.surfaceList = el('div', { id: 'surfaces' });
    const views = el('div', { class: 'buttons' }, ...Object.keys(VIEWS).map((v) => el('button', { id: `view-${v}`, onclick: () => { this.viewer.setView(v); this.redraw(); } }, v)));
    const shot = el('button', { id: 'screenshot', onclick: () => this.screenshot() }, 'screenshot');
    this.plotsButton = el('button', { id: 'plots', onclick: () => this.togglePlots() }, 'time series');
    const row = (label, ...items) => el('div', { class: 'row' }, el('span', { class: 'label' }, label), ...items);
    const panel = el('div', { class: 'panel' },
      this.title,
      el('h3', {}, 'time'), row('', this.slider), row('', this.play, el('label', {}, this.followBox, ' follow'), this.timeText),
      el('h3', {}, 'colour'), row('field', this.colorBy), row('map', this.colormap), row('range', this.min, this.max, autoRange),
      row('', el('label', {}, this.particlesBox, ' particles')),
      el('h3', {}, 'clip plane'), row('', el('label', {}, this.clipOn, ' cut away beyond'), this.clipAxis), row('', this.clipValue),
      el('h3', {}, 'grid slice'), row('', el('label', {}, this.sliceOn, ' show'), this.sliceAxis, el('label', {}, this.streamBox, ' streamlines')),
      row('', this.sliceValue), row('field', this.sliceField), row('map', this.sliceMap),
      el('h3', {}, 'surfaces'), this.surfaceList,
      el('h3', {}, 'view'), views, row('', shot, this.plotsButton));
    this.root.replaceChildren(el('div', { class: 'jobview' }, this.stage, panel));
  }

  close() {
    if (this.stream) this.stream.close();
    this.stopPlay();
    this.resizer.disconnect();
    this.viewer.renderer.dispose();
  }

  resize() {
    const w = this.stage.clientWidth, h = this.stage.clientHeight;
    if (w < 10 || h < 10) return;
    this.viewer.setSize(w, h);
    this.redraw();
  }

  setState(state, message = '') {
    this.stage.dataset.state = state;
    this.status.textContent = message;
  }

  onEvent(event) {
    if (!event.job) return;
    const j = event.job;
    this.title.textContent = `${j.name || 'job'} ${j.id} (${j.state})`;
    const p = j.progress || {};
    const newest = this.steps.length ? this.steps[this.steps.length - 1].step : -1;
    if (p.step > newest || ['succeeded', 'failed', 'cancelled'].includes(j.state)) {
      this.listSnapshots();
      if (this.plotsOn && this.follow && Date.now() - (this.seriesAt || 0) > 5000) this.loadSeries();
    }
  }

  // The run's time series over the view (DEM series, SPH probes), drawn with plot.js.
  async togglePlots() {
    this.plotsOn = !this.plotsOn;
    this.plotsButton.textContent = this.plotsOn ? '3-D view' : 'time series';
    this.stage.dataset.plots = this.plotsOn ? 'loading' : 'off';
    if (this.plotsOn) await this.loadSeries();
    this.drawLegend();
  }

  async loadSeries() {
    this.seriesAt = Date.now();
    try {
      const s = await api.series(this.job);
      this.series = s.probes;
      this.stage.dataset.plots = 'ready';
    } catch (e) {
      this.series = null;
      this.stage.dataset.plots = 'error';
      this.status.textContent = `time series: ${e.message}`;
    }
    this.drawLegend();
  }

  async listSnapshots() {
    if (this.listing) {
      this.listAgain = true;  // an event came meanwhile: list once more when this one is done
      return;
    }
    this.listing = true;
    this.listAgain = false;
    try {
      const answer = await api.snapshots(this.job);
      const before = this.steps.length;
      this.steps = answer.snapshots || [];
      this.slider.max = Math.max(0, this.steps.length - 1);
      if (!this.steps.length) this.setState('loading', 'no snapshot yet');
      else if (this.index < 0 || (this.follow && this.steps.length !== before && !this.playing)) await this.seek(this.steps.length - 1, true);
    } catch (e) {
      this.setState('error', e.message);
    } finally {
      this.listing = false;
      if (this.listAgain) this.listSnapshots();
    }
  }

  async load(step) {
    const wantGrid = this.sliceOn.checked;
    const key = `${step}:${wantGrid}`;
    if (this.cache.has(key)) return this.cache.get(key);
    const snap = await api.snapshot(this.job, step, { grid: wantGrid, geometry: !this.geometryLoaded });
    if (snap.geometry) this.geometryLoaded = true;
    this.cache.set(key, snap);
    while (this.cache.size > CACHE) this.cache.delete(this.cache.keys().next().value);
    return snap;
  }

  async seek(index, moveSlider) {
    if (index < 0 || index >= this.steps.length) return;
    this.index = index;
    if (moveSlider) this.slider.value = index;
    const step = this.steps[index].step;
    this.setState('loading', `loading step ${step}`);
    try {
      const snap = await this.load(step);
      if (this.index !== index) return;  // the slider moved on meanwhile
      this.viewer.setSnapshot(snap, { keepView: true });
      if (snap.geometry) this.fillSurfaces();
      this.fillFields();
      this.applyClip(false, true);
      this.applySlice(false, true);
      this.timeText.textContent = `step ${snap.step}, t = ${snap.time.toPrecision(4)} s`;
      this.stage.dataset.step = String(snap.step);
      this.redraw();
      this.setState('ready');
    } catch (e) {
      this.setState('error', e.message);
    }
  }

  fillFields() {
    const fields = this.viewer.colorFields();
    const now = this.viewer.color.key;
    if (this.colorBy.options.length !== fields.length)
      this.colorBy.replaceChildren(...fields.map((f) => el('option', { value: f.key }, f.label)));
    this.colorBy.value = now;
    const grid = this.viewer.snapshot.grid;
    if (grid) {
      const names = Object.keys(grid.fields);
      const keep = this.sliceField.value;
      this.sliceField.replaceChildren(...names.map((n) => el('option', { value: n }, n)));
      if (names.includes(keep)) this.sliceField.value = keep;
    }
  }

  fillSurfaces() {
    this.surfaceList.replaceChildren(...this.viewer.surfaces.map((s) => el('label', { class: 'surface' },
      el('input', { type: 'checkbox', checked: s.object.visible, 'data-surface': s.number,
        onchange: (e) => { this.viewer.setSurfaceVisible(s.number, e.target.checked); this.redraw(); } }), ` ${s.name}`)));
  }

  recolor() {
    const range = this.min.value !== '' || this.max.value !== '' ? [this.min.value !== '' ? Number(this.min.value) : this.viewer.color.auto[0], this.max.value !== '' ? Number(this.max.value) : this.viewer.color.auto[1]] : null;
    this.viewer.color.userMap = this.colormap.value !== '';
    this.viewer.setColor({ key: this.colorBy.value, range, colormap: this.colormap.value || 'viridis' });
    this.redraw();
  }

  axisRange(axis) {
    const b = this.viewer.bounds;
    return [b.min[axis], b.max[axis]];
  }

  applyClip(axisChanged = false, quiet = false) {
    if (!this.viewer.snapshot) return;
    if (!this.clipOn.checked) this.viewer.setClip(null);
    else {
      const [lo, hi] = this.axisRange(this.clipAxis.value);
      this.viewer.setClip({ axis: this.clipAxis.value, value: lo + (Number(this.clipValue.value) / 1000) * (hi - lo) });
    }
    if (!quiet) this.redraw();
  }

  async applySlice(toggled = false, quiet = false) {
    if (!this.viewer.snapshot) return;
    if (!this.sliceOn.checked) {
      this.viewer.setSlice(null);
      if (!quiet) this.redraw();
      return;
    }
    if (!this.viewer.snapshot.grid) {  // the grid comes with a second request
      if (toggled) await this.seek(this.index, false);
      return;
    }
    const [lo, hi] = this.axisRange(this.sliceAxis.value);
    try {
      if (!this.sliceField.value) this.fillFields();
      this.viewer.setSlice({ axis: this.sliceAxis.value, value: lo + (Number(this.sliceValue.value) / 1000) * (hi - lo),
        field: this.sliceField.value || Object.keys(this.viewer.snapshot.grid.fields)[0], streamlines: this.streamBox.checked, colormap: this.sliceMap.value });
      this.status.textContent = '';
    } catch (e) {
      this.status.textContent = e.message;
    }
    if (!quiet) this.redraw();
  }

  togglePlay() {
    if (this.playing) return this.stopPlay();
    this.play.textContent = 'pause';
    const tick = async () => {
      if (!this.playing) return;
      const next = this.index + 1 < this.steps.length ? this.index + 1 : 0;
      await this.seek(next, true);
      if (this.playing) this.playing = setTimeout(tick, 150);
    };
    this.playing = setTimeout(tick, 0);
  }

  stopPlay() {
    if (this.playing) clearTimeout(this.playing);
    this.playing = null;
    this.play.textContent = 'play';
  }

  redraw() {
    this.viewer.render();
    this.drawLegend();
  }

  drawLegend() {
    const w = this.stage.clientWidth, h = this.stage.clientHeight;
    this.overlay.width = w;
    this.overlay.height = h;
    const ctx = this.overlay.getContext('2d');
    ctx.clearRect(0, 0, w, h);
    if (this.plotsOn) drawPlots(ctx, w, h, seriesPanels(this.series), this.title.textContent, { scale: 0.9 });
    else this.viewer.drawLegend(ctx);
  }

  screenshot() {
    const picture = this.viewer.compose(this.title.textContent);
    picture.toBlob((blob) => {
      const a = el('a', { href: URL.createObjectURL(blob), download: `pflow-${this.job}-step${this.stage.dataset.step || 0}.png` });
      document.body.append(a);
      a.click();
      a.remove();
    }, 'image/png');
  }
}
