// THE list of per-particle fields. Reorder, snapshots, and (later) migration and halo exchange
// iterate over this table, so adding a field is one line here.
//
// Columns: enum name, output name, element type, multiplicity (one value, one per contact slot, or
// one per wall slot), SI unit, flags. `Real` and `Real3` are the run's precision (float or double,
// `simulation.precision`); positions are double in both (ARCHITECTURE.md, "Precision").
#pragma once
#include <cstdint>

#include "compute/core/VectorMath.h"
#include "compute/particles/ParticleSnapshot.h"

namespace pflow::compute {

enum FieldFlags : std::uint32_t {
  kSnapshot = 1u << 0,  // written to snapshot files
  kMigrate = 1u << 1,   // travels with a particle that changes rank
  kGhost = 1u << 2,     // what a ghost (a copy in a neighbouring rank's halo) holds, sent at each rebuild
  kRefresh = 1u << 3,   // refreshed in the ghosts every step between rebuilds
};

enum class Multiplicity : std::uint8_t { kOne, kContactSlots, kWallSlots };

// clang-format off
#define PFLOW_PARTICLE_FIELDS(X)                                                                                       \
  X(Position,        "position",           Vec3d,         kOne,          "m",     kSnapshot | kMigrate | kGhost | kRefresh) \
  X(Velocity,        "velocity",           Real3,         kOne,          "m/s",   kSnapshot | kMigrate | kGhost | kRefresh) \
  X(AngularVelocity, "angular_velocity",   Real3,         kOne,          "rad/s", kSnapshot | kMigrate | kGhost | kRefresh) \
  X(Force,           "force",              Real3,         kOne,          "N",     kSnapshot)                            \
  X(Torque,          "torque",             Real3,         kOne,          "N m",   0)                                    \
  X(Radius,          "radius",             Real,          kOne,          "m",     kSnapshot | kMigrate | kGhost)        \
  X(Mass,            "mass",               Real,          kOne,          "kg",    kMigrate | kGhost)                    \
  X(Material,        "material",           std::int32_t,  kOne,          "",      kSnapshot | kMigrate | kGhost)        \
  X(Gid,             "id",                 Gid,           kOne,          "",      kSnapshot | kMigrate | kGhost)        \
  X(HistoryPartner,  "history_partner",    PartnerId,     kContactSlots, "",      kMigrate)                             \
  X(HistoryDisp,     "history_disp",       Real3,         kContactSlots, "m",     kMigrate)                             \
  X(WallKey,         "wall_key",           std::uint64_t, kWallSlots,    "",      kMigrate)                             \
  X(WallDisp,        "wall_disp",          Real3,         kWallSlots,    "m",     kMigrate)
// clang-format on

enum class Field : std::uint8_t {
#define PFLOW_X(id, name, type, mult, unit, flags) id,
  PFLOW_PARTICLE_FIELDS(PFLOW_X)
#undef PFLOW_X
      kCount
};
inline constexpr int kNumFields = static_cast<int>(Field::kCount);

// The element type of field F in a run of precision R (float or double).
template <Field F, class R> struct FieldType;
#define PFLOW_X(id, name, type_, mult, unit, flags) \
  template <class R> struct FieldType<Field::id, R> {  \
    using Real = R;                                    \
    using Real3 = Vec3<R>;                             \
    using type = type_;                                \
  };
PFLOW_PARTICLE_FIELDS(PFLOW_X)
#undef PFLOW_X

template <class T> constexpr ScalarType scalarTypeOf();
template <> constexpr ScalarType scalarTypeOf<double>() { return ScalarType::kF64; }
template <> constexpr ScalarType scalarTypeOf<Vec3d>() { return ScalarType::kF64; }
template <> constexpr ScalarType scalarTypeOf<float>() { return ScalarType::kF32; }
template <> constexpr ScalarType scalarTypeOf<Vec3f>() { return ScalarType::kF32; }
template <> constexpr ScalarType scalarTypeOf<std::int32_t>() { return ScalarType::kI32; }
template <> constexpr ScalarType scalarTypeOf<std::uint64_t>() { return ScalarType::kU64; }
template <> constexpr ScalarType scalarTypeOf<std::uint32_t>() { return ScalarType::kU32; }

struct FieldInfo {
  Field id;
  const char* name;
  std::size_t elementBytes;  // one value (times the slot count for slot fields)
  ScalarType scalar;
  int components;
  Multiplicity multiplicity;
  const char* unit;
  std::uint32_t flags;
};

// The table for a run of precision R.
template <class R>
inline constexpr FieldInfo kFieldTableOf[kNumFields] = {
#define PFLOW_X(id, name, type_, mult, unit, flags)                                                              \
  {Field::id, name, sizeof(typename FieldType<Field::id, R>::type),                                             \
   scalarTypeOf<typename FieldType<Field::id, R>::type>(),                                                       \
   int(sizeof(typename FieldType<Field::id, R>::type) /                                                          \
       scalarBytesOf(scalarTypeOf<typename FieldType<Field::id, R>::type>())),                                   \
   Multiplicity::mult, unit, flags},
    PFLOW_PARTICLE_FIELDS(PFLOW_X)
#undef PFLOW_X
};
// Names, units, flags and multiplicities are the same at both precisions; sizes are those of a double run.
inline constexpr const FieldInfo (&kFieldTable)[kNumFields] = kFieldTableOf<double>;
inline const FieldInfo* fieldTable(bool singlePrecision) {
  return singlePrecision ? kFieldTableOf<float> : kFieldTableOf<double>;
}

}  // namespace pflow::compute
