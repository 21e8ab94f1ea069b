// The scene loader's internals: one Loader per load, reading sections in order (materials, simulation, pairs,
// particles, geometry, output) and collecting every error with its YAML path and location. Split over
// Loader.cc (generic readers, top-level sections, validation), Particles.cc and Geometry.cc.
#pragma once
#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "common/Status.h"
#include "compute/sim/RunConfig.h"
#include "frontend/SceneLoader.h"
#include "frontend/geometry/Primitives.h"
#include "frontend/geometry/TriMesh.h"
#include "frontend/generators/Generators.h"
#include "frontend/scene/YamlUtil.h"

namespace pflow::frontend::detail {

class WallClearance;  // frontend/scene/WallClearance.h

using compute::MaterialConfig;
using compute::MaterialPairConfig;
using compute::MeshConfig;
using compute::MeshMotion;
using compute::PlaneConfig;
using compute::RunConfig;
using Keys = std::span<const std::string_view>;


constexpr std::string_view kTopKeys[] = {"materials", "pairs", "particles", "geometry", "simulation", "output", "solver", "slurm"};
constexpr std::string_view kSolvers[] = {"dem", "sph"};
// solver: sph (frontend/scene/Fluid.cc; docs/scene-format.md, "Fluids").
constexpr std::string_view kSphTopKeys[] = {"solver", "fluid", "tank", "obstacles", "sph", "probes", "simulation", "output", "slurm"};
// slurm: what the job asks of Slurm when the manager places jobs through it (frontend/scene/Cluster.cc; docs/cluster.md).
constexpr std::string_view kSlurmKeys[] = {"partition", "account", "time_limit"};
constexpr std::string_view kFluidKeys[] = {"density", "sound_speed", "gamma", "kinematic_viscosity", "blocks"};
constexpr std::string_view kFluidBlockKeys[] = {"name", "min", "max", "velocity"};
constexpr std::string_view kTankKeys[] = {"name", "min", "max", "open_top"};
constexpr std::string_view kObstacleKeys[] = {"name", "min", "max"};
constexpr std::string_view kSphKeys[] = {"dimension", "spacing", "smoothing_ratio", "kernel", "artificial_viscosity",
                                         "density_diffusion", "diffusion_correction", "cfl", "dt", "boundary",
                                         "boundary_layers", "wall_slip", "boundary_density", "skin", "density_bounds",
                                         "integrator", "verlet_steps"};
constexpr std::string_view kSphKernels[] = {"wendland", "cubic_spline"};
constexpr std::string_view kSphBoundaries[] = {"dynamic", "mirror"};
constexpr std::string_view kWallSlips[] = {"no_slip", "free_slip"};
constexpr std::string_view kBoundaryDensities[] = {"continuity", "mdbc"};
constexpr std::string_view kSphIntegrators[] = {"symplectic", "verlet", "velocity_verlet"};
constexpr std::string_view kDiffusionCorrections[] = {"hydrostatic", "none"};
constexpr std::string_view kProbeKeys[] = {"name", "point", "gauge"};
constexpr std::string_view kSphSimulationKeys[] = {"gravity", "duration", "snapshot_interval", "precision", "threads", "decomposition", "reproducible"};
constexpr std::string_view kSphOutputKeys[] = {"file", "fields", "probe_interval", "probe_sampling", "checkpoint_interval"};
constexpr std::string_view kProbeSamplings[] = {"instant", "mean"};
constexpr std::string_view kMaterialKeys[] = {"name", "youngs_modulus", "poisson_ratio", "density", "restitution", "friction", "rolling_friction", "fixed"};
constexpr std::string_view kPairKeys[] = {"materials", "restitution", "friction", "rolling_friction", "cohesion"};
constexpr std::string_view kCohesionKeys[] = {"model", "work_of_adhesion"};
constexpr std::string_view kCohesionModels[] = {"jkr", "constant"};
constexpr std::string_view kParticleSetKeys[] = {"name", "material", "method", "size", "count", "solid_fraction", "region",
                                                 "velocity", "angular_velocity", "lattice", "tiled", "random", "list", "file"};
constexpr std::string_view kMethods[] = {"lattice", "random", "tiled", "list"};
constexpr std::string_view kParticleKeys[] = {"position", "radius", "velocity", "angular_velocity"};
constexpr std::string_view kLatticeKeys[] = {"packing", "spacing", "jitter"};
constexpr std::string_view kPackings[] = {"cubic", "hexagonal"};
constexpr std::string_view kTiledKeys[] = {"tile_size", "max_attempts"};
constexpr std::string_view kRandomKeys[] = {"max_attempts"};
constexpr std::string_view kSizeKeys[] = {"distribution", "radius", "min", "max", "mean", "std", "median", "geometric_std", "radii", "fractions", "basis"};
constexpr std::string_view kDistributions[] = {"single", "uniform", "normal", "lognormal", "discrete"};
constexpr std::string_view kBases[] = {"number", "volume"};
constexpr std::string_view kRegionShapes[] = {"box", "cylinder", "mesh"};
constexpr std::string_view kRegionKeys[] = {"min", "max"};
constexpr std::string_view kCylinderRegionKeys[] = {"base", "axis", "radius", "height"};
constexpr std::string_view kShapeKinds[] = {"plane", "box", "cylinder", "cone", "hopper", "drum", "mesh"};
constexpr std::string_view kGeometryKeys[] = {"plane", "box", "cylinder", "cone", "hopper", "drum", "mesh", "name", "material", "motion"};
constexpr std::string_view kPlaneKeys[] = {"point", "normal"};
constexpr std::string_view kBoxKeys[] = {"min", "max", "open", "resolution", "side"};
constexpr std::string_view kCylinderKeys[] = {"base", "axis", "radius", "height", "open", "resolution", "segments", "side"};
constexpr std::string_view kConeKeys[] = {"base", "axis", "bottom_radius", "top_radius", "height", "open", "resolution", "segments", "side"};
constexpr std::string_view kHopperKeys[] = {"orifice", "axis", "orifice_radius", "top_radius", "cone_height", "cylinder_height", "open", "resolution", "segments"};
constexpr std::string_view kDrumKeys[] = {"center", "axis", "radius", "length", "angular_velocity", "start_time", "resolution", "segments"};
constexpr std::string_view kMeshKeys[] = {"vertices", "triangles", "surfaces", "file", "scale", "translate", "rotate", "flip"};
constexpr std::string_view kRotateKeys[] = {"axis", "angle"};
constexpr std::string_view kSides[] = {"inside", "outside"};
constexpr std::string_view kCapNames[] = {"bottom", "top"};
constexpr std::string_view kHopperOpenings[] = {"orifice", "top"};
constexpr std::string_view kMotionKeys[] = {"velocity", "angular_velocity", "axis", "axis_point", "start_time", "vibration",
                                            "velocity_profile", "drive"};
constexpr std::string_view kDriveKeys[] = {"mass", "force", "force_limit", "moment_of_inertia", "torque", "torque_limit"};
constexpr std::string_view kVibrationKeys[] = {"amplitude", "frequency", "phase"};
constexpr std::string_view kSimulationKeys[] = {"gravity", "duration", "dt", "dt_fraction", "skin", "snapshot_interval",
                                                "domain", "precision", "decomposition", "history_slots", "wall_history_slots", "threads", "seed", "physics",
                                                "max_overlap", "max_contacts", "on_instability", "checkpoint_steps",
                                                "model", "accuracy", "reproducible"};
constexpr std::string_view kModelModes[] = {"auto", "full"};
constexpr std::string_view kAccuracyKeys[] = {"quantity", "tolerance"};
constexpr std::string_view kPhysicsKeys[] = {"friction", "rolling_resistance", "cohesion"};
constexpr std::string_view kOutputKeys[] = {"file", "fields", "checkpoint_interval", "series_interval", "flow_planes"};
constexpr std::string_view kFlowPlaneKeys[] = {"name", "point", "normal"};
constexpr std::string_view kPrecisions[] = {"double", "float"};
constexpr std::string_view kDecompositions[] = {"sfc", "multisection"};
constexpr std::string_view kInstabilityActions[] = {"stop", "reduce_dt"};
// Box faces; the index is the face's surface number.
constexpr std::array<std::string_view, 6> kBoxFaces = {"bottom", "top", "left", "right", "front", "back"};

class Loader {
 public:
  explicit Loader(LoadOptions options) : m_options(std::move(options)) {}
  Result<LoadedScene> run(const std::string& yaml, const std::string& sourceName);

