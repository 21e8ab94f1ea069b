// The scene's walls as transparent surfaces, one object per surface (its triangles, or a plane drawn as a square
// across the particles' box), so each can be shown or hidden. Input: the snapshot's geometry section (arrays.js).
import * as THREE from 'three';
import { CATEGORICAL } from './colormap.js';

function surfaceMaterial(index) {
  return new THREE.MeshPhongMaterial({
    color: new THREE.Color(CATEGORICAL[(index + 7) % CATEGORICAL.length]).lerp(new THREE.Color('#b0b8c0'), 0.55),
    transparent: true,
    opacity: 0.28,
    side: THREE.DoubleSide,
    depthWrite: false,
    shininess: 20,
  });
}

// bounds: THREE.Box3 of the particles (planes are drawn across it). Returns [{name, object}] by surface number.
export function buildSurfaces(geometry, bounds) {
  const surfaces = new Map();
  const names = geometry.surface_names || [];
  const nameOf = (s, fallback) => names[s] || fallback || `surface ${s}`;
  const add = (s, name, object) => {
    if (!surfaces.has(s)) surfaces.set(s, { name, objects: [] });
    surfaces.get(s).objects.push(object);
  };
  const vertices = geometry.vertices, triangles = geometry.triangles;
  if (vertices && triangles) {
    const tSurface = geometry.triangle_surface ? geometry.triangle_surface.values : null;
    const byTri = new Map();
    for (let t = 0; t < triangles.rows; ++t) {
      const s = tSurface ? tSurface[t] : 0;
      if (!byTri.has(s)) byTri.set(s, []);
      byTri.get(s).push(t);
    }
    for (const [s, list] of byTri) {
      const pos = new Float32Array(list.length * 9);
      list.forEach((t, k) => {
        for (let c = 0; c < 3; ++c) {
          const v = triangles.values[3 * t + c];
          pos.set(vertices.values.subarray(3 * v, 3 * v + 3), 9 * k + 3 * c);
        }
      });
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.BufferAttribute(pos, 3));
      g.computeVertexNormals();
      const mesh = new THREE.Mesh(g, surfaceMaterial(s));
      const edges = new THREE.LineSegments(new THREE.EdgesGeometry(g, 30), new THREE.LineBasicMaterial({ color: 0x506070, transparent: true, opacity: 0.6 }));
      const group = new THREE.Group();
      group.add(mesh, edges);
      add(s, nameOf(s), group);
    }
  }
  const pp = geometry.plane_point, pn = geometry.plane_normal;
  if (pp && pn && !bounds.isEmpty()) {
    // A plane is drawn as the square across the box of the particles and the meshes.
    const box = bounds.clone();
    for (const { objects } of surfaces.values()) for (const o of objects) box.union(new THREE.Box3().setFromObject(o));
    const size = box.getSize(new THREE.Vector3());
    const centre = box.getCenter(new THREE.Vector3());
    const extent = 1.1 * Math.max(size.x, size.y, size.z, 1e-6);
    const pSurface = geometry.plane_surface ? geometry.plane_surface.values : null;
    for (let p = 0; p < pp.rows; ++p) {
      const point = new THREE.Vector3().fromArray(pp.values, 3 * p);
      const normal = new THREE.Vector3().fromArray(pn.values, 3 * p).normalize();
      // The square of side `extent` in the plane, centred on the projection of the particles' centre.
      const c = centre.clone().sub(normal.clone().multiplyScalar(centre.clone().sub(point).dot(normal)));
      const g = new THREE.PlaneGeometry(extent, extent);
      const mesh = new THREE.Mesh(g, surfaceMaterial(pSurface ? pSurface[p] : 100 + p));
      mesh.quaternion.setFromUnitVectors(new THREE.Vector3(0, 0, 1), normal);
      mesh.position.copy(c);
      const s = pSurface ? pSurface[p] : -1 - p;
      add(s, nameOf(s, (geometry.plane_names || [])[p]), mesh);
    }
  }
  return [...surfaces.entries()].sort((a, b) => a[0] - b[0]).map(([number, { name, objects }]) => {
    const group = new THREE.Group();
    for (const o of objects) group.add(o);
    return { number, name, object: group };
  });
}

// Applies clipping planes (THREE.Plane[]) to every material of the surfaces.
export function clipSurfaces(surfaces, planes) {
  for (const s of surfaces)
    s.object.traverse((o) => {
      if (o.material) {
        o.material.clippingPlanes = planes;
        o.material.needsUpdate = true;
      }
    });
}
