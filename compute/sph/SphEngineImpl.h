// The SPH engine over any executor and precision: the phases as launches of the kernels in SphKernels.h.
// Instantiated for the OpenMP executor in SphCpuEngine.cc and for CUDA in SphCudaEngine.cu, each in float
// and double (positions are double in both). What it shares with the DEM engine: the executor, the field
// store and its row operations (compute/particles), the cell hash and counting sort (compute/neighbor).
#pragma once
#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include "compute/neighbor/NeighborKernels.h"
#include "compute/particles/FieldRows.h"
#include "compute/particles/FieldStore.h"
#include "compute/sph/SphEngine.h"
#include "compute/sph/SphFields.h"
#include "compute/sph/SphKernels.h"

namespace pflow::compute::sph {

template <class Exec, class R>
class SphEngineImpl final : public SphEngine {
 public:
  using Store = FieldStore<SphFieldSet, R>;
  using V = Vec3<R>;

  explicit SphEngineImpl(SphSetup s)
      : m_exec(s.threads), m_mem(m_exec.memory()), m_fields(m_mem), m_rows(m_exec, m_mem, m_fields), m_setup(std::move(s)) {
    init();
  }

  std::string executorDescription() const override { return m_exec.description(); }
  const char* precisionName() const override { return sizeof(R) == 4 ? "float" : "double"; }
  std::size_t size() const override { return m_n; }
  std::size_t deviceBytes() const override { return m_mem.bytesInUse(); }
  void fence() const override { m_exec.synchronize(); }

  void sortByCell() override {
    const CellGrid& g = m_setup.grid;
    m_exec.forEach(m_n, compute::kernels::CellKey{g, ptr<SphField::Position>(), m_cellKey.as<std::uint32_t>()});
    m_exec.sortByKey(m_cellKey.as<std::uint32_t>(), m_n, g.numCells(), m_perm.as<Index>(), m_cellStart.as<Index>());
    m_rows.reorder(m_perm.as<Index>(), m_n);
    m_mem.copyWithin(m_ref.data(), ptr<SphField::Position>(), std::size_t(m_n) * sizeof(Vec3d));
  }

  void computeRates() override {
    kernels::Interact<R> k{m_setup.grid, m_cellStart.as<Index>(), ptr<SphField::Position>(), ptr<SphField::Velocity>(),
                           ptr<SphField::Density>(), ptr<SphField::Pressure>(), ptr<SphField::Mass>(), ptr<SphField::Kind>(),
                           m_kernel, m_pair, vcast<R>(m_setup.gravity), ptr<SphField::Acceleration>(),
                           ptr<SphField::DensityRate>(), ptr<SphField::ViscousRate>()};
    m_exec.forEach(m_n, k);
  }

  double maxAcceleration() const override {
    return std::sqrt(m_exec.maxOf(m_n, kernels::AccelerationSquared<R>{cptr<SphField::Acceleration>(), cptr<SphField::Kind>()}));
  }
  double maxViscousRate() const override { return m_exec.maxOf(m_n, kernels::MaxOfField<R>{cptr<SphField::ViscousRate>()}); }

  double predictor(double dt) override { return m_exec.maxOf(m_n, kernels::Predictor<R>{stepArgs(dt)}); }

  Status corrector(double dt, double& moved2) override {
    m_exec.forEach(1, compute::kernels::ResetConditions{m_cond.as<Conditions>()});
    moved2 = m_exec.maxOf(m_n, kernels::Corrector<R>{stepArgs(dt)});
    Conditions c;
    m_mem.copyToHost(&c, m_cond.data(), sizeof c);
    if (c.flags & kNonFinite) return failure("non-finite", c.badParticle, "has a non-finite position, velocity or density");
    if (c.flags & kDensityOutOfRange)
      return failure("density out of range", c.densityParticle,
                     "left the density bounds [" + std::to_string(m_setup.minDensity) + ", " + std::to_string(m_setup.maxDensity) +
                         "] kg/m^3 (sph.density_bounds)");
    if (c.flags & kLeftDomain)
      return failure("leak", c.outsideParticle,
                     "is outside the tank's walls below their top: it passed through a wall (dt too large, or too few "
                     "wall layers), or spilled over an open top (the tank is too low for this flow)");
    return Status::ok();
  }

  double fluidEnergy() const override {
    return m_exec.sumOf(m_n, kernels::FluidEnergy<R>{cptr<SphField::Position>(), cptr<SphField::Velocity>(), cptr<SphField::Mass>(),
                                                     cptr<SphField::Kind>(), m_setup.gravity});
  }

