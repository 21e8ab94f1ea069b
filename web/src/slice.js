// A grid field on one slice of the back-end's grid (docs/output-format.md) as an image on a plane, and the
// in-plane velocity as streamlines over it.
import * as THREE from 'three';
import { lookupTable } from './colormap.js';

const AXES = { x: 0, y: 1, z: 2 };
const PLANE_AXES = [[1, 2], [0, 2], [0, 1]];  // image (u, v) axes for a slice normal to x, y, z

export function axisIndex(axis) {
  if (!(axis in AXES)) throw new Error(`slice axis '${axis}': one of x, y, z`);
  return AXES[axis];
}

// Per-cell value of a grid field: itself, or the magnitude of a vector (3 per cell).
function cellReader(field, cellCount) {
  const per = Math.round(field.values.length / cellCount);
  const v = field.values;
  if (per === 1) return (c) => v[c];
  return (c) => Math.hypot(v[per * c], v[per * c + 1], v[per * c + 2]);
}

// The slice's cell index along `a` for coordinate `value` (clamped to the grid).
function sliceIndex(spec, a, value) {
  const i = Math.floor((value - spec.origin[a]) / spec.cellSize);
  return Math.max(0, Math.min(spec.cells[a] - 1, i));
}

// Returns {object, min, max, unit, index, coordinate} or throws with the reason. options: {axis, value, field,
// colormap, range: [min, max] | null, streamlines}.
export function buildSlice(grid, options) {
  if (!grid || !grid.spec) throw new Error('this snapshot has no grid fields');
  const field = grid.fields[options.field];
  if (!field) throw new Error(`no grid field '${options.field}' (have: ${Object.keys(grid.fields).join(', ')})`);
  const spec = grid.spec;
  const [nx, ny, nz] = spec.cells;
  const a = axisIndex(options.axis);
  const [ua, va] = PLANE_AXES[a];
  const nu = spec.cells[ua], nv = spec.cells[va];
  const index = sliceIndex(spec, a, options.value);
  const cellOf = (u, v) => {
    const ijk = [0, 0, 0];
    ijk[a] = index;
    ijk[ua] = u;
    ijk[va] = v;
    return (ijk[0] * ny + ijk[1]) * nz + ijk[2];
  };
  const read = cellReader(field, nx * ny * nz);
  const image = new Float32Array(nu * nv);
  let min = Infinity, max = -Infinity;
  for (let v = 0; v < nv; ++v)
    for (let u = 0; u < nu; ++u) {
      const x = read(cellOf(u, v));
      image[v * nu + u] = x;
      if (Number.isFinite(x)) (min = Math.min(min, x)), (max = Math.max(max, x));
    }
  if (!(max >= min)) (min = 0), (max = 1);
  if (options.range) [min, max] = options.range;
  const lut = lookupTable(options.colormap || 'grey');
  // Cells without material (solid or fluid fraction 0) are left transparent: no field there, only emptiness.
  const fraction = grid.fields.solid_fraction || grid.fields.fluid_fraction;
  const rgba = new Uint8Array(nu * nv * 4);
  for (let v = 0; v < nv; ++v)
    for (let u = 0; u < nu; ++u) {
      const p = v * nu + u;
      const t = Math.max(0, Math.min(1, (image[p] - min) / (max - min || 1)));
      const k = 4 * Math.round(t * 255);
      const empty = fraction && !(fraction.values[cellOf(u, v)] > 0);
      rgba.set([lut[k], lut[k + 1], lut[k + 2], empty ? 0 : 255], 4 * p);
    }
  const texture = new THREE.DataTexture(rgba, nu, nv, THREE.RGBAFormat);
  texture.magFilter = THREE.NearestFilter;  // cells are cells: no smoothing that would invent values
  texture.colorSpace = THREE.SRGBColorSpace;
  texture.needsUpdate = true;

  const h = spec.cellSize;
  const coordinate = spec.origin[a] + (index + 0.5) * h;
  const lo = [spec.origin[ua], spec.origin[va]];
  const size = [nu * h, nv * h];
  // A quad in (u, v) mapped to world axes.
  const corner = (su, sv) => {
    const p = [0, 0, 0];
    p[a] = coordinate;
    p[ua] = lo[0] + su * size[0];
    p[va] = lo[1] + sv * size[1];
    return p;
  };
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.Float32BufferAttribute([...corner(0, 0), ...corner(1, 0), ...corner(1, 1), ...corner(0, 1)], 3));
  g.setAttribute('uv', new THREE.Float32BufferAttribute([0, 0, 1, 0, 1, 1, 0, 1], 2));
  g.setIndex([0, 1, 2, 0, 2, 3]);
  const group = new THREE.Group();
  group.add(new THREE.Mesh(g, new THREE.MeshBasicMaterial({ map: texture, side: THREE.DoubleSide, alphaTest: 0.5 })));

  if (options.streamlines) {
    const velocity = grid.fields.mean_velocity;
    if (!velocity) throw new Error('streamlines need the grid field mean_velocity');
    const vel = velocity.values;
    const inPlane = new Float32Array(nu * nv * 2);
    for (let v = 0; v < nv; ++v)
      for (let u = 0; u < nu; ++u) {
        const c = cellOf(u, v);
        inPlane[2 * (v * nu + u)] = vel[3 * c + ua];
        inPlane[2 * (v * nu + u) + 1] = vel[3 * c + va];
      }
    const lines = streamlines(inPlane, nu, nv);
    const positions = [];
    const toWorld = (pu, pv) => {
      const p = [0, 0, 0];
      p[a] = coordinate;
      p[ua] = lo[0] + pu * h;
      p[va] = lo[1] + pv * h;
      return p;
    };
    for (const line of lines)
      for (let k = 0; k + 3 < line.length; k += 2) positions.push(...toWorld(line[k], line[k + 1]), ...toWorld(line[k + 2], line[k + 3]));
    const lg = new THREE.BufferGeometry();
    lg.setAttribute('position', new THREE.Float32BufferAttribute(positions, 3));
    const segments = new THREE.LineSegments(lg, new THREE.LineBasicMaterial({ color: 0xff5a1f, depthTest: false }));
    segments.renderOrder = 2;  // over the image from either side
    group.add(segments);
  }
  return { object: group, min, max, unit: field.unit, index, coordinate, cells: [nu, nv] };
}

