// Small 3-vector for host and device code (HOOMD VectorMath role).
#pragma once
#include <cmath>

#include "compute/core/Types.h"

namespace pflow {

template <class T>
struct Vec3 {
  T x, y, z;
};
using Vec3d = Vec3<double>;
using Vec3f = Vec3<float>;

template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3<T> operator+(Vec3<T> a, Vec3<T> b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3<T> operator-(Vec3<T> a, Vec3<T> b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3<T> operator-(Vec3<T> a) { return {-a.x, -a.y, -a.z}; }
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3<T> operator*(T s, Vec3<T> a) { return {s * a.x, s * a.y, s * a.z}; }
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3<T> operator*(Vec3<T> a, T s) { return {s * a.x, s * a.y, s * a.z}; }
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3<T>& operator+=(Vec3<T>& a, Vec3<T> b) { a.x += b.x; a.y += b.y; a.z += b.z; return a; }
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3<T>& operator-=(Vec3<T>& a, Vec3<T> b) { a.x -= b.x; a.y -= b.y; a.z -= b.z; return a; }
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE T dot(Vec3<T> a, Vec3<T> b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3<T> cross(Vec3<T> a, Vec3<T> b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE T norm2(Vec3<T> a) { return dot(a, a); }
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE T norm(Vec3<T> a) { return std::sqrt(dot(a, a)); }
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE bool isFinite(Vec3<T> a) {
  return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
}
template <class T> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3<T> zero3() { return {T(0), T(0), T(0)}; }
// Converts between precisions (float runs keep positions in double, everything else in float).
template <class T, class U> PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3<T> vcast(Vec3<U> a) { return {T(a.x), T(a.y), T(a.z)}; }

// Rotates v about the unit axis k by angle a (Rodrigues).
template <class T>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Vec3<T> rotateAbout(Vec3<T> v, Vec3<T> k, T a) {
  const T c = std::cos(a), s = std::sin(a);
  return c * v + s * cross(k, v) + ((T(1) - c) * dot(k, v)) * k;
}

}  // namespace pflow
