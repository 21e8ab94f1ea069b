// The 3-D view shared by the page (app.js) and `pflow render` (render.js): particles as shaded spheres coloured by
// a field, walls as transparent surfaces, a clip plane, a grid-field slice with streamlines, fixed views and a
// composed picture (the view, its title and colour bars) for screenshots.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { ParticleCloud } from './particles.js';
import { buildSurfaces, clipSurfaces } from './geometry.js';
import { buildSlice, axisIndex } from './slice.js';
import { lookupTable, drawColorBar, formatValue } from './colormap.js';

const CATEGORY_FIELDS = new Set(['material', 'kind', 'type']);

// The colourings a snapshot offers: derived ones first, then every stored scalar, then vector magnitudes.
export function colorFields(particles) {
  const out = [];
  const has = (n, c) => particles[n] && particles[n].components === c;
  if (has('velocity', 3)) out.push({ key: 'speed', label: 'speed', unit: particles.velocity.unit });
  if (has('position', 3)) out.push({ key: 'height', label: 'height (z)', unit: particles.position.unit });
  if (has('radius', 1)) out.push({ key: 'diameter', label: 'diameter', unit: particles.radius.unit });
  for (const [name, f] of Object.entries(particles)) if (f.components === 1) out.push({ key: name, label: name, unit: f.unit });
  for (const [name, f] of Object.entries(particles))
    if (f.components === 3 && name !== 'position' && name !== 'velocity') out.push({ key: `|${name}|`, label: `|${name}|`, unit: f.unit });
  return out;
}

export function fieldValues(particles, key) {
  const n = particles.position ? particles.position.rows : 0;
  const out = new Float32Array(n);
  const vec = (f, k) => {
    for (let i = 0; i < n; ++i) out[i] = Math.hypot(f[3 * i], f[3 * i + 1], f[3 * i + 2]);
    return out;
  };
  if (key === 'speed') return vec(particles.velocity.values);
  if (key === 'height') {
    for (let i = 0; i < n; ++i) out[i] = particles.position.values[3 * i + 2];
    return out;
  }
  if (key === 'diameter') {
    for (let i = 0; i < n; ++i) out[i] = 2 * particles.radius.values[i];
    return out;
  }
  if (key.startsWith('|') && particles[key.slice(1, -1)]) return vec(particles[key.slice(1, -1)].values);
  const f = particles[key];
  if (!f || f.components !== 1) throw new Error(`no particle field '${key}' (have: ${colorFields(particles).map((c) => c.key).join(', ')})`);
  return f.values;
}

// Radii to draw: `radius`, or for a fluid the sphere (3-D) or half the square side (a planar fluid) of m / rho.
export function drawRadii(particles) {
  if (particles.radius) return particles.radius.values;
  const n = particles.position ? particles.position.rows : 0;
  const r = new Float32Array(n);
  const m = particles.mass && particles.mass.values, rho = particles.density && particles.density.values;
  const p = particles.position.values;
  let planar = n > 1;
  for (let i = 1; i < n && planar; ++i) planar = p[3 * i + 1] === p[1];
  for (let i = 0; i < n; ++i) {
    const v = m && rho && rho[i] > 0 ? m[i] / rho[i] : NaN;
    r[i] = planar ? 0.5 * Math.sqrt(v) : Math.cbrt((3 * v) / (4 * Math.PI));
  }
  let fallback = 0;
  if (!r.every((x) => x > 0)) {  // nothing to size them by: 1/100 of the box's largest side
    const box = new THREE.Box3();
    for (let i = 0; i < n; ++i) box.expandByPoint(new THREE.Vector3(p[3 * i], p[3 * i + 1], p[3 * i + 2]));
    const s = box.getSize(new THREE.Vector3());
    fallback = Math.max(s.x, s.y, s.z, 1e-3) / 100;
    for (let i = 0; i < n; ++i) if (!(r[i] > 0)) r[i] = fallback;
  }
  return r;
}

function finiteRange(values) {
  let min = Infinity, max = -Infinity;
  for (let i = 0; i < values.length; ++i) {
    const v = values[i];
    if (!Number.isFinite(v)) continue;
    if (v < min) min = v;
    if (v > max) max = v;
  }
  if (!(max >= min)) return [0, 1];
  if (max === min) return min === 0 ? [0, 1] : [min - 0.5 * Math.abs(min), max + 0.5 * Math.abs(max)];
  return [min, max];
}

// Frees the GPU side of an object tree (geometries, materials, textures): three.js does not when it is removed.
function dispose(object) {
  object.traverse((o) => {
    if (o.geometry) o.geometry.dispose();
    if (o.material) {
      if (o.material.map) o.material.map.dispose();
      o.material.dispose();
    }
  });
}

