// EngineImpl's error path and diagnostics, from host copies made when they are needed (never on the step path):
// the detectors' messages (non-finite, excessive overlap, tunnelling, leaving the domain, slot overflow) with the
// particle and wall they name, the start's elastic energy, the fastest particle, contact statistics.
// Included at the end of EngineImpl.h: these are its member templates.
#pragma once

#include "compute/dem/EngineImpl.h"

namespace pflow::compute {

template <class Exec, class R>
typename EngineImpl<Exec, R>::HostView EngineImpl<Exec, R>::hostView() const {
  HostView h;
  h.pos.resize(m_n);
  h.rad.resize(m_n);
  h.mass.resize(m_n);
  h.mat.resize(m_n);
  h.gid.resize(m_n);
  m_mem.copyToHost(h.pos.data(), m_particles.template ptr<Field::Position>(), m_n * sizeof(Vec3d));
  m_mem.copyToHost(h.rad.data(), m_particles.template ptr<Field::Radius>(), m_n * sizeof(R));
  m_mem.copyToHost(h.mass.data(), m_particles.template ptr<Field::Mass>(), m_n * sizeof(R));
  m_mem.copyToHost(h.mat.data(), m_particles.template ptr<Field::Material>(), m_n * sizeof(std::int32_t));
  m_mem.copyToHost(h.gid.data(), m_particles.template ptr<Field::Gid>(), m_n * sizeof(Gid));
  h.rows = hostRows();
  // Without wall phases (ModelFlags::walls) the candidate rows are never written: no candidates.
  hostWallCandidates(h.wallCand, h.wallCandStart);
  h.triVerts.resize(3 * std::size_t(m_numTri));
  m_mem.copyToHost(h.triVerts.data(), m_triVerts.data(), h.triVerts.size() * sizeof(Vec3d));
  return h;
}

template <class Exec, class R>
typename EngineImpl<Exec, R>::Deepest EngineImpl<Exec, R>::deepestContact(const HostView& h, Index i) const {
  Deepest best;
  const double ri = double(h.rad[i]);
  for (std::uint32_t e = 0; e < h.rows.count[i]; ++e) {
    const Index j = h.rows.at(i, e);
    const double ov = ri + double(h.rad[j]) - norm(h.pos[j] - h.pos[i]);
    if (ov > best.overlap) {
      best = {"particle " + std::to_string(h.gid[j]), h.gid[j], ov, ov / std::min(ri, double(h.rad[j]))};
    }
  }
  for (std::size_t p = 0; p < m_setup.planes.size(); ++p) {
    const double ov = ri - dot(h.pos[i] - m_setup.planes[p].point, m_setup.planes[p].normal);
    if (ov > best.overlap) best = {"plane '" + m_setup.planeNames[p] + "'", kNoGid, ov, ov / ri};
  }
  for (std::uint32_t e = h.wallCandStart[i]; e < h.wallCandStart[i + 1]; ++e) {
    const Index t = h.wallCand[e];
    const auto cp = geometry::closestPointOnTriangle(h.pos[i], h.triVerts[3 * t], h.triVerts[3 * t + 1], h.triVerts[3 * t + 2]);
    const double ov = ri - norm(cp.point - h.pos[i]);
    if (ov > best.overlap)
      best = {"mesh '" + m_setup.meshNames[std::size_t(m_setup.triMesh[t])] + "' (triangle " + std::to_string(t) + ")", kNoGid, ov, ov / ri};
  }
  return best;
}

template <class Exec, class R>
ParticleProbe EngineImpl<Exec, R>::probe(Index i) const {
  ParticleProbe p;
  if (i >= m_owned) return p;
  R r, m;
  V v;
  std::int32_t mat;
  m_mem.copyToHost(&p.gid, m_particles.template ptr<Field::Gid>() + i, sizeof p.gid);
  m_mem.copyToHost(&r, m_particles.template ptr<Field::Radius>() + i, sizeof r);
  m_mem.copyToHost(&m, m_particles.template ptr<Field::Mass>() + i, sizeof m);
  m_mem.copyToHost(&mat, m_particles.template ptr<Field::Material>() + i, sizeof mat);
  m_mem.copyToHost(&p.position, m_particles.template ptr<Field::Position>() + i, sizeof p.position);
  m_mem.copyToHost(&v, m_particles.template ptr<Field::Velocity>() + i, sizeof v);
  p.velocity = vcast<double>(v);
  p.radius = double(r);
  p.speed = norm(p.velocity);
  // Hertz contact time of an impact on its own kind: R* = r/2, m* = m/2 (physics-reference.md).
  const double effYoung = m_setup.contactTable[std::size_t(mat) * m_setup.numMaterials + std::size_t(mat)].effYoung;
  if (p.speed > 0 && std::isfinite(p.speed) && effYoung > 0) {
    p.contactTime = hertzContactTime(0.5 * double(r), 0.5 * double(m), effYoung, p.speed);
  }
  return p;
}

template <class Exec, class R>
Status EngineImpl<Exec, R>::nonFiniteError(Index i, double dt) const {
  const ParticleSnapshot s = snapshot(0, 0, {});
  auto vec = [&](const char* name) {
    const Vec3d v = s.find(name)->template as<Vec3d>()[i];
    return std::string(name) + " (" + std::to_string(v.x) + ", " + std::to_string(v.y) + ", " + std::to_string(v.z) + ")";
  };
  V f, t;
  m_mem.copyToHost(&f, m_particles.template ptr<Field::Force>() + i, sizeof f);
  m_mem.copyToHost(&t, m_particles.template ptr<Field::Torque>() + i, sizeof t);
  const Gid gid = s.find("id")->template as<Gid>()[i];
  std::string what;
  for (const char* name : {"position", "velocity", "angular_velocity"})
    if (!isFinite(s.find(name)->template as<Vec3d>()[i])) what += (what.empty() ? "" : ", ") + vec(name);
  if (!isFinite(f)) what += std::string(what.empty() ? "" : ", ") + "force";
  if (!isFinite(t)) what += std::string(what.empty() ? "" : ", ") + "torque";
  // Its speed is meaningless now: the suggestion is half the step.
  return numericalError("non-finite: particle " + std::to_string(gid) + " has a non-finite " + what +
                        ": the integration has blown up (time step too large, or the material too soft)" + suggestion(dt, {}));
}

template <class Exec, class R>
Status EngineImpl<Exec, R>::deepOverlapError(Index i, double dt) const {
  const ParticleProbe p = probe(i);
  const Deepest d = deepestContact(hostView(), i);
  char buf[768];
  std::snprintf(buf, sizeof buf,
                "excessive overlap: %s and %s overlap by %.4g m, %.1f%% of the smaller radius (simulation.max_overlap: %.1f%%): "
                "the contact is not resolved (time step too large for these speeds, or the material too soft)",
                describeParticle(p).c_str(), d.partner.c_str(), d.overlap, 100 * d.ratio, 100 * m_setup.maxOverlap);
  return numericalError(buf + suggestion(dt, p));
}

template <class Exec, class R>
Status EngineImpl<Exec, R>::tunnelError(Index i, double dt) const {
  const ParticleProbe p = probe(i);
  std::string wall;
  for (std::size_t k = 0; k < m_setup.planes.size() && wall.empty(); ++k) {
    const double sd = dot(p.position - m_setup.planes[k].point, m_setup.planes[k].normal);
    if (sd < 0) {
      char buf[256];
      std::snprintf(buf, sizeof buf, "plane '%s' (its centre is %.4g m behind it)", m_setup.planeNames[k].c_str(), -sd);
      wall = buf;
    }
  }
  if (wall.empty()) {
    // A triangle's face: the mesh of the candidate triangle nearest the centre.
    const HostView h = hostView();
    double nearest = 1e300;
    for (std::uint32_t e = h.wallCandStart[i]; e < h.wallCandStart[i + 1]; ++e) {
      const Index t = h.wallCand[e];
      const auto cp = geometry::closestPointOnTriangle(p.position, h.triVerts[3 * t], h.triVerts[3 * t + 1], h.triVerts[3 * t + 2]);
      const double d = norm(cp.point - p.position);
      if (d < nearest) {
        nearest = d;
        wall = "a face of mesh '" + m_setup.meshNames[std::size_t(m_setup.triMesh[t])] + "' (triangle " + std::to_string(t) + ")";
      }
    }
    if (wall.empty()) wall = "a wall";
  }
  return numericalError("tunnelling: " + describeParticle(p) + " passed through " + wall +
                        " within one step: the step carries it further than a contact can stop it (time step too large "
                        "for this speed)" + suggestion(dt, p));
}

template <class Exec, class R>
Status EngineImpl<Exec, R>::leftDomainError(Index i, double dt) const {
  const ParticleProbe p = probe(i);
  const Vec3d lo = m_setup.domainLo, hi = m_setup.domainHi;
  char buf[256];
  std::snprintf(buf, sizeof buf, " is outside simulation.domain (min (%.6g, %.6g, %.6g), max (%.6g, %.6g, %.6g) m)", lo.x, lo.y,
                lo.z, hi.x, hi.y, hi.z);
  return numericalError("left the domain: " + describeParticle(p) + buf +
                        ": a wall is missing or was passed through, or the time step is too large" + suggestion(dt, p));
}

template <class Exec, class R>
Status EngineImpl<Exec, R>::slotOverflowError(double dt) const {
  // The particle with the most contacts now (host copies: the error path).
  const HostView h = hostView();
  Index worst = 0;
  std::uint32_t most = 0;
  for (Index i = 0; i < m_owned; ++i) {
    std::uint32_t contacts = 0;
    for (std::uint32_t e = 0; e < h.rows.count[i]; ++e) {
      const Index j = h.rows.at(i, e);
      contacts += norm(h.pos[j] - h.pos[i]) < double(h.rad[i]) + double(h.rad[j]);
    }
    if (contacts > most) {
      most = contacts;
      worst = i;
    }
  }
  const ParticleProbe p = probe(worst);
  return numericalError("contact-slot overflow: " + describeParticle(p) + " has " + std::to_string(most) +
                        " simultaneous contacts, above simulation.max_contacts (" + std::to_string(m_setup.maxContacts) +
                        "): the packing has collapsed (time step too large, or the material too soft)" + suggestion(dt, p));
}

template <class Exec, class R>
double EngineImpl<Exec, R>::elasticEnergy() const {
  const HostView h = hostView();
  const int nm = m_setup.numMaterials;
  // Hertz's energy, or with adhesion the work done on the contact since it formed (contactEnergy); a JKR contact
  // held past zero overlap is left out (its energy, positive, is what breaking it will dissipate).
  auto table = [&](int a, int b) -> const ContactParams& { return m_setup.contactTable[std::size_t(a) * nm + std::size_t(b)]; };
  const auto hertz = [](const ContactParams& p, double effRadius, double ov) { return contactEnergy(p, effRadius, ov); };
  double u = 0;
  for (Index i = 0; i < m_owned; ++i) {
    const double ri = double(h.rad[i]);
    for (std::uint32_t e = 0; e < h.rows.count[i]; ++e) {
      const Index j = h.rows.at(i, e);
      const double rj = double(h.rad[j]), ov = ri + rj - norm(h.pos[j] - h.pos[i]);
      if (ov > 0) u += 0.5 * hertz(table(h.mat[i], h.mat[j]), ri * rj / (ri + rj), ov);  // half: j counts the other
    }
    for (const auto& pl : m_setup.planes) {
      const double ov = ri - dot(h.pos[i] - pl.point, pl.normal);
      if (ov > 0) u += hertz(table(h.mat[i], pl.material), ri, ov);
    }
    // Triangles: every face contact (each is a genuine contact; the rims of neighbouring triangles in the
    // same plane are edge contacts the force kernel drops), or the deepest edge or vertex contact when
    // there is no face contact (an approximation: the start's elastic energy only widens the allowance).
    double edge = 0;
    int edgeMaterial = 0;
    bool face = false;
    for (std::uint32_t e = h.wallCandStart[i]; e < h.wallCandStart[i + 1]; ++e) {
      const Index t = h.wallCand[e];
      const auto cp = geometry::closestPointOnTriangle(h.pos[i], h.triVerts[3 * t], h.triVerts[3 * t + 1], h.triVerts[3 * t + 2]);
      const double ov = ri - norm(cp.point - h.pos[i]);
      if (ov <= 0) continue;
      if (cp.feature == geometry::Feature::kFace) {
        face = true;
        u += hertz(table(h.mat[i], m_setup.triMaterial[t]), ri, ov);
      } else if (ov > edge) {
        edge = ov;
        edgeMaterial = m_setup.triMaterial[t];
      }
    }
    if (!face && edge > 0) u += hertz(table(h.mat[i], edgeMaterial), ri, edge);
  }
  return u;
}

template <class Exec, class R>
ParticleProbe EngineImpl<Exec, R>::fastestParticle() const {
  if (m_owned == 0) return {};
  std::vector<V> vel(m_owned), om(m_owned);
  std::vector<R> rad(m_owned), mass(m_owned);
  m_mem.copyToHost(vel.data(), m_particles.template ptr<Field::Velocity>(), m_owned * sizeof(V));
  m_mem.copyToHost(om.data(), m_particles.template ptr<Field::AngularVelocity>(), m_owned * sizeof(V));
  m_mem.copyToHost(rad.data(), m_particles.template ptr<Field::Radius>(), m_owned * sizeof(R));
  m_mem.copyToHost(mass.data(), m_particles.template ptr<Field::Mass>(), m_owned * sizeof(R));
  Index best = 0;
  double most = -1;
  for (Index i = 0; i < m_owned; ++i) {
    const kernels::KineticEnergy<R> ke{vel.data(), om.data(), mass.data(), rad.data()};
    const double k = ke(i);
    if (k > most || !std::isfinite(k)) {
      most = k;
      best = i;
      if (!std::isfinite(k)) break;
    }
  }
  return probe(best);
}

template <class Exec, class R>
ContactStats EngineImpl<Exec, R>::contactStats() const {
  // Diagnostics only (not on the step path): computed from host copies.
  // Owned particles [0, n); their candidates may be ghosts [n, m_n). A pair across ranks is counted by
  // both ranks count a pair that spans two: these statistics are per rank.
  const Index n = m_owned;
  std::vector<Vec3d> pos(m_n);
  std::vector<V> vel(m_n), om(m_n);
  std::vector<R> rad(m_n), mass(m_n);
  const HostRows rows = hostRows();
  m_mem.copyToHost(pos.data(), m_particles.template ptr<Field::Position>(), m_n * sizeof(Vec3d));
  m_mem.copyToHost(vel.data(), m_particles.template ptr<Field::Velocity>(), m_n * sizeof(V));
  m_mem.copyToHost(om.data(), m_particles.template ptr<Field::AngularVelocity>(), m_n * sizeof(V));
  m_mem.copyToHost(rad.data(), m_particles.template ptr<Field::Radius>(), m_n * sizeof(R));
  m_mem.copyToHost(mass.data(), m_particles.template ptr<Field::Mass>(), m_n * sizeof(R));
  // Mesh walls: each particle's candidate triangles (as of the last rebuild) and the triangles' vertices now.
  std::vector<Index> wallCand;
  std::vector<std::uint32_t> wallStart;
  std::vector<Vec3d> triVerts;
  hostWallCandidates(wallCand, wallStart);
  if (m_anyWalls && m_numTri > 0) {
    triVerts.resize(3 * std::size_t(m_numTri));
    m_mem.copyToHost(triVerts.data(), m_triVerts.data(), triVerts.size() * sizeof(Vec3d));
  }
  ContactStats st;
  for (Index i = 0; i < n; ++i) st.candidatesPerParticle += double(rows.count[i]) / std::max<Index>(n, 1);
  for (Index i = 0; i < n; ++i) {
    st.translationalEnergy += 0.5 * mass[i] * norm2(vel[i]);
    st.kineticEnergy += 0.5 * mass[i] * norm2(vel[i]) + 0.5 * 0.4 * mass[i] * rad[i] * rad[i] * norm2(om[i]);
    st.maxSpeed = std::max(st.maxSpeed, double(norm(vel[i])));
    for (std::uint32_t e = 0; e < rows.count[i]; ++e) {
      const Index j = rows.at(i, e);
      if (j < i) continue;
      const double ov = double(rad[i]) + double(rad[j]) - norm(pos[j] - pos[i]);
      if (ov <= 0) continue;
      ++st.particleContacts;
      st.maxOverlapRatio = std::max(st.maxOverlapRatio, ov / double(std::min(rad[i], rad[j])));
    }
    for (const auto& p : m_setup.planes) {
      const double ov = double(rad[i]) - dot(pos[i] - p.point, p.normal);
      if (ov <= 0) continue;
      ++st.wallContacts;
      st.maxOverlapRatio = std::max(st.maxOverlapRatio, ov / rad[i]);
    }
    for (std::uint32_t e = wallStart[i]; e < wallStart[i + 1]; ++e) {  // mesh triangles
      const Index t = wallCand[e];
      const auto cp = geometry::closestPointOnTriangle(pos[i], triVerts[3 * t], triVerts[3 * t + 1], triVerts[3 * t + 2]);
      const double ov = double(rad[i]) - norm(cp.point - pos[i]);
      if (ov <= 0) continue;
      ++st.wallContacts;
      st.maxOverlapRatio = std::max(st.maxOverlapRatio, ov / rad[i]);
    }
  }
  st.coordinationNumber = n ? 2.0 * double(st.particleContacts) / n : 0.0;
  auto occupied = [&]<class T>(Field f, T empty, std::size_t weight) {
    std::vector<T> keys(m_particles.buffer(f).bytes() / sizeof(T));
    m_mem.copyToHost(keys.data(), m_particles.buffer(f).data(), keys.size() * sizeof(T));
    const FieldInfo& info = kFieldTableOf<R>[int(f)];
    const SlotLayout layout = m_particles.layout(info.multiplicity);
    for (Index i = 0; i < n; ++i)  // owned particles only (ghost and spare rows hold nothing)
      for (std::size_t k = 0; k < m_particles.valuesPerParticle(info); ++k)
        st.historyEntries += weight * (keys[std::size_t(i) * layout.row + k * layout.col] != empty);
  };
  occupied(Field::HistoryPartner, kNoPartner, m_numSlabs || halfPairs() ? 2 : 1);  // pairs once: the owner's stands for both
  occupied(Field::WallKey, kNoGid, 1);
  st.historyEntries += (halfPairs() ? 2 : 1) * m_pool.entries().size();  // beyond the inline slots (HistoryPool.h)
  return st;
}

template <class Exec, class R>
typename EngineImpl<Exec, R>::HostRows EngineImpl<Exec, R>::bothWays(const HostRows& upper) const {
  HostRows h;
  h.count = upper.count;
  for (Index i = 0; i < m_owned; ++i)
    for (std::uint32_t e = 0; e < upper.count[i]; ++e) ++h.count[upper.at(i, e)];
  h.start.assign(std::size_t(m_owned) + 1, 0);
  for (Index i = 0; i < m_owned; ++i) h.start[i + 1] = h.start[i] + h.count[i];
  h.nbr.resize(h.start[m_owned]);
  std::vector<std::uint32_t> next(h.start.begin(), h.start.end() - 1);
  for (Index i = 0; i < m_owned; ++i)
    for (std::uint32_t e = 0; e < upper.count[i]; ++e) {
      const Index j = upper.at(i, e);
      h.nbr[next[i]++] = j;
      h.nbr[next[j]++] = i;
    }
  return h;
}

}  // namespace pflow::compute
