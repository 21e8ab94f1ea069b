// Closest point on a triangle, with the feature (face, edge or vertex) it lies on.
#pragma once
#include "compute/core/VectorMath.h"

namespace pflow::compute::geometry {

enum class Feature : unsigned char { kFace, kEdgeAB, kEdgeBC, kEdgeCA, kVertexA, kVertexB, kVertexC };

template <class T>
struct ClosestPoint {
  Vec3<T> point;
  Feature feature;
};

// Region tests on barycentric coordinates (Voronoi regions of the vertices, then edges, then face).
template <class T>
PFLOW_HOSTDEVICE inline ClosestPoint<T> closestPointOnTriangle(Vec3<T> p, Vec3<T> a, Vec3<T> b, Vec3<T> c) {
  const Vec3<T> ab = b - a, ac = c - a, ap = p - a;
  const T d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= T(0) && d2 <= T(0)) return {a, Feature::kVertexA};
  const Vec3<T> bp = p - b;
  const T d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= T(0) && d4 <= d3) return {b, Feature::kVertexB};
  const T vc = d1 * d4 - d3 * d2;
  if (vc <= T(0) && d1 >= T(0) && d3 <= T(0)) {
    const T v = d1 / (d1 - d3);
    return {a + v * ab, Feature::kEdgeAB};
  }
  const Vec3<T> cp = p - c;
  const T d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= T(0) && d5 <= d6) return {c, Feature::kVertexC};
  const T vb = d5 * d2 - d1 * d6;
  if (vb <= T(0) && d2 >= T(0) && d6 <= T(0)) {
    const T w = d2 / (d2 - d6);
    return {a + w * ac, Feature::kEdgeCA};
  }
  const T va = d3 * d6 - d5 * d4;
  if (va <= T(0) && (d4 - d3) >= T(0) && (d5 - d6) >= T(0)) {
    const T w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {b + w * (c - b), Feature::kEdgeBC};
  }
  const T denom = T(1) / (va + vb + vc);
  const T v = vb * denom, w = vc * denom;
  return {a + v * ab + w * ac, Feature::kFace};
}

// Unit normal by the right-hand rule (b - a) x (c - a).
template <class T>
PFLOW_HOSTDEVICE inline Vec3<T> triangleNormal(Vec3<T> a, Vec3<T> b, Vec3<T> c) {
  const Vec3<T> nn = cross(b - a, c - a);
  return (T(1) / norm(nn)) * nn;
}

}  // namespace pflow::compute::geometry