export const VIEWS = {
  iso: { dir: [1, -1.25, 0.85], up: [0, 0, 1] },
  top: { dir: [0, 0, 1], up: [0, 1, 0] },
  front: { dir: [0, -1, 0], up: [0, 0, 1] },
  side: { dir: [1, 0, 0], up: [0, 0, 1] },
};

export class Viewer {
  // canvas: the WebGL canvas; options: {width, height, pixelRatio, interactive}.
  constructor(canvas, options = {}) {
    this.canvas = canvas;
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: options.antialias !== false, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(options.pixelRatio || 1);
    this.renderer.localClippingEnabled = true;
    this.renderer.setClearColor(0xf3f4f6, 1);
    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(25, 1, 1e-4, 1e4);
    this.camera.up.set(0, 0, 1);
    this.scene.add(new THREE.AmbientLight(0xffffff, 0.55));
    this.headlight = new THREE.DirectionalLight(0xffffff, 1.6);
    this.camera.add(this.headlight);
    this.headlight.position.set(0.3, 0.5, 1);
    this.scene.add(this.camera);
    this.particles = new ParticleCloud({ sprites: options.sprites || 'quads' });
    this.scene.add(this.particles.mesh);
    this.surfaces = [];
    this.surfaceGroup = new THREE.Group();
    this.scene.add(this.surfaceGroup);
    this.sliceGroup = new THREE.Group();
    this.scene.add(this.sliceGroup);
    this.bounds = new THREE.Box3();
    this.snapshot = null;
    this.color = { key: null, colormap: 'viridis', range: null, auto: [0, 1] };
    this.clip = null;
    this.slice = null;     // {axis, value, field, streamlines, colormap}
    this.sliceInfo = null;
    this.viewName = 'iso';
    this.legendScale = options.legendScale || 1;  // font scale of the colour bars
    this.controls = null;
    if (options.interactive) {
      this.controls = new OrbitControls(this.camera, canvas);
      this.controls.addEventListener('change', () => this.render());
    }
    this.setSize(options.width || canvas.clientWidth || 800, options.height || canvas.clientHeight || 600);
  }

  setSize(width, height) {
    this.width = width;
    this.height = height;
    this.renderer.setSize(width, height, false);
    this.particles.setViewportHeight(height * this.renderer.getPixelRatio());
    this.camera.aspect = width / height;
    if (this.camera.view) this.camera.setViewOffset(width, height, this.camera.view.offsetX, 0, width, height);
    this.camera.updateProjectionMatrix();
  }

  // A snapshot (arrays.js). Geometry is kept from an earlier snapshot when this one carries none.
  setSnapshot(snapshot, { keepView = false } = {}) {
    const p = snapshot.particles;
    if (!p.position || p.position.components !== 3) throw new Error('the snapshot has no position array');
    const first = !this.snapshot;
    this.snapshot = snapshot;
    this.particles.setData(p.position.values, drawRadii(p), new Float32Array(p.position.rows));
    this.bounds = new THREE.Box3();
    const pos = p.position.values, r = drawRadii(p);
    this.planarY = p.position.rows > 1;  // a planar (2-D, x-z) scene: every particle at one y
    for (let i = 1; i < p.position.rows && this.planarY; ++i) this.planarY = pos[3 * i + 1] === pos[1];
    for (let i = 0; i < p.position.rows; ++i) {
      const x = pos[3 * i], y = pos[3 * i + 1], z = pos[3 * i + 2];
      if (!Number.isFinite(x + y + z)) continue;
      this.bounds.expandByPoint(new THREE.Vector3(x - r[i], y - r[i], z - r[i]));
      this.bounds.expandByPoint(new THREE.Vector3(x + r[i], y + r[i], z + r[i]));
    }
    if (snapshot.geometry) this.setGeometry(snapshot.geometry);
    const fields = colorFields(p);
    if (!this.color.key || !fields.some((f) => f.key === this.color.key)) this.color.key = fields.length ? fields[0].key : null;
    this.applyColor();
    if (this.slice) this.setSlice(this.slice);
    if (first || !keepView) this.setView(this.viewName);
  }

  setGeometry(geometry) {
    for (const s of this.surfaces) (this.surfaceGroup.remove(s.object), dispose(s.object));
    const hidden = new Set(this.surfaces.filter((s) => !s.object.visible).map((s) => s.number));
    this.surfaces = buildSurfaces(geometry, this.bounds);
    for (const s of this.surfaces) {
      s.object.visible = !hidden.has(s.number);
      this.surfaceGroup.add(s.object);
    }
    this.applyClip();
  }