 private:
  struct Entry {
    std::string key;
    YAML::Node value;
    Loc keyLoc;
    Loc loc;  // of the value; the key's when the value is empty
  };
  struct Fields {
    std::string path;
    Loc loc;
    std::vector<Entry> entries;
    const Entry* find(std::string_view k) const {
      for (const Entry& e : entries) {
        if (e.key == k) return &e;
      }
      return nullptr;
    }
    std::string child(std::string_view k) const { return path.empty() ? std::string(k) : path + "." + std::string(k); }
  };
  struct ParticleSet {
    std::size_t first = 0, count = 0;
    std::string path;
    std::string method;
    bool inlineList = false;     // particles from `list` entries (each has its own YAML location)
    std::vector<Loc> entryLocs;  // inline lists: one per particle
  };
  // RunConfig path prefix -> YAML path; keepSuffix appends what follows the prefix (e.g. `[3]`).
  struct PathMap {
    std::string rcPrefix, yamlPath;
    bool keepSuffix;
  };

  void error(const std::string& path, const std::string& message, Loc loc) { m_errors.add(path, message, loc.line, loc.column); }
  // An error that leaves the value unusable: validate() findings at or under this path are not repeated.
  void badValue(const std::string& path, const std::string& message, Loc loc) {
    error(path, message, loc);
    m_badPaths.push_back(path);
  }
  void missing(const Fields& f, std::string_view key, std::string_view hint = {}) {
    badValue(f.child(key), "required key '" + std::string(key) + "' is missing" + (hint.empty() ? "" : " (" + std::string(hint) + ")"), f.loc);
  }

