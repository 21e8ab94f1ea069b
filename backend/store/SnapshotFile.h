// Snapshot files: one HDF5 file per run plus an XDMF sidecar (`<stem>.xmf`) that ParaView opens.
// No gRPC/protobuf here: used by the `pflow run` CLI and by the backend service.
//
// Layout of the .h5 file (format "pflow-snapshots", version 1):
//   /                      attrs format="pflow-snapshots", format_version=1 (i32), units="SI"
//   /snapshots/<step>      one group per snapshot, <step> in plain decimal ("0", "250", "-3")
//                          attrs time (f64, s), step (i64), n (u64)
//     <array name>         one dataset per SnapshotArray: shape (n) for 1 component, (n, c) otherwise,
//                          HDF5 type matching ScalarType, string attribute `unit` (SI, "" = dimensionless)
//   /geometry              optional (writeGeometry); datasets absent when empty:
//     vertices (V,3) f64 [m], triangles (T,3) u32, triangle_mesh / triangle_surface / triangle_material (T) i32,
//     plane_point (P,3) f64 [m], plane_normal (P,3) f64, plane_material (P) i32,
//     plane_surface (P) i32: scene-wide surface number of each plane (triangle_surface for triangles)
//     mesh_names, plane_names, surface_names (by surface number): 1-D variable-length UTF-8 string datasets;
//     numeric ones carry `unit` too
//     grid/                optional (the back-end's grid fields, see backend/fields/GridFields.h and
//                          docs/output-format.md): attrs origin (3 x f64, m, lower corner of cell (0,0,0)),
//                          cell_size (f64, m, cubic cells), cells (3 x u32: nx, ny, nz); datasets, each with `unit`:
//       solid_fraction       (nx, ny, nz) f64, ""
//       mean_velocity        (nx, ny, nz, 3) f64, "m/s"
//       granular_temperature (nx, ny, nz) f64, "m^2/s^2"
//                          a fluid's (SPH) grid: fluid_fraction instead of solid_fraction, mean_velocity, and
//       mean_pressure        (nx, ny, nz) f64, "Pa" instead of granular_temperature
//                          cell (i, j, k) is element [i][j][k] (C order, k fastest). The grid is not in the .xmf.
//   /xdmf/polyvertex_index helper for the sidecar: u32 0..M-1 (M = largest n so far); the .xmf selects its
//                          first n entries as the particles' vertex cells
//
// The .xmf (XDMF 3) holds a Temporal collection with one entry per snapshot: a Uniform Polyvertex grid
// "particles" (position as XYZ geometry, every other array a node Attribute), or, once geometry was written, a
// Spatial collection of "particles" and a Triangle grid "geometry". It names the .h5 by bare file name, so the
// pair can be moved together. Checked against ParaView 5.11's Xdmf3ReaderS/T and legacy XDMF reader.
//
// Neither writer nor reader takes an HDF5 file lock, so ParaView or h5py can open a live run between snapshots.
// Thread safety: every call takes one process-wide lock (HDF5 itself is built without thread safety). Calls also
// turn off HDF5's automatic error printing for the process (errors come back as Status).
// A reader sees the file as it was at open(); reopen to see snapshots written since.
//
// Bounded-memory paths (the back-end): SnapshotStaging assembles one snapshot array by array, piece by piece, in a
// scratch HDF5 file; SnapshotWriter::commit copies it into /snapshots/<step> (H5Ocopy, dataset by dataset) so a
// snapshot appears whole or not at all. SnapshotReader::meta and readRows serve any row range of any array
// (HDF5 hyperslabs), so a server streams a large array without loading the snapshot.
#pragma once
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "backend/fields/GridFields.h"
#include "backend/store/ProbeSeries.h"
#include "common/Status.h"
#include "compute/particles/ParticleSnapshot.h"