  double fluidReach(Vec3d direction) const override {
    // Measured from the grid's far corner against `direction`, so every value is >= 0 (maxOf's floor).
    const CellGrid& g = m_setup.grid;
    const Vec3d hi = g.lo + g.cellSize * Vec3d{double(g.nx), double(g.ny), double(g.nz)};
    const Vec3d base{direction.x >= 0 ? g.lo.x : hi.x, direction.y >= 0 ? g.lo.y : hi.y, direction.z >= 0 ? g.lo.z : hi.z};
    if (m_n == 0) return 0;
    return m_exec.maxOf(m_n, kernels::FluidReach{cptr<SphField::Position>(), cptr<SphField::Kind>(), direction, base}) + dot(base, direction);
  }

  void sample(const std::vector<Vec3d>& points, std::vector<double>& fraction, std::vector<double>& pressure) const override {
    const std::size_t n = points.size();
    fraction.assign(n, 0.0);
    pressure.assign(n, 0.0);
    if (!n) return;
    if (m_samples.bytes() < n * (sizeof(Vec3d) + 2 * sizeof(double))) m_samples.resize(n * (sizeof(Vec3d) + 2 * sizeof(double)));
    auto* pts = m_samples.as<Vec3d>();
    auto* frac = reinterpret_cast<double*>(pts + n);
    double* pres = frac + n;
    m_mem.copyFromHost(pts, points.data(), n * sizeof(Vec3d));
    m_exec.forEach(Index(n), kernels::SampleAt<R>{m_setup.grid, m_cellStart.as<Index>(), cptr<SphField::Position>(),
                                                  cptr<SphField::Density>(), cptr<SphField::Pressure>(), cptr<SphField::Mass>(),
                                                  cptr<SphField::Kind>(), m_kernel, pts, frac, pres});
    m_mem.copyToHost(fraction.data(), frac, n * sizeof(double));
    m_mem.copyToHost(pressure.data(), pres, n * sizeof(double));
  }

  ParticleSnapshot snapshot(std::int64_t step, double time, const std::vector<std::string>& fields) const override {
    return m_rows.snapshot(step, time, m_n, fields);
  }

  SphProbeState probe(Index i) const override {
    SphProbeState s;
    if (i >= m_n) return s;
    V v;
    R rho, p;
    std::int32_t kind;
    m_mem.copyToHost(&s.gid, cptr<SphField::Gid>() + i, sizeof s.gid);
    m_mem.copyToHost(&s.position, cptr<SphField::Position>() + i, sizeof s.position);
    m_mem.copyToHost(&v, cptr<SphField::Velocity>() + i, sizeof v);
    m_mem.copyToHost(&rho, cptr<SphField::Density>() + i, sizeof rho);
    m_mem.copyToHost(&p, cptr<SphField::Pressure>() + i, sizeof p);
    m_mem.copyToHost(&kind, cptr<SphField::Kind>() + i, sizeof kind);
    s.velocity = vcast<double>(v);
    s.density = double(rho);
    s.pressure = double(p);
    s.fluid = kind == kernels::kFluid;
    return s;
  }

 private:
  template <SphField F> typename Store::template Type<F>* ptr() { return m_fields.template ptr<F>(); }
  template <SphField F> const typename Store::template Type<F>* cptr() const { return m_fields.template ptr<F>(); }

