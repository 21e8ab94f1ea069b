// Particles as shaded spheres: one camera-facing quad per particle (instanced), on which the fragment shader
// intersects the view ray with the true sphere, shades it and writes its depth. Four vertices a particle whatever
// the zoom, so 10^6 particles stay interactive on a laptop GPU; spheres cut each other exactly where they overlap.
import * as THREE from 'three';

const vertexShader = /* glsl */ `
#ifdef POINTS
#define center position
#else
in vec3 center;
#endif
in float radius;
in float value;
uniform float vmin, vmax;
uniform vec4 clipPlane;   // (n, d): particles whose centre has dot(n, c) > d are not drawn
uniform float clipOn;
uniform float viewportHeight;  // pixels
#ifdef POINTS
out float vGrow;
#else
out vec3 vView;           // this corner's point in view space
#endif
out vec3 vCenter;         // the sphere's centre in view space
out float vRadius;
out float vT;             // colour-map coordinate
void main() {
  vec4 c = modelViewMatrix * vec4(center, 1.0);
  if ((clipOn > 0.5 && dot(clipPlane.xyz, center) > clipPlane.w) || !(radius > 0.0)) {
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // outside the clip volume: dropped
    return;
  }
  // The square around the sphere's outline in the plane through its centre facing the camera. In perspective the
  // outline's far edge, seen at theta + alpha off the view axis (theta: the centre's angle, sin alpha = r / d), lies
  // r / cos(theta + alpha) from the centre in that plane: d / (sqrt(d^2 - r^2) cos theta - r sin theta) radii.
  // (The viewer's camera is always perspective.)
  float d = length(c.xyz);
  float cosT = clamp(-c.z / d, 0.0, 1.0), sinT = sqrt(1.0 - cosT * cosT);
  float den = sqrt(max(d * d - radius * radius, 0.0)) * cosT - radius * sinT;
  float grow = den > d / 8.0 ? 1.02 * d / den : 8.0;
  vCenter = c.xyz;
  vRadius = radius;
  vT = clamp((value - vmin) / max(vmax - vmin, 1e-30), 0.0, 1.0);
  if (isnan(value)) vT = -1.0;  // NaN (no value, or a fluid's boundary particle): drawn grey
#ifdef POINTS
  vGrow = grow;
  gl_Position = projectionMatrix * c;
  // Pixels across the square: its side in view space times the projection's scale at this depth.
  gl_PointSize = 2.0 * radius * grow * projectionMatrix[1][1] * 0.5 * viewportHeight / -c.z;
#else
  vec3 corner = c.xyz + vec3(position.xy * radius * grow, 0.0);
  vView = corner;
  gl_Position = projectionMatrix * vec4(corner, 1.0);
#endif
}`;

const fragmentShader = /* glsl */ `
uniform sampler2D lut;
uniform mat4 projectionMatrix;
layout(location = 0) out vec4 outColor;
#ifdef POINTS
in float vGrow;
#else
in vec3 vView;
#endif
in vec3 vCenter;
in float vRadius;
in float vT;
void main() {
#ifdef POINTS
  vec3 vView = vCenter + vec3(2.0 * gl_PointCoord.x - 1.0, 1.0 - 2.0 * gl_PointCoord.y, 0.0) * vRadius * vGrow;
#endif
  vec3 rd = normalize(vView);  // the view ray from the eye, at the origin of view space
  vec3 oc = -vCenter;
  float b = dot(oc, rd);
  float c = dot(oc, oc) - vRadius * vRadius;
  float disc = b * b - c;
  if (disc < 0.0) discard;
  float t = -b - sqrt(disc);
  vec3 p = t * rd;
  vec3 n = (p - vCenter) / vRadius;
  vec4 clip = projectionMatrix * vec4(p, 1.0);
  gl_FragDepth = 0.5 * (clip.z / clip.w) + 0.5;
  vec3 base = vT < 0.0 ? vec3(0.5) : texture(lut, vec2(vT, 0.5)).rgb;
  vec3 l = normalize(vec3(0.35, 0.45, 1.0));       // a head light, slightly above and right
  float diffuse = max(dot(n, l), 0.0);
  vec3 h = normalize(l - rd);
  float specular = pow(max(dot(n, h), 0.0), 40.0);
  vec3 color = base * (0.28 + 0.72 * diffuse) + 0.25 * specular;
  outColor = vec4(color, 1.0);
}`;