namespace pflow::backend {

inline constexpr const char* kSnapshotFormat = "pflow-snapshots";
inline constexpr int kSnapshotFormatVersion = 1;

// The sidecar path for an .h5 path: same folder and stem, extension ".xmf".
std::string xdmfPathFor(const std::string& h5Path);

// What a stored (or staged) array is, without its data.
struct ArrayMeta {
  std::string name;
  compute::ScalarType type = compute::ScalarType::kF64;
  std::vector<std::uint64_t> shape;  // particles: (n) or (n, c); grid: (nx, ny, nz) or (nx, ny, nz, 3)
  std::string unit;                  // SI, "" = dimensionless
  std::uint64_t rows() const { return shape.empty() ? 0 : shape[0]; }
  std::uint64_t rowElements() const;  // product of shape[1..]
  std::uint64_t rowBytes() const { return rowElements() * compute::scalarBytesOf(type); }
};

struct GridMeta {
  GridSpec spec;
  std::vector<ArrayMeta> arrays;
};

struct StepMeta {
  std::int64_t step = 0;
  double time = 0;  // s
  std::uint64_t n = 0;
  std::vector<ArrayMeta> arrays;  // particle arrays in write order
  std::optional<GridMeta> grid;
  const ArrayMeta* find(const std::string& name) const;
};

// Grid field names and units as stored.
inline constexpr const char* kSolidFractionName = "solid_fraction";
inline constexpr const char* kMeanVelocityName = "mean_velocity";
inline constexpr const char* kGranularTemperatureName = "granular_temperature";
inline constexpr const char* kFluidFractionName = "fluid_fraction";  // a fluid's grid, instead of solid_fraction
inline constexpr const char* kMeanPressureName = "mean_pressure";

// One snapshot being assembled piece by piece in a scratch HDF5 file (removed by the destructor), for ingest
// without holding the snapshot in memory. Not a pflow snapshot file itself.
class SnapshotStaging {
 public:
  static Result<std::unique_ptr<SnapshotStaging>> create(const std::string& scratchPath, std::int64_t step,
                                                         double time, std::uint64_t n);
  ~SnapshotStaging();
  SnapshotStaging(const SnapshotStaging&) = delete;
  SnapshotStaging& operator=(const SnapshotStaging&) = delete;

  // Rows [firstRow, firstRow + rows) of particle array meta.name; `bytes` must be rows * meta.rowBytes(). The first
  // piece of an array creates it with meta's type, shape and unit; later pieces must repeat them and continue
  // where the last ended. INVALID_ARGUMENT (and nothing written) for anything that does not fit: shape[0] != n, a
  // name that is empty or has '/', a gap or overlap, a size mismatch.
  Status writeParticleRows(const ArrayMeta& meta, std::uint64_t firstRow, std::uint64_t rows, const void* data,
                           std::size_t bytes);
  // The same for a grid array; `spec` must be the same for every grid piece and shape (nx, ny, nz[, 3]) match it.
  Status writeGridRows(const GridSpec& spec, const ArrayMeta& meta, std::uint64_t firstRow, std::uint64_t rows,
                       const void* data, std::size_t bytes);
  // INVALID_ARGUMENT naming the first array with rows missing.
  Status checkComplete() const;
  // Rows of a staged particle array converted to f64 (any numeric type); out gets rows * rowElements values.
  Status readParticleRowsF64(const std::string& name, std::uint64_t firstRow, std::uint64_t rows,
                             std::vector<double>& out) const;
  const StepMeta& meta() const;  // what was staged so far
  std::uint64_t bytes() const;   // payload bytes received

 private:
  friend class SnapshotWriter;
  struct Impl;
  explicit SnapshotStaging(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> m_impl;
};

// Writes one run's snapshots. The file is flushed and the .xmf rewritten after every write, so the pair on disk
// is complete and consistent between calls even if the process dies. Closes the file in the destructor.
class SnapshotWriter {
 public:
  // Creates (truncates) h5Path and writes an empty sidecar.
  static Result<std::unique_ptr<SnapshotWriter>> create(const std::string& h5Path);
  ~SnapshotWriter();
  SnapshotWriter(const SnapshotWriter&) = delete;
  SnapshotWriter& operator=(const SnapshotWriter&) = delete;

  // Opens an existing snapshot file to add snapshots, or creates it when missing. The sidecar is rebuilt from what
  // the file holds. INVALID_ARGUMENT if the file exists but is not a pflow snapshot file.
  static Result<std::unique_ptr<SnapshotWriter>> openOrCreate(const std::string& h5Path);