  void init() {
    const SphSetup& s = m_setup;
    m_n = Index(s.position.size());
    m_fields.allocate(m_n, 0, 0, false);
    auto put = [&]<SphField F, class T>(std::integral_constant<SphField, F>, const std::vector<T>& src) {
      using Dst = typename Store::template Type<F>;
      std::vector<Dst> v(m_n);
      for (Index i = 0; i < m_n; ++i) {
        if (src.empty()) std::memset(static_cast<void*>(&v[i]), 0, sizeof(Dst));
        else if constexpr (std::is_same_v<T, Vec3d> && !std::is_same_v<Dst, Vec3d>) v[i] = vcast<R>(src[i]);
        else v[i] = Dst(src[i]);
      }
      m_mem.copyFromHost(m_fields.buffer(F).data(), v.data(), v.size() * sizeof(Dst));
    };
    std::vector<Gid> gids(m_n);
    for (Index i = 0; i < m_n; ++i) gids[i] = s.gid.empty() ? Gid(i) : s.gid[i];
    const std::vector<Vec3d> none3;
    const std::vector<double> none;
    put(std::integral_constant<SphField, SphField::Position>{}, s.position);
    put(std::integral_constant<SphField, SphField::Velocity>{}, s.velocity);
    put(std::integral_constant<SphField, SphField::Density>{}, s.density);
    put(std::integral_constant<SphField, SphField::Mass>{}, s.mass);
    put(std::integral_constant<SphField, SphField::Kind>{}, s.kind);
    put(std::integral_constant<SphField, SphField::Gid>{}, gids);
    put(std::integral_constant<SphField, SphField::Acceleration>{}, none3);
    put(std::integral_constant<SphField, SphField::DensityRate>{}, none);
    put(std::integral_constant<SphField, SphField::ViscousRate>{}, none);
    put(std::integral_constant<SphField, SphField::Position0>{}, s.position);
    put(std::integral_constant<SphField, SphField::Velocity0>{}, s.velocity);
    put(std::integral_constant<SphField, SphField::Density0>{}, s.density);

    m_kernel = Kernel<R>::make(s.kernel, s.dimension, s.h);
    m_eos = Tait<R>::make(s.rho0, s.c0, s.gamma);
    m_pair.alpha = R(s.alpha);
    m_pair.nu = R(s.nu);
    m_pair.delta = R(s.delta);
    m_pair.eta2 = R(0.01 * s.h * s.h);
    m_pair.h = R(s.h);
    m_pair.c0 = R(s.c0);
    m_pair.hydrostatic = s.hydrostaticDiffusion;
    m_pair.gOverC2 = vcast<R>((1.0 / (s.c0 * s.c0)) * s.gravity);
    m_pair.rho0 = R(s.rho0);
    m_exec.forEach(m_n, kernels::EquationOfState<R>{ptr<SphField::Density>(), ptr<SphField::Pressure>(), m_eos});

    const std::size_t n = std::max<std::size_t>(1, m_n);
    m_cellKey.resize(n * sizeof(std::uint32_t));
    m_perm.resize(n * sizeof(Index));
    m_ref.resize(n * sizeof(Vec3d));
    m_cellStart.resize((std::size_t(s.grid.numCells()) + 1) * sizeof(Index));
  }

  kernels::StepArgs<R> stepArgs(double dt) {
    kernels::StepArgs<R> a{ptr<SphField::Position>(), ptr<SphField::Velocity>(), ptr<SphField::Density>(), ptr<SphField::Pressure>(),
                           ptr<SphField::Acceleration>(), ptr<SphField::DensityRate>(), ptr<SphField::Kind>(),
                           ptr<SphField::Position0>(), ptr<SphField::Velocity0>(), ptr<SphField::Density0>(), m_ref.as<Vec3d>(),
                           m_eos, dt, R(m_setup.rho0), R(m_setup.minDensity), R(m_setup.maxDensity)};
    a.checkBox = m_setup.checkBox;
    a.boxLo = m_setup.boxLo;
    a.boxHi = m_setup.boxHi;
    a.cond = m_cond.as<Conditions>();
    return a;
  }

  // "<what>: fluid particle G at (x, y, z) m, speed v m/s, density rho kg/m^3 <why>" (the step and time are
  // added by the simulation).
  Status failure(const char* what, Index i, const std::string& why) const {
    const SphProbeState p = probe(i);
    char buf[384];
    std::snprintf(buf, sizeof buf, "%s: %s particle %llu at (%.6g, %.6g, %.6g) m, speed %.4g m/s, density %.6g kg/m^3, ", what,
                  p.fluid ? "fluid" : "boundary", (unsigned long long)p.gid, p.position.x, p.position.y, p.position.z,
                  norm(p.velocity), p.density);
    return Status(StatusCode::kNumerical, buf + why);
  }

  Exec m_exec;
  MemorySpace& m_mem;
  Store m_fields;
  FieldRows<Exec, Store> m_rows;  // reorder and snapshots: driven by the SPH field table
  SphSetup m_setup;
  Index m_n = 0;
  Kernel<R> m_kernel;
  Tait<R> m_eos;
  PairParams<R> m_pair;
  Buffer m_cellKey{m_mem, 0}, m_perm{m_mem, 0}, m_cellStart{m_mem, 0}, m_ref{m_mem, 0};
  Buffer m_cond{m_mem, sizeof(Conditions)};
  mutable Buffer m_samples{m_mem, 0};  // sample(): points, then fractions and pressures
};

}  // namespace pflow::compute::sph