// sprites: 'quads' (any size on screen; the page) or 'points' (one vertex a particle, 4x less vertex work for a
// software renderer; a point's size is capped by the GPU, so only for pictures where particles stay small).
export class ParticleCloud {
  constructor({ sprites = 'quads' } = {}) {
    this.points = sprites === 'points';
    this.lut = new THREE.DataTexture(new Uint8Array(256 * 4), 256, 1, THREE.RGBAFormat);
    this.lut.magFilter = THREE.LinearFilter;
    this.lut.minFilter = THREE.LinearFilter;
    this.lut.colorSpace = THREE.NoColorSpace;  // the table is used as stored (sRGB), as is the output
    this.material = new THREE.ShaderMaterial({
      glslVersion: THREE.GLSL3,
      vertexShader,
      fragmentShader,
      defines: this.points ? { POINTS: 1 } : {},
      uniforms: {
        vmin: { value: 0 },
        vmax: { value: 1 },
        lut: { value: this.lut },
        clipPlane: { value: new THREE.Vector4(0, 0, 1, 0) },
        clipOn: { value: 0 },
        viewportHeight: { value: 1000 },
      },
    });
    if (this.points) {
      this.geometry = new THREE.BufferGeometry();
      this.mesh = new THREE.Points(this.geometry, this.material);
    } else {
      this.geometry = new THREE.InstancedBufferGeometry();
      this.geometry.setAttribute('position', new THREE.Float32BufferAttribute([-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0], 3));
      this.geometry.setIndex([0, 1, 2, 0, 2, 3]);
      this.mesh = new THREE.Mesh(this.geometry, this.material);
    }
    this.mesh.frustumCulled = false;
    this.count = 0;
  }

  // centers: Float32Array(3n), radii and values: Float32Array(n).
  setData(centers, radii, values) {
    const n = radii.length;
    const g = this.geometry;
    const centerName = this.points ? 'position' : 'center';
    const Attribute = this.points ? THREE.BufferAttribute : THREE.InstancedBufferAttribute;
    if (this.count === n && g.getAttribute('radius')) {
      g.getAttribute(centerName).array.set(centers);
      g.getAttribute('radius').array.set(radii);
      g.getAttribute('value').array.set(values);
      for (const a of [centerName, 'radius', 'value']) g.getAttribute(a).needsUpdate = true;
    } else {
      g.dispose();  // the old buffers' GPU side
      g.setAttribute(centerName, new Attribute(Float32Array.from(centers), 3));
      g.setAttribute('radius', new Attribute(Float32Array.from(radii), 1));
      g.setAttribute('value', new Attribute(Float32Array.from(values), 1));
    }
    if (this.points) g.setDrawRange(0, n);
    else g.instanceCount = n;
    this.count = n;
  }

  setValues(values) {
    const a = this.geometry.getAttribute('value');
    if (!a) return;
    a.array.set(values);
    a.needsUpdate = true;
  }

  setRange(min, max) {
    this.material.uniforms.vmin.value = min;
    this.material.uniforms.vmax.value = max;
  }

  setLookupTable(bytes) {
    this.lut.image.data.set(bytes);
    this.lut.needsUpdate = true;
  }

  // plane: {normal: [x, y, z], offset} or null.
  setClip(plane) {
    const u = this.material.uniforms;
    u.clipOn.value = plane ? 1 : 0;
    if (plane) u.clipPlane.value.set(plane.normal[0], plane.normal[1], plane.normal[2], plane.offset);
  }

  setViewportHeight(pixels) {
    this.material.uniforms.viewportHeight.value = pixels;
  }
}
