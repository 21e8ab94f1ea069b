// THE list of the DEM solver's per-particle fields. Reorder, snapshots, migration and halo exchange
// iterate over this table (compute/particles/FieldRows.h), so adding a field is one line here. The SPH
// solver's table, on the same machinery, is compute/sph/SphFields.h.
//
// Columns: enum name, output name, element type, multiplicity (one value, one per contact slot, or
// one per wall slot), SI unit, flags. `Real` and `Real3` are the run's precision (float or double,
// `simulation.precision`); positions are double in both (ARCHITECTURE.md, "Precision").
#pragma once
#include <cstdint>

#include "compute/particles/FieldInfo.h"

namespace pflow::compute {

// clang-format off
#define PFLOW_PARTICLE_FIELDS(X)                                                                                       \
  X(Position,        "position",           Vec3d,         kOne,          "m",     kSnapshot | kMigrate | kGhost | kRefresh) \
  X(Velocity,        "velocity",           Real3,         kOne,          "m/s",   kSnapshot | kMigrate | kGhost | kRefresh) \
  X(AngularVelocity, "angular_velocity",   Real3,         kOne,          "rad/s", kSnapshot | kMigrate | kGhost | kRefresh) \
  X(Force,           "force",              Real3,         kOne,          "N",     kSnapshot | kCheckpoint | kRecomputed) \
  X(Torque,          "torque",             Real3,         kOne,          "N m",   kSnapshot | kOnRequest | kCheckpoint | kRecomputed) \
  X(Radius,          "radius",             Real,          kOne,          "m",     kSnapshot | kMigrate | kGhost)        \
  X(Mass,            "mass",               Real,          kOne,          "kg",    kMigrate | kGhost)                    \
  X(Material,        "material",           std::int32_t,  kOne,          "",      kSnapshot | kMigrate | kGhost)        \
  X(Gid,             "id",                 Gid,           kOne,          "",      kSnapshot | kMigrate | kGhost)        \
  X(HistoryPartner,  "history_partner",    PartnerId,     kContactSlots, "",      kMigrate)                             \
  X(HistoryDisp,     "history_disp",       Real3,         kContactSlots, "m",     kMigrate)                             \
  X(HistoryPooled,   "history_pooled",     std::int32_t,  kOne,          "",      0u)                                   \
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

using FieldInfo = FieldInfoOf<Field>;

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
static_assert(wordSized(kFieldTableOf<float>) && wordSized(kFieldTableOf<double>), "a field of whole 4-byte words");
// Names, units, flags and multiplicities are the same at both precisions; sizes are those of a double run.
inline constexpr const FieldInfo (&kFieldTable)[kNumFields] = kFieldTableOf<double>;
inline const FieldInfo* fieldTable(bool singlePrecision) {
  return singlePrecision ? kFieldTableOf<float> : kFieldTableOf<double>;
}

// The DEM field set, as FieldStore (compute/particles/FieldStore.h) sees it.
struct DemFieldSet {
  using Id = Field;
  static constexpr int kCount = kNumFields;
  template <class R> static constexpr const FieldInfo* table() { return kFieldTableOf<R>; }
  template <Field F, class R> using Type = typename FieldType<F, R>::type;
  // Bytes of an empty slot: partner and wall keys all ones (kNoPartner, kNoGid), displacements zero.
  static constexpr unsigned char emptySlotByte(Field f) { return f == Field::HistoryPartner || f == Field::WallKey ? 0xFF : 0x00; }
};

}  // namespace pflow::compute