  std::optional<Fields> mapping(const YAML::Node& n, const std::string& path, Loc loc, Keys allowed);
  bool isList(const YAML::Node& n, const std::string& path, Loc loc, std::string_view itemWhat);

  bool read(const YAML::Node& n, const std::string& path, Loc loc, double& out);
  bool read(const YAML::Node& n, const std::string& path, Loc loc, int& out);
  bool read(const YAML::Node& n, const std::string& path, Loc loc, std::uint64_t& out);
  bool read(const YAML::Node& n, const std::string& path, Loc loc, std::string& out);
  bool read(const YAML::Node& n, const std::string& path, Loc loc, Vec3d& out);
  bool read(const YAML::Node& n, const std::string& path, Loc loc, bool& out);
  template <class T>
  bool get(const Fields& f, std::string_view key, T& out, bool required = false) {
    const Entry* e = f.find(key);
    if (!e) {
      if (required) missing(f, key);
      return false;
    }
    return read(e->value, f.child(key), e->loc, out);
  }
  // `auto` or a number; nullopt for auto (and, after reporting it, for a type error).
  std::optional<double> autoOrNumber(const Entry& e, const std::string& path, std::string_view unit);
  int materialRef(const Fields& f, std::string_view key);
  int materialByName(const YAML::Node& n, const std::string& path, Loc loc);

