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
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/Status.h"
#include "compute/particles/ParticleSnapshot.h"

namespace pflow::backend {

inline constexpr const char* kSnapshotFormat = "pflow-snapshots";
inline constexpr int kSnapshotFormatVersion = 1;

// The sidecar path for an .h5 path: same folder and stem, extension ".xmf".
std::string xdmfPathFor(const std::string& h5Path);

// Writes one run's snapshots. The file is flushed and the .xmf rewritten after every write, so the pair on disk
// is complete and consistent between calls even if the process dies. Closes the file in the destructor.
class SnapshotWriter {
 public:
  // Creates (truncates) h5Path and writes an empty sidecar.
  static Result<std::unique_ptr<SnapshotWriter>> create(const std::string& h5Path);
  ~SnapshotWriter();
  SnapshotWriter(const SnapshotWriter&) = delete;
  SnapshotWriter& operator=(const SnapshotWriter&) = delete;

  // Writes /geometry once; a second call is FAILED_PRECONDITION. Indices and per-triangle arrays are checked.
  Status writeGeometry(const compute::GeometrySnapshot& geometry);
  // Writes /snapshots/<step>. INVALID_ARGUMENT (and nothing written) if the step exists, an array's byte size
  // is not n * components * scalarBytes, names are empty/duplicate/contain '/', or there is no 3-component
  // floating-point `position` array (the sidecar needs it as geometry).
  Status writeSnapshot(const compute::ParticleSnapshot& snapshot);
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
  // NOT_FOUND if the file has no /geometry.
  Result<compute::GeometrySnapshot> readGeometry() const;

  const std::string& path() const;

 private:
  struct Impl;
  explicit SnapshotReader(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> m_impl;
};

}  // namespace pflow::backend