  bool hasStep(std::int64_t step) const;
  bool hasGeometry() const;
  std::vector<std::int64_t> steps() const;  // ascending

  // Writes /geometry once; a second call is FAILED_PRECONDITION. Indices and per-triangle arrays are checked.
  Status writeGeometry(const compute::GeometrySnapshot& geometry);
  // Writes /snapshots/<step>. INVALID_ARGUMENT (and nothing written) if the step exists, an array's byte size
  // is not n * components * scalarBytes, names are empty/duplicate/contain '/', or there is no 3-component
  // floating-point `position` array (the sidecar needs it as geometry).
  Status writeSnapshot(const compute::ParticleSnapshot& snapshot);
  // Adds /snapshots/<step>/grid to a stored step. NOT_FOUND for an unknown step, ALREADY_EXISTS if it has a grid,
  // INVALID_ARGUMENT if the field arrays do not match the spec.
  Status writeGrid(std::int64_t step, const GridFields& grid);
  // Moves a complete staged snapshot into /snapshots/<step>: its particle datasets in staging order, then its grid
  // (`grid` when given, else the staged grid arrays if any). ALREADY_EXISTS if the step is stored; INVALID_ARGUMENT
  // for an incomplete or invalid snapshot (no 3-component float `position`). On any error nothing is left behind.
  Status commit(const SnapshotStaging& staged, const GridFields* grid);
  // Appends samples to /probes (ProbeSeries.h), creating it on the first call; the probes' names must be the
  // ones already there, in the same order (INVALID_ARGUMENT otherwise).
  Result<std::uint64_t> appendProbes(const ProbeSeries& samples);  // the samples now stored
  // Flushes HDF5 buffers and rewrites the sidecar (writes already do both; cheap to call again).
  Status flush();
  // Closes the file and reports any error; later writes are FAILED_PRECONDITION. The destructor does the same.
  Status close();

  const std::string& path() const;
  const std::string& xdmfPath() const;

 private:
  struct Impl;
  explicit SnapshotWriter(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> m_impl;
};

// Reads a snapshot file written by SnapshotWriter (format version 1).
class SnapshotReader {
 public:
  // NOT_FOUND if the file is missing; INVALID_ARGUMENT if it is not HDF5 or not a pflow snapshot file.
  static Result<std::unique_ptr<SnapshotReader>> open(const std::string& h5Path);
  ~SnapshotReader();
  SnapshotReader(const SnapshotReader&) = delete;
  SnapshotReader& operator=(const SnapshotReader&) = delete;

  std::vector<std::int64_t> steps() const;  // ascending
  // Every dataset of /snapshots/<step> in write order, with units. NOT_FOUND for an unknown step.
  Result<compute::ParticleSnapshot> read(std::int64_t step) const;
  bool hasGeometry() const;
  // Step attributes and array shapes and units, particles and grid, without data. NOT_FOUND for an unknown step.
  Result<StepMeta> meta(std::int64_t step) const;
  // Rows [first, first + count) of particle array `name` of `step` (a hyperslab: only those rows are read), as the
  // stored type's little-endian bytes, into `out` (resized to count * rowBytes). NOT_FOUND for an unknown step or
  // array, INVALID_ARGUMENT for rows beyond the array.
  Status readRows(std::int64_t step, const std::string& name, std::uint64_t first, std::uint64_t count,
                  std::string& out) const;
  // The same for an array of the step's grid.
  Status readGridRows(std::int64_t step, const std::string& name, std::uint64_t first, std::uint64_t count,
                      std::string& out) const;
  // The whole grid of a step (NOT_FOUND if it has none).
  Result<GridFields> readGrid(std::int64_t step) const;
  // NOT_FOUND if the file has no /geometry.
  Result<compute::GeometrySnapshot> readGeometry() const;
  // The whole /probes series; NOT_FOUND if the file has none.
  Result<ProbeSeries> readProbes() const;

  const std::string& path() const;

 private:
  struct Impl;
  explicit SnapshotReader(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> m_impl;
};

}  // namespace pflow::backend