// Streamlines of a 2-D field (w: nu x nv x 2, cell-centred) in cell coordinates: seeded on a lattice, traced both
// ways by second-order Runge-Kutta along the field's direction (bilinear), stopped where the field vanishes,
// leaves the grid or runs into another line (an occupancy grid keeps them apart). Returns arrays [u0, v0, u1, ...].
export function streamlines(w, nu, nv) {
  let peak = 0;
  for (let i = 0; i < nu * nv; ++i) peak = Math.max(peak, Math.hypot(w[2 * i], w[2 * i + 1]));
  if (!(peak > 0)) return [];
  const floor = 1e-3 * peak;
  const sample = (u, v) => {
    const x = Math.max(0, Math.min(nu - 1, u - 0.5)), y = Math.max(0, Math.min(nv - 1, v - 0.5));
    const i = Math.min(nu - 2, Math.floor(x)), j = Math.min(nv - 2, Math.floor(y));
    const fx = nu > 1 ? x - Math.max(0, i) : 0, fy = nv > 1 ? y - Math.max(0, j) : 0;
    const at = (ii, jj, c) => w[2 * (Math.max(0, Math.min(nv - 1, jj)) * nu + Math.max(0, Math.min(nu - 1, ii))) + c];
    const out = [0, 0];
    for (let c = 0; c < 2; ++c)
      out[c] = (1 - fx) * (1 - fy) * at(i, j, c) + fx * (1 - fy) * at(i + 1, j, c) + (1 - fx) * fy * at(i, j + 1, c) + fx * fy * at(i + 1, j + 1, c);
    return out;
  };
  const res = 2;  // occupancy cells per grid cell
  const owner = new Int32Array(nu * nv * res * res).fill(-1);
  const occ = (u, v) => Math.floor(v * res) * nu * res + Math.floor(u * res);
  const inside = (u, v) => u >= 0 && v >= 0 && u < nu && v < nv;
  const stride = Math.max(1, Math.round(Math.max(nu, nv) / 28));
  const step = 0.3, maxSteps = 4 * (nu + nv);
  const lines = [];
  let touched = [];  // occupancy cells the current line took
  const trace = (u0, v0, sign, id) => {
    const pts = [];
    let u = u0, v = v0;
    for (let s = 0; s < maxSteps; ++s) {
      const k1 = sample(u, v);
      const m1 = Math.hypot(k1[0], k1[1]);
      if (m1 < floor) break;
      const um = u + 0.5 * step * sign * k1[0] / m1, vm = v + 0.5 * step * sign * k1[1] / m1;
      const k2 = sample(um, vm);
      const m2 = Math.hypot(k2[0], k2[1]);
      if (m2 < floor) break;
      const un = u + step * sign * k2[0] / m2, vn = v + step * sign * k2[1] / m2;
      if (!inside(un, vn)) break;
      const o = occ(un, vn);
      if (owner[o] >= 0 && owner[o] !== id) break;
      if (owner[o] < 0) touched.push(o);
      owner[o] = id;
      pts.push(un, vn);
      u = un;
      v = vn;
    }
    return pts;
  };
  for (let j = Math.floor(stride / 2); j < nv; j += stride)
    for (let i = Math.floor(stride / 2); i < nu; i += stride) {
      const u0 = i + 0.5, v0 = j + 0.5;
      if (owner[occ(u0, v0)] >= 0) continue;
      const id = lines.length;
      touched = [occ(u0, v0)];
      owner[occ(u0, v0)] = id;
      const back = trace(u0, v0, -1, id), fwd = trace(u0, v0, 1, id);
      if (back.length + fwd.length < 8) {  // too short to show: its cells free for others
        for (const o of touched) owner[o] = -1;
        continue;
      }
      const line = [];
      for (let k = back.length - 2; k >= 0; k -= 2) line.push(back[k], back[k + 1]);
      line.push(u0, v0, ...fwd);
      lines.push(line);
    }
  return lines;
}