  void checkStructure(const YAML::Node& node, const std::string& path, std::vector<YAML::Node>& ancestors);
  void parseMaterials(const Fields& top);
  void parsePairs(const Fields& top);
  void parseSimulation(const Fields& top);
  void parseParticles(const Fields& top);
  void parseParticleSet(const YAML::Node& item, const std::string& path, Loc loc, std::size_t setIndex);
  // The set's `velocity` / `angular_velocity` (v0, w0) are the defaults of its entries.
  bool parseParticleList(const Fields& f, const Vec3d& v0, const Vec3d& w0, Particles& out, std::vector<Vec3d>& vel,
                         std::vector<Vec3d>& spin, ParticleSet& set);
  std::optional<SizeDistribution> parseSize(const Fields& set);
  std::optional<Region> parseParticleRegion(const Fields& set);
  std::optional<Vec3d> readVec(const Fields& f, std::string_view key);
  void parseGeometry(const Fields& top);
  // One shape entry -> its mesh as the particles see it (normals towards them), or nullopt after reporting why.
  std::optional<TriMesh> parseShape(std::string_view kind, const Entry& shape, const std::string& path, MeshMotion& motion,
                                    bool& motionGiven);
  std::optional<TriMesh> parseBox(const Fields& f);
  std::optional<TriMesh> parseCylinder(const Fields& f);
  std::optional<TriMesh> parseCone(const Fields& f);
  std::optional<TriMesh> parseHopper(const Fields& f);
  std::optional<TriMesh> parseDrum(const Fields& f, MeshMotion& motion);
  std::optional<TriMesh> parseMesh(const Fields& f);
  std::optional<TriMesh> parseInlineMesh(const Fields& f);
  bool parseTessellation(const Fields& f, Tessellation& t);
  bool parseSide(const Fields& f, bool& inside);
  // `key: [name, ...]` naming openings among `names`; false after reporting an error.
  bool parseOpenings(const Fields& f, Keys names, std::string_view what, std::vector<bool>& open);
  // A required or optional number that must be > 0 (>= 0 with allowZero); false after reporting.
  bool positive(const Fields& f, std::string_view key, double& out, bool required, bool allowZero = false);
  bool unitAxis(const Fields& f, std::string_view key, Vec3d& axis);
  // A tessellation error, with the spec's parameter names mapped to the scene's keys.
  void shapeError(const Fields& f, const Status& s);
  bool parseRegion(const Fields& f, std::string_view key, Vec3d& lo, Vec3d& hi, bool required);
  void parseMotion(const Fields& g, MeshMotion& motion);
  void parseOutput(const Fields& top);
  void parseSlurm(const Fields& top);  // Cluster.cc
  void parseSeries(const Fields& output);
  // solver: sph (Fluid.cc): fluid, tank, obstacles, sph and probes; the particles generated on the lattice.
  void parseSphScene(const Fields& top);
  std::optional<compute::sph::SphRegion> parseSphBox(const Fields& f, const std::string& path);

  void addParticle(const Vec3d& x, double r, const Vec3d& v, const Vec3d& w, int material);
  void appendValidation(const ErrorList& found);
  std::pair<std::string, Loc> locate(const std::string& rcPath, std::string& message) const;
  Loc markFor(std::string yamlPath) const;
  bool isBad(const std::string& yamlPath) const;

  // A file name from the scene, resolved against the scene file's folder.
  std::string resolvePath(const std::string& name) const;
  // A file the scene names, checked before it is read: a regular file (not a FIFO, device or folder) of at most
  // LoadOptions::maxFileBytes; with confineFiles also relative, without '..', and not a link out of baseDir.
  Result<std::string> resolveInput(const std::string& name) const;

  LoadOptions m_options;
  ErrorList m_errors;
  RunConfig m_config;
  std::string m_outputFile;
  SlurmRequest m_slurm;
  double m_checkpointInterval = 0;
  std::vector<std::string> m_outputFields;
  std::vector<SurfaceInfo> m_surfaces;
  std::vector<ParticleSetInfo> m_setInfo;
  std::vector<std::string> m_files;
  std::shared_ptr<WallClearance> m_clearance;  // built at the first generated set, shared by all  // files the scene refers to, as written
  bool m_friction = true, m_rollingResistance = true, m_cohesion = true;  // simulation.physics switches
  std::vector<std::string> m_badPaths;
  std::unordered_map<std::string, Loc> m_marks;  // YAML path -> where its value starts
  std::vector<PathMap> m_pathMaps;
  std::vector<ParticleSet> m_sets;
  std::map<std::string, int, std::less<>> m_materialIndex;
  std::vector<std::string> m_materialNames;
  bool m_sph = false;  // solver: sph
};

}  // namespace pflow::frontend::detail