  setSurfaceVisible(number, visible) {
    for (const s of this.surfaces) if (s.number === number) s.object.visible = visible;
  }

  colorFields() {
    return this.snapshot ? colorFields(this.snapshot.particles) : [];
  }

  // key: a colorFields() key; range: [min, max] or null (the snapshot's own); colormap: a COLORMAPS name.
  setColor({ key, range, colormap } = {}) {
    if (key !== undefined) this.color.key = key;
    if (range !== undefined) this.color.range = range;
    if (colormap !== undefined) this.color.colormap = colormap;
    this.applyColor();
  }

  applyColor() {
    if (!this.snapshot || !this.color.key) return;
    let values = fieldValues(this.snapshot.particles, this.color.key);
    const kind = this.snapshot.particles.kind;
    if (kind && this.color.key !== 'kind') {  // a fluid's boundary particles: neutral grey, out of the colour range
      values = Float32Array.from(values);
      for (let i = 0; i < values.length; ++i) if (kind.values[i] !== 0) values[i] = NaN;
    }
    this.particles.setValues(values);
    let auto = finiteRange(values);
    const category = CATEGORY_FIELDS.has(this.color.key);
    if (category) auto = [Math.round(auto[0]) - 0.5, Math.round(auto[0]) + 9.5];
    this.color.auto = auto;
    const [min, max] = this.color.range || auto;
    this.particles.setRange(min, max);
    this.particles.setLookupTable(lookupTable(category && !this.color.userMap ? 'categories' : this.color.colormap));
  }

  colorRange() {
    return this.color.range || this.color.auto;
  }

  // The view a snapshot is best seen from: front for a planar (x-z) scene, else iso.
  defaultView() {
    return this.planarY ? 'front' : 'iso';
  }

  // clip: {axis: 'x'|'y'|'z', value, below: false, surfacesOnly: false} or null: what lies beyond value along the
  // axis (below it with `below`) is cut away, from the surfaces only with `surfacesOnly`.
  setClip(clip) {
    this.clip = clip;
    this.applyClip();
  }

  applyClip() {
    if (!this.clip) {
      this.particles.setClip(null);
      clipSurfaces(this.surfaces, []);
      return;
    }
    const a = axisIndex(this.clip.axis);
    const sign = this.clip.below ? -1 : 1;
    const normal = [0, 0, 0];
    normal[a] = sign;
    this.particles.setClip(this.clip.surfacesOnly ? null : { normal, offset: sign * this.clip.value });
    // THREE.Plane keeps the side where dot(n, p) + constant >= 0.
    const n = new THREE.Vector3(-normal[0], -normal[1], -normal[2]);
    clipSurfaces(this.surfaces, [new THREE.Plane(n, sign * this.clip.value)]);
  }

  // slice: {axis, value, field, streamlines, colormap, range} or null. Throws with the reason on a bad request.
  setSlice(slice) {
    dispose(this.sliceGroup);
    this.sliceGroup.clear();
    this.slice = slice;
    this.sliceInfo = null;
    if (!slice || !this.snapshot) return;
    this.sliceInfo = buildSlice(this.snapshot.grid, slice);
    this.sliceGroup.add(this.sliceInfo.object);
  }

  setParticlesVisible(visible) {
    this.particles.mesh.visible = visible;
  }

