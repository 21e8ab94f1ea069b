// What every solver's field table is made of: the flags that decide where a field travels (snapshots,
// migration, halo), its multiplicity and one row of description per field. The DEM table is
// compute/dem/ParticleFields.h, the SPH table compute/sph/SphFields.h; FieldStore and FieldRows
// work on either.
#pragma once
#include <cstddef>
#include <cstdint>

#include "compute/core/VectorMath.h"
#include "compute/particles/ParticleSnapshot.h"

namespace pflow::compute {

enum FieldFlags : std::uint32_t {
  kSnapshot = 1u << 0,  // written to snapshot files
  kMigrate = 1u << 1,   // travels with a particle that changes rank
  kGhost = 1u << 2,     // what a ghost (a copy in a neighbouring rank's halo) holds, sent at each rebuild
  kRefresh = 1u << 3,   // refreshed in the ghosts every step between rebuilds
  kCheckpoint = 1u << 4,  // in a checkpoint besides the kMigrate fields (what the step after it reads unrecomputed)
  kOnRequest = 1u << 5,   // a kSnapshot field written only when output.fields names it (not by default)
  // Written before it is read again after a cell sort (DEM's force and torque: the sort falls between the step's
  // two half kicks, before the forces): the sort does not reorder it, and lends its memory to the sort as scratch.
  kRecomputed = 1u << 6,
};

enum class Multiplicity : std::uint8_t { kOne, kContactSlots, kWallSlots };

template <class T> constexpr ScalarType scalarTypeOf();
template <> constexpr ScalarType scalarTypeOf<double>() { return ScalarType::kF64; }
template <> constexpr ScalarType scalarTypeOf<Vec3d>() { return ScalarType::kF64; }
template <> constexpr ScalarType scalarTypeOf<float>() { return ScalarType::kF32; }
template <> constexpr ScalarType scalarTypeOf<Vec3f>() { return ScalarType::kF32; }
template <> constexpr ScalarType scalarTypeOf<std::int32_t>() { return ScalarType::kI32; }
template <> constexpr ScalarType scalarTypeOf<std::uint64_t>() { return ScalarType::kU64; }
template <> constexpr ScalarType scalarTypeOf<std::uint32_t>() { return ScalarType::kU32; }

// One field of a table whose fields are named by the enum E.
template <class E>
struct FieldInfoOf {
  E id;
  const char* name;
  std::size_t elementBytes;  // one value (times the slot count for slot fields)
  ScalarType scalar;
  int components;
  Multiplicity multiplicity;
  const char* unit;
  std::uint32_t flags;
};

// The reorder, pack and copy kernels move whole 4- or 8-byte words (kernels::GatherBlocks, GatherBytes): a field
// whose element is not a multiple of 4 bytes would silently not move. Each table asserts this.
template <class Info, std::size_t N>
constexpr bool wordSized(const Info (&table)[N]) {
  for (const Info& f : table)
    if (f.elementBytes % 4 != 0) return false;
  return true;
}

}  // namespace pflow::compute
