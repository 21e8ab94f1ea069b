// Snapshots as chunk streams, without gRPC: the domain twins of pflow.backend.v1.SnapshotChunk and
// pflow.common.v1.ArrayChunk, cutting arrays into pieces of at most 1 MiB, and assembling a stream of pieces
// back into a snapshot (in a scratch HDF5 file, so memory stays bounded by one piece plus the geometry).
//
// Stream contract (what WriteSnapshot accepts and ReadSnapshot sends):
//  * every chunk repeats job_id, step, time (s) and particles (n);
//  * SECTION_PARTICLES: one array per particle field, shape (n) or (n, c); dtype f64, f32, i32, u32 or u64;
//  * SECTION_GRID: grid fields, shape (nx, ny, nz) or (nx, ny, nz, 3), every chunk with the same grid spec;
//  * SECTION_GEOMETRY: the /geometry arrays by their dataset names (vertices (V,3) f64, triangles (T,3) u32,
//    triangle_mesh / triangle_surface / triangle_material (T) i32, plane_point / plane_normal (P,3) f64,
//    plane_material / plane_surface (P) i32, mesh_names / plane_names / surface_names (k) strings);
//  * the pieces of one array come in row order without gaps or overlaps (pieces of different arrays may
//    interleave); each piece carries the whole array's dtype, shape and unit; data holds whole rows, at most
//    kMaxChunkBytes (one row may be larger only if a single row exceeds it, which no pflow array does).
//  * an array with zero rows is sent as one piece with rows = 0, so the receiver knows it exists.
#pragma once
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "backend/fields/GridFields.h"
#include "backend/store/ProbeSeries.h"
#include "backend/store/SnapshotFile.h"
#include "common/Status.h"
#include "compute/particles/ParticleSnapshot.h"

namespace pflow::backend {

inline constexpr std::size_t kMaxChunkBytes = std::size_t(1) << 20;  // payload bytes per chunk
inline constexpr std::size_t kMaxGeometryBytes = std::size_t(256) << 20;

enum class Section { kParticles, kGeometry, kGrid, kProbes };
enum class DType { kF64, kF32, kI32, kU32, kI64, kU64, kString };  // pflow.common.v1.DType without UNSPECIFIED

const char* sectionName(Section s);
const char* dtypeName(DType t);
// Storable scalar type of a dtype (nullopt for i64 and strings); and the other way (nullopt for i8).
std::optional<compute::ScalarType> storedTypeOf(DType t);
std::optional<DType> dtypeOf(compute::ScalarType t);

// A piece of a bulk array: rows [firstRow, firstRow + rows) of an array of `shape`, little-endian bytes.
struct ArrayPiece {
  std::string name;
  DType dtype = DType::kF64;
  std::vector<std::uint64_t> shape;  // of the whole array
  std::uint64_t firstRow = 0;
  std::uint64_t rows = 0;
  std::string unit;
  std::string data;  // bytes (std::string so it moves into and out of protobuf without a copy)
};

struct Chunk {
  std::string jobId;
  std::int64_t step = 0;
  double time = 0;          // s
  std::uint64_t particles = 0;
  Section section = Section::kParticles;
  ArrayPiece array;
  std::optional<GridSpec> grid;  // kGrid only
  std::optional<Vec3d> point = std::nullopt;  // kProbes, a probe's array: where it samples [m]
};

using PieceSink = std::function<Status(ArrayPiece&&)>;

// Rows per piece for rows of `rowBytes` bytes (at least 1).
std::uint64_t rowsPerPiece(std::uint64_t rowBytes);
// Cuts a particle array of n rows into pieces (one empty piece when n == 0). INVALID_ARGUMENT for i8 arrays
// (the protocol has no i8) or a byte size that is not n rows.
Status particlePieces(const compute::SnapshotArray& array, std::size_t n, const PieceSink& sink);
// Cuts every non-empty geometry array into pieces.
Status geometryPieces(const compute::GeometrySnapshot& geometry, const PieceSink& sink);

using ChunkSink = std::function<Status(Chunk&&)>;
// The whole chunk stream of a snapshot (particle arrays, then the geometry if given), as a writer sends it.
Status snapshotChunks(const std::string& jobId, const compute::ParticleSnapshot& snapshot,
                      const compute::GeometrySnapshot* geometryOrNull, const ChunkSink& sink);

// Collects geometry pieces into a GeometrySnapshot (held in memory, at most kMaxGeometryBytes).
class GeometryAssembler {
 public:
  Status add(const ArrayPiece& piece);
  Status checkComplete() const;
  bool empty() const { return m_arrays.empty(); }
  Result<compute::GeometrySnapshot> take();

 private:
  struct Array {
    ArrayPiece first;  // dtype, shape, unit (data cleared)
    std::uint64_t next = 0;
    std::string bytes;                 // numeric arrays
    std::vector<std::string> strings;  // string arrays
  };
  std::vector<Array> m_arrays;
  std::size_t m_bytes = 0;
};

// Assembles one snapshot's chunk stream: particle and grid pieces into a SnapshotStaging scratch file, geometry
// pieces into memory. Every chunk must repeat the first chunk's job, step, time and particle count.
class ChunkAssembler {
 public:
  // `first` fixes job, step, time and n; it is not added (call add(first) too).
  static Result<std::unique_ptr<ChunkAssembler>> create(const std::string& scratchPath, const Chunk& first);
  Status add(const Chunk& chunk);
  // INVALID_ARGUMENT when an array misses rows or there are no particle arrays.
  Status checkComplete() const;
  SnapshotStaging& staging() { return *m_staging; }
  GeometryAssembler& geometry() { return m_geometry; }
  const std::string& jobId() const { return m_jobId; }
  std::int64_t step() const { return m_step; }
  std::uint64_t bytes() const { return m_bytes; }

 private:
  std::unique_ptr<SnapshotStaging> m_staging;
  GeometryAssembler m_geometry;
  std::string m_jobId;
  std::int64_t m_step = 0;
  double m_time = 0;
  std::uint64_t m_n = 0;
  std::uint64_t m_bytes = 0;
};

// Writes one streamed snapshot into a new local snapshot file (created or truncated; + .xmf) in the store's layout,
// through a scratch file `<output>.part` that finish() or the destructor removes. Grid chunks are stored as sent.
class SnapshotFileSink {
 public:
  explicit SnapshotFileSink(std::string outputH5) : m_output(std::move(outputH5)) {}
  Status add(const Chunk& chunk);
  // INVALID_ARGUMENT if nothing arrived or an array is incomplete; otherwise writes the file, and, when probe
  // chunks came, its /probes and the same series as CSV in probesCsvPath().
  Status finish();
  std::string probesCsvPath() const;  // <output without .h5>.probes.csv

 private:
  Status addProbes(const Chunk& chunk);
  std::string m_output;
  std::unique_ptr<ChunkAssembler> m_assembler;
  ProbeSeries m_probes;
};


}  // namespace pflow::backend
