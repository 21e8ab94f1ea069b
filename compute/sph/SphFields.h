// THE list of the SPH solver's per-particle fields, in the same form as the DEM table
// (compute/dem/ParticleFields.h): reorder, snapshots, migration and halo exchange iterate over it
// through the shared FieldStore and FieldRows, so adding a field is one line here.
//
// Columns: enum name, output name, element type, SI unit, flags. `Real` and `Real3` are the run's
// precision; positions are double at both.
#pragma once
#include <cstdint>

#include "compute/particles/FieldInfo.h"

namespace pflow::compute::sph {

// clang-format off
#define PFLOW_SPH_FIELDS(X)                                                                                    \
  X(Position,     "position",     Vec3d,        "m",        kSnapshot | kMigrate | kGhost | kRefresh)          \
  X(Velocity,     "velocity",     Real3,        "m/s",      kSnapshot | kMigrate | kGhost | kRefresh)          \
  X(Density,      "density",      Real,         "kg/m^3",   kSnapshot | kMigrate | kGhost | kRefresh)          \
  X(Pressure,     "pressure",     Real,         "Pa",       kSnapshot | kMigrate | kGhost | kRefresh)          \
  X(Mass,         "mass",         Real,         "kg",       kSnapshot | kMigrate | kGhost)                     \
  X(Kind,         "kind",         std::int32_t, "",         kSnapshot | kMigrate | kGhost)                     \
  X(Gid,          "id",           Gid,          "",         kSnapshot | kMigrate | kGhost)                     \
  X(Acceleration, "acceleration", Real3,        "m/s^2",    kMigrate)                                          \
  X(DensityRate,  "density_rate", Real,         "kg/m^3/s", kMigrate)                                          \
  X(ViscousRate,  "viscous_rate", Real,         "1/s",      kCheckpoint)                                       \
  X(Position0,    "position0",    Vec3d,        "m",        kMigrate)                                          \
  X(Velocity0,    "velocity0",    Real3,        "m/s",      kMigrate)                                          \
  X(Density0,     "density0",     Real,         "kg/m^3",   kMigrate)
// clang-format on
// Acceleration and DensityRate migrate: the predictor of the next step starts from them. The state at the start
// of the step (Position0, Velocity0, Density0) migrates too: a rebuild may fall between the predictor and the
// corrector, which reads it. ViscousRate lives within one evaluation, but the next step's dt reads it: a checkpoint
// keeps it (kCheckpoint).

enum class SphField : std::uint8_t {
#define PFLOW_X(id, name, type, unit, flags) id,
  PFLOW_SPH_FIELDS(PFLOW_X)
#undef PFLOW_X
      kCount
};
inline constexpr int kNumSphFields = static_cast<int>(SphField::kCount);

template <SphField F, class R> struct SphFieldType;
#define PFLOW_X(id, name, type_, unit, flags)          \
  template <class R> struct SphFieldType<SphField::id, R> { \
    using Real = R;                                    \
    using Real3 = Vec3<R>;                             \
    using type = type_;                                \
  };
PFLOW_SPH_FIELDS(PFLOW_X)
#undef PFLOW_X

using SphFieldInfo = FieldInfoOf<SphField>;

template <class R>
inline constexpr SphFieldInfo kSphFieldTableOf[kNumSphFields] = {
#define PFLOW_X(id, name, type_, unit, flags)                                                              \
  {SphField::id, name, sizeof(typename SphFieldType<SphField::id, R>::type),                                \
   scalarTypeOf<typename SphFieldType<SphField::id, R>::type>(),                                            \
   int(sizeof(typename SphFieldType<SphField::id, R>::type) /                                               \
       scalarBytesOf(scalarTypeOf<typename SphFieldType<SphField::id, R>::type>())),                        \
   Multiplicity::kOne, unit, flags},
    PFLOW_SPH_FIELDS(PFLOW_X)
#undef PFLOW_X
};
static_assert(wordSized(kSphFieldTableOf<float>) && wordSized(kSphFieldTableOf<double>), "a field of whole 4-byte words");

// The SPH field set, as FieldStore (compute/particles/FieldStore.h) sees it.
struct SphFieldSet {
  using Id = SphField;
  static constexpr int kCount = kNumSphFields;
  template <class R> static constexpr const SphFieldInfo* table() { return kSphFieldTableOf<R>; }
  template <SphField F, class R> using Type = typename SphFieldType<F, R>::type;
  static constexpr unsigned char emptySlotByte(SphField) { return 0; }  // no slot fields
};

}  // namespace pflow::compute::sph