  // Looks at the particles' box from a fixed direction (VIEWS), fitting it to the frame.
  setView(name) {
    const view = VIEWS[name];
    if (!view) throw new Error(`view '${name}': one of ${Object.keys(VIEWS).join(', ')}`);
    this.viewName = name;
    // Framed: what is drawn (particles, slice, meshes), not the squares standing for planes (a floor far below
    // would shrink everything else).
    const frame = this.particles.mesh.visible ? this.bounds.clone() : new THREE.Box3();
    if (this.sliceInfo) frame.union(new THREE.Box3().setFromObject(this.sliceInfo.object));
    for (const s of this.surfaces)
      if (s.object.visible) s.object.traverse((o) => { if (o.isMesh && o.geometry.type !== 'PlaneGeometry') frame.union(new THREE.Box3().setFromObject(o)); });
    if (frame.isEmpty()) frame.copy(this.bounds);
    if (frame.isEmpty()) frame.set(new THREE.Vector3(-1, -1, -1), new THREE.Vector3(1, 1, 1));
    const centre = frame.getCenter(new THREE.Vector3());
    const f = new THREE.Vector3(...view.dir).normalize();  // from the centre towards the camera
    const up = new THREE.Vector3(...view.up);
    const right = new THREE.Vector3().crossVectors(up, f).normalize();
    const trueUp = new THREE.Vector3().crossVectors(f, right);
    let hx = 0, hy = 0, hz = 0;
    for (let c = 0; c < 8; ++c) {
      const p = new THREE.Vector3(c & 1 ? frame.max.x : frame.min.x, c & 2 ? frame.max.y : frame.min.y, c & 4 ? frame.max.z : frame.min.z).sub(centre);
      hx = Math.max(hx, Math.abs(p.dot(right)));
      hy = Math.max(hy, Math.abs(p.dot(trueUp)));
      hz = Math.max(hz, Math.abs(p.dot(f)));
    }
    // The colour bars take the right of the picture: fit into the rest, and shift the view left by half of it.
    const bars = (this.particles.mesh.visible && this.color.key ? 1 : 0) + (this.sliceInfo ? 1 : 0);
    const legend = Math.min(0.4 * this.width, bars * 130 * this.legendScale);
    const aspect = (this.width - legend) / this.height;
    this.camera.setViewOffset(this.width, this.height, 0.5 * legend, 0, this.width, this.height);
    const t = Math.tan(THREE.MathUtils.degToRad(this.camera.fov / 2));
    const distance = hz + 1.1 * Math.max(hx / (t * aspect), hy / t, 1e-6);
    this.camera.up.copy(trueUp);
    this.camera.position.copy(centre).addScaledVector(f, distance);
    this.camera.near = Math.max(1e-5, (distance - 4 * hz) / 100, distance / 1e4);
    this.camera.far = distance + 4 * (hz + hx + hy) + 1;
    this.camera.lookAt(centre);
    this.camera.updateProjectionMatrix();
    if (this.controls) {
      this.controls.target.copy(centre);
      this.controls.update();
    }
  }

  render() {
    this.renderer.render(this.scene, this.camera);
  }

  // The legend: the particles' colour bar (right) and the slice's (left of it), into a 2D context of the
  // picture's size. `scale`: font scale.
  drawLegend(ctx, { scale = this.legendScale } = {}) {
    const barH = Math.min(0.55 * this.height, 520 * scale), barW = 22 * scale;
    const y = 0.5 * (this.height - barH);
    let x = this.width - 120 * scale;
    if (this.snapshot && this.color.key && this.particles.mesh.visible) {
      const field = colorFields(this.snapshot.particles).find((f) => f.key === this.color.key);
      const [min, max] = this.colorRange();
      const category = CATEGORY_FIELDS.has(this.color.key);
      const lut = lookupTable(category && !this.color.userMap ? 'categories' : this.color.colormap);
      drawColorBar(ctx, { x, y, w: barW, h: barH, lut, min, max, label: field ? `${field.label}${field.unit ? ` [${field.unit}]` : ''}` : this.color.key, scale });
      x -= 130 * scale;
    }
    if (this.sliceInfo) {
      const s = this.slice;
      drawColorBar(ctx, { x, y, w: barW, h: barH, lut: lookupTable(s.colormap || 'grey'), min: this.sliceInfo.min, max: this.sliceInfo.max,
        label: `${s.field}${this.sliceInfo.unit ? ` [${this.sliceInfo.unit}]` : ''}`, scale });
    }
  }

  // The picture as a 2D canvas: the view, the title (with the snapshot's step and time) and the legend.
  compose(title, { scale = this.legendScale } = {}) {
    this.render();
    const out = document.createElement('canvas');
    out.width = this.canvas.width;
    out.height = this.canvas.height;
    const ctx = out.getContext('2d');
    ctx.drawImage(this.canvas, 0, 0);
    ctx.setTransform(out.width / this.width, 0, 0, out.height / this.height, 0, 0);
    ctx.fillStyle = '#111';
    ctx.font = `bold ${Math.round(20 * scale)}px sans-serif`;
    ctx.textBaseline = 'top';
    ctx.fillText(title, 24 * scale, 20 * scale);
    if (this.snapshot) {
      ctx.font = `${Math.round(16 * scale)}px sans-serif`;
      const n = this.snapshot.particles.position.rows;
      let line = `t = ${formatValue(this.snapshot.time)} s   step ${this.snapshot.step}   ${n.toLocaleString('en-US')} particles`;
      if (this.sliceInfo) line += `   slice ${this.slice.axis} = ${formatValue(this.sliceInfo.coordinate)} m`;
      if (this.clip) line += `   clipped at ${this.clip.axis} = ${formatValue(this.clip.value)} m`;
      ctx.fillText(line, 24 * scale, 50 * scale);
    }
    this.drawLegend(ctx, { scale });
    return out;
  }
}
