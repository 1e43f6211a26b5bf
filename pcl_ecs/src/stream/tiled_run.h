// tiled_run.h — the pieces of the out-of-core run (out_of_core.h) that its source files share:
// constants, scratch files, the tile tree, the plan and its persistence, one tile in memory, and
// the Runner that drives the steps (scan and split: scan_split.cpp; the tiles' steps A-D:
// phases.cpp; the plan: plan.cpp; scratch files and threads: scratch.cpp; the run and its tasks:
// out_of_core.cpp). Not installed.
#pragma once

#include <pcl_ecs/stream/out_of_core.h>

#include <pcl_ecs/io/record_stream.h>
#include <pcl_ecs/neighborhood.h>
#include <pcl_ecs/parameter_table.h>
#include <pcl_ecs/search/box_tree_search.h>
#include <pcl_ecs/simplify_core.h>
#include <pcl_ecs/spatial_order.h>
#include <pcl_ecs/stages/ball_cover.h>
#include <pcl_ecs/stages/density_weights.h>
#include <pcl_ecs/stages/feature_measure.h>
#include <pcl_ecs/stages/gap_fill.h>
#include <pcl_ecs/stages/global_stats.h>
#include <pcl_ecs/stages/local_density.h>
#include <pcl_ecs/stages/normals.h>
#include <pcl_ecs/stages/paraboloid_curvature.h>
#include <pcl_ecs/stages/representative_relax.h>
#include <pcl_ecs/stages/seeded_order.h>

#include "../detail/radix_sort.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <sys/resource.h>
#include <unistd.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif

namespace pcl_ecs
{
namespace stream
{
namespace detail
{
namespace fs = std::filesystem;

using Clock = std::chrono::steady_clock;

/// What step A adds up over one tile's own points (the file sumA: these four values in order).
struct TileSumsA
{
  GlobalStats stats;      ///< Σ measure (eq. 3) and the point count
  double incomplete = 0;  ///< neighbourhoods that reach past the halo
  double merged = 0;      ///< coincident points merged into another
  static constexpr std::size_t kValues = 4;
  std::vector<double> values() const { return {stats.measure_sum, stats.points, incomplete, merged}; }
  static TileSumsA from(const std::vector<double>& v)
  {
    TileSumsA a;
    a.stats.measure_sum = v.at(0);
    a.stats.points = v.at(1);
    a.incomplete = v.at(2);
    a.merged = v.at(3);
    return a;
  }
};

/// What step B adds up over one tile's own points (the file sumB: these six values in order).
struct TileSumsB
{
  GlobalStats stats;     ///< Σ spacing (eq. 5), Σ sqrt(a) (eq. 1), Σ |H| (eq. 11), non-feature count
  double features = 0;   ///< feature points
  double searched = 0;   ///< 1 when the tile was loaded for a search over its non-feature points
  static constexpr std::size_t kValues = 6;
  std::vector<double> values() const
  {
    return {stats.spacing_sum, stats.radius_sum, stats.abs_curvature_sum, stats.nonfeature_points, features, searched};
  }
  static TileSumsB from(const std::vector<double>& v)
  {
    TileSumsB b;
    b.stats.spacing_sum = v.at(0);
    b.stats.radius_sum = v.at(1);
    b.stats.abs_curvature_sum = v.at(2);
    b.stats.nonfeature_points = v.at(3);
    b.features = v.at(4);
    b.searched = v.at(5);
    return b;
  }
};
constexpr const char* kScratchMarker = "pcl_ecs-scratch";
constexpr int kFormatVersion = 2;
constexpr std::size_t kChunk = 1 << 16;          // points per read
constexpr std::size_t kSampleTarget = 1000000;   // points in the planning sample (at most)
constexpr std::size_t kMinSample = 50000;        // ... and at least, when the memory limit is small
constexpr double kPlanBytesPerSample = 160.0;    // the plan's memory per sample point (sample, tree, tiles)
constexpr std::uint64_t kMinTilePoints = 20000;  // the smallest tile (own points + halo) worth running
constexpr int kConcurrentTiles = 2;              // the plan assumes this many tiles in memory
constexpr std::uint64_t kProcessAllowance = 48ull << 20;  // what the plan counts for the process itself
/// The tile store's records, each with its layout in one place (little-endian, packed; written and
/// read only through store() / load()).
///
/// attr/T: per point of tile T, what step A computed: the normal (3 × f32), then the weight a_i
/// (eq. 1), the feature measure (eq. 3) and the curvature H (eq. 11), each f64.
struct PointAttr
{
  static constexpr std::size_t kBytes = 12 + 3 * 8;
  /// Where the three values start; value(at, 0 weight | 1 measure | 2 curvature) reads one alone.
  static constexpr std::size_t kValuesAt = 12;
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();
  double weight = 0, measure = 0, curvature = 0;
  void store(std::uint8_t* at) const
  {
    std::memcpy(at, normal.data(), 12);
    std::memcpy(at + kValuesAt, &weight, 8);
    std::memcpy(at + kValuesAt + 8, &measure, 8);
    std::memcpy(at + kValuesAt + 16, &curvature, 8);
  }
  static Eigen::Vector3f loadNormal(const std::uint8_t* at)
  {
    Eigen::Vector3f n;
    std::memcpy(n.data(), at, 12);
    return n;
  }
  static double value(const std::uint8_t* at, int which)
  {
    double v;
    std::memcpy(&v, at + kValuesAt + 8 * static_cast<std::size_t>(which), 8);
    return v;
  }
};
constexpr std::size_t kAttrBytes = PointAttr::kBytes;

/// frontier/T: per own point, its neighbours whose measure is below that of every nearer one, as
/// (squared distance f32, index in the tile u32) entries.
struct FrontierEntry
{
  static constexpr std::size_t kBytes = 8;
  float d2 = 0;
  std::uint32_t index = 0;
  void store(std::uint8_t* at) const
  {
    std::memcpy(at, &d2, 4);
    std::memcpy(at + 4, &index, 4);
  }
  static FrontierEntry load(const std::uint8_t* at)
  {
    FrontierEntry e;
    std::memcpy(&e.d2, at, 4);
    std::memcpy(&e.index, at + 4, 4);
    return e;
  }
};

/// tiles/T.core.P and tiles/T.halo.P: the split's records. A core record is the point's input
/// index (u64) and its input record; a halo record is the input index, the tile that owns the
/// point and its index among that tile's points (u32 each), then the input record.
struct SplitHeader
{
  static constexpr std::size_t kCoreBytes = 8, kHaloBytes = 16;
  std::uint64_t gid = 0;
  std::uint32_t tile = 0, index = 0;  ///< halo records only
  void storeCore(std::uint8_t* at) const { std::memcpy(at, &gid, 8); }
  void storeHalo(std::uint8_t* at) const
  {
    std::memcpy(at, &gid, 8);
    std::memcpy(at + 8, &tile, 4);
    std::memcpy(at + 12, &index, 4);
  }
  static SplitHeader loadCore(const std::uint8_t* at)
  {
    SplitHeader h;
    std::memcpy(&h.gid, at, 8);
    return h;
  }
  static SplitHeader loadHalo(const std::uint8_t* at)
  {
    SplitHeader h;
    std::memcpy(&h.gid, at, 8);
    std::memcpy(&h.tile, at + 8, 4);
    std::memcpy(&h.index, at + 12, 4);
    return h;
  }
};

inline double secondsSince(Clock::time_point t0)
{
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// The process's resident memory now (0 when /proc cannot tell).
std::uint64_t residentBytes();

[[noreturn]] inline void failRun(const std::string& what)
{
  throw std::runtime_error(what);
}

/// A scratch file that does not match what the run wrote: `what` says which and how.
[[noreturn]] inline void failDamaged(const std::string& what)
{
  failRun(what + ": the scratch directory is damaged; remove it and run again");
}

// ---- scratch files: written under a temporary name, renamed when complete -------------------
void writeFileAtomic(const fs::path& path, const void* data, std::size_t bytes);

template <typename T>
void writeVectorAtomic(const fs::path& path, const std::vector<T>& v)
{
  writeFileAtomic(path, v.data(), v.size() * sizeof(T));
}

template <typename T>
std::vector<T> readVector(const fs::path& path)
{
  std::ifstream f(path, std::ios::binary);
  if (!f)
    failRun("cannot read the scratch file " + path.string());
  f.seekg(0, std::ios::end);
  const std::size_t bytes = static_cast<std::size_t>(f.tellg());
  f.seekg(0);
  std::vector<T> v(bytes / sizeof(T));
  f.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(T)));
  if (!f)
    failRun("cannot read the scratch file " + path.string());
  return v;
}

/// Appends the bytes of `path` to `into`; returns how many.
std::size_t appendFile(const fs::path& path, std::vector<std::uint8_t>& into);

/// File descriptors this process can still open: its soft limit less those open now.
std::uint64_t freeFileDescriptors();

std::uint64_t directoryBytes(const fs::path& dir);


// ---- the tile tree: recursive median splits of the sample ------------------------------------
struct KdNode
{
  int axis = -1;       // -1: a leaf
  double split = 0.0;  // left: coordinate < split
  int left = -1, right = -1;
  int tile = -1;
};

/// Squared distance in the plane from p to the rectangle [lo, hi] (0 inside; bounds may be infinite).
inline double rectDistance2(const std::array<double, 2>& p, const std::array<double, 2>& lo, const std::array<double, 2>& hi)
{
  const double du = std::max({lo[0] - p[0], 0.0, p[0] - hi[0]});
  const double dv = std::max({lo[1] - p[1], 0.0, p[1] - hi[1]});
  return du * du + dv * dv;
}

struct TileTree
{
  std::vector<KdNode> nodes;
  std::vector<Tile> tiles;

  /// The tile that owns p (at a split, `p[axis] < split` goes left) and, into `out`, every tile
  /// whose rectangle comes within `h` of p (the owner among them): one walk down the tree.
  int locateAndNear(const std::array<double, 2>& p, double h, std::vector<int>& out) const
  {
    int own = -1;
    nearFrom(0, p, h, true, own, out);
    return own;
  }

private:
  void nearFrom(int n, const std::array<double, 2>& p, double h, bool owner_path, int& own,
                std::vector<int>& out) const
  {
    const KdNode& k = nodes[static_cast<std::size_t>(n)];
    if (k.axis < 0)
    {
      if (owner_path)
        own = k.tile;
      const Tile& t = tiles[static_cast<std::size_t>(k.tile)];
      if (owner_path || rectDistance2(p, t.lo, t.hi) <= h * h)
        out.push_back(k.tile);
      return;
    }
    const double c = p[static_cast<std::size_t>(k.axis)];
    const bool left = c < k.split;  // the owner's side (h >= 0: that side is always walked)
    if (c - h < k.split)
      nearFrom(k.left, p, h, owner_path && left, own, out);
    if (c + h >= k.split)
      nearFrom(k.right, p, h, owner_path && !left, own, out);
  }
};

/// Recursive splits of the sample until every tile holds at most `max_core` samples and its load,
/// its samples plus those within `halo` of its rectangle, is at most `max_load` (halo 0: its own
/// samples only). A part is split across its longer side at the m/2 : m - m/2 quantile of its own
/// samples, m the larger of its count / max_core and load / max_load rounded up: the tiles come out
/// even, and a part whose halo is large (a thin part, a dense neighbour) is split further on its own
/// instead of shrinking every tile.
TileTree buildTileTree(const std::vector<std::array<double, 2>>& sample, std::size_t max_core, std::size_t max_load,
                       double halo);

// ---- one tile in memory ---------------------------------------------------------------------
struct TileData
{
  LocalCloud::Ptr cloud = std::make_shared<LocalCloud>();
  std::vector<std::uint64_t> gid;
  std::vector<std::uint32_t> src_tile, src_index;
  std::vector<std::uint8_t> is_core;
  std::vector<std::uint8_t> records;  // point_step bytes each
  /// order[o]: where point o was in the tile's files (core points first, then the halo's); a
  /// point at exactly the place of another is not loaded (see loadTile)
  std::vector<std::uint32_t> order;
  std::uint64_t merged_core = 0;  ///< own points not loaded for that reason
  std::size_t file_points = 0;    ///< points in the tile's files (own and halo), loaded or not
  std::size_t size() const { return gid.size(); }
};

struct Paths
{
  fs::path root;
  /// the points of tile t that part p of the split found (its own points; its halo's)
  fs::path core(int t, int p) const
  {
    return root / "tiles" / (std::to_string(t) + ".core." + std::to_string(p));
  }
  fs::path halo(int t, int p) const
  {
    return root / "tiles" / (std::to_string(t) + ".halo." + std::to_string(p));
  }
  fs::path attr(int t) const { return root / "a" / (std::to_string(t) + ".attr"); }
  fs::path sumA(int t) const { return root / "a" / (std::to_string(t) + ".sum"); }
  fs::path frontier(int t) const { return root / "a" / (std::to_string(t) + ".front"); }
  fs::path order(int t) const { return root / "a" / (std::to_string(t) + ".order"); }
  fs::path dens(int t) const { return root / "b" / (std::to_string(t) + ".dens"); }
  fs::path sumB(int t) const { return root / "b" / (std::to_string(t) + ".sum"); }
  /// Every tile's stage A (B) sums added up in tile order, written by the first reader once they
  /// are all there, so that each later task reads one file instead of one per tile.
  fs::path totalA() const { return root / "a" / "total.sum"; }
  fs::path totalB() const { return root / "b" / "total.sum"; }
  fs::path out(int t) const { return root / "c" / (std::to_string(t) + ".out"); }
  fs::path doneC(int t) const { return root / "c" / (std::to_string(t) + ".done"); }
  fs::path gapCandidates(int t) const { return root / "c" / (std::to_string(t) + ".gapc"); }
  fs::path fill(int t) const { return root / "d" / (std::to_string(t) + ".fill"); }
  fs::path doneD(int t) const { return root / "d" / (std::to_string(t) + ".done"); }
  fs::path claims(int target, int writer) const
  {
    return root / "c" / (std::to_string(target) + ".from." + std::to_string(writer));
  }
  fs::path plan() const { return root / "plan.txt"; }
  /// the finite points as pass 1 read them: (input index, record) each; read by the split when the
  /// input is not binary
  fs::path points() const { return root / "points.bin"; }
};

/// What the scan and the split establish; saved in plan.txt (text, exact doubles).
struct Plan
{
  std::string fingerprint;
  std::uint64_t input_points = 0, finite_points = 0;
  Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();
  int axis_u = 0, axis_v = 1;
  double halo = 0.0;
  std::uint64_t tile_point_budget = 0;
  TileTree tree;
  /// The split reads the input in `parts` consecutive runs at once; part_core[t][p] is how many
  /// of tile t's own points run p found. A tile's own points are its parts' files in turn, which
  /// is the input's order: the same tile whatever the number of parts.
  int parts = 1;
  std::vector<std::vector<std::uint64_t>> part_core;

  Eigen::Vector3d origin() const { return 0.5 * (lo + hi); }
  /// The local frame every phase computes in: (world - origin) × scale, the scale the in-memory
  /// filter uses (frameScale: 1 in everyday units, a power of four for extreme extents, which
  /// scales every length exactly). Tiles, the halo and the summary stay in world units.
  double scale() const { return frameScale((hi - lo).maxCoeff()); }
  Eigen::Vector3d toLocal(const Eigen::Vector3d& world) const { return (world - origin()) * scale(); }
  Eigen::Vector3d toWorld(const Eigen::Vector3d& local) const { return local / scale() + origin(); }
};

void savePlan(const Paths& paths, const Plan& plan);
bool loadPlan(const Paths& paths, const std::string& fingerprint, Plan& plan);


/// A file's size and modification time: what the fingerprint records of the input, and what the
/// split checks has not changed since the scan.
struct FileStamp
{
  std::uintmax_t size = 0;
  fs::file_time_type::rep mtime = 0;
  bool known = false;  ///< both could be read
  bool same(const FileStamp& o) const { return known && o.known && size == o.size && mtime == o.mtime; }
};

FileStamp stampOf(const fs::path& file);
std::string fingerprintOf(const std::vector<std::string>& inputs, const Parameters& p, std::uint64_t memory_limit);
/// A fixed pseudo-random choice per point: the planning sample does not depend on chunking.
bool inSample(std::uint64_t gid, double fraction);

/// Runs fn(tile) for every tile in `tiles` on `workers` threads; the first exception wins.
void forEachTile(const std::vector<int>& tiles, int workers, const std::function<void(int)>& fn);


class Runner
{
public:
  Runner(const std::vector<std::string>& inputs, const std::string& output, const Parameters& params,
         const StreamOptions& options)
    : inputs_(inputs), output_(output), params_(params), options_(options)
  {
    if (inputs_.empty())
      throw std::invalid_argument("no input files");
    // Messages name the input: the file, or the first of several.
    input_ = inputs_.size() == 1 ? inputs_[0]
                                 : inputs_[0] + " (and " + std::to_string(inputs_.size() - 1) + " more)";
  }

  StreamSummary run();
  /// The header, the limit, the scratch and the plan: the scan and split when the scratch holds no
  /// plan for this run (with `plan_if_missing`; else an error), the plan of an earlier run when it
  /// does.
  void prepare(bool plan_if_missing);
  /// δ (eq. 4) from every tile's phase A sums.
  void globalsAfterA();
  /// The means of eq. 6 and 12 and the radius cap from every tile's phase B sums; colours the
  /// tiles and returns the number of colours.
  int globalsAfterB(bool warn);
  /// One step of one tile, as a task: its inputs are read from the scratch and its outputs
  /// written there atomically; false when it was done already.
  bool runTask(char stage, int tile);
  /// The output from every tile's results, and the scratch removed.
  void finishRun();
  const Plan& plan() const { return plan_; }
  StreamSummary& summary() { return summary_; }

private:
  void listClaims();
  void report(const std::string& line)
  {
    if (options_.progress)
    {
      std::lock_guard<std::mutex> lock(report_mutex_);
      options_.progress(line);
    }
  }
  void stepDone()
  {
#ifdef __GLIBC__
    // Hand the finished tile's freed memory back once the process holds more than half the
    // budget: peak RSS stays that of two tiles. Below that, the next tile reuses the pages
    // without faulting them in again (trimming after every tile cost ~4% of the run in the kernel).
    if (residentBytes() > memory_limit_ / 2)
      ::malloc_trim(0);
#endif
    const std::uint64_t done = ++steps_;
    if (options_.kill_after_steps && done >= options_.kill_after_steps)
      std::raise(SIGKILL);
  }
  /// Removes scratch files no later step reads once their step's marker is written (their pages
  /// go back to the system for the next files instead of piling up in the page cache and being
  /// written to disk), unless the scratch is to be kept. A rerun skips the marked steps.
  void dropScratch(const std::vector<fs::path>& files) const
  {
    if (options_.keep_scratch)
      return;
    std::error_code ec;
    for (const fs::path& f : files)
      fs::remove(f, ec);
  }
  /// Memory per point of a tile in memory (points, neighbourhoods, per-point values, records).
  static double tileBytesPerPoint(std::size_t step) { return 420.0 + 2.0 * static_cast<double>(step); }
  /// The limit less what the plan counts for the process itself.
  double usableBytes() const
  {
    return static_cast<double>(memory_limit_) - static_cast<double>(std::min(memory_limit_, baseline_bytes_));
  }
  /// The smallest --memory-limit this run can keep to: the process as it is, the smallest
  /// planning sample and two of the smallest tiles.
  std::uint64_t minimumLimit(std::size_t step) const
  {
    const double usable = std::max(kMinSample * kPlanBytesPerSample / 0.5,
                                   kConcurrentTiles * kMinTilePoints * tileBytesPerPoint(step) / 0.7);
    return baseline_bytes_ + static_cast<std::uint64_t>(usable);
  }
  /// The limit a refusal suggests, in MiB: `needed` and 8 MiB more, rounded up to 8 MiB. The
  /// process's own size at the start varies by a MiB or so from run to run (page faults in its
  /// libraries), so a suggestion of exactly `needed` could be refused on the next run.
  static std::string suggestedLimit(std::uint64_t needed)
  {
    constexpr std::uint64_t kStep = 8ull << 20;
    return std::to_string((needed + kStep + kStep - 1) / kStep * (kStep >> 20)) + "M";
  }
  void scanAndPlan(io::RecordSource& reader);
  /// The planning sample: a fixed pseudo-random fraction of the finite points, and their bounds.
  struct PlanningSample
  {
    std::vector<Eigen::Vector3d> points;
    double fraction = 1.0;
    Eigen::Vector3d lo, hi;
  };
  /// Reads the input once: bounds, the sample, and (an input read only once) the finite points
  /// copied to scratch. Returns the number of finite points.
  std::uint64_t scanInput(io::RecordSource& reader, PlanningSample& sample);
  /// The halo width from the sample's neighbour distances (world units).
  double estimateHalo(const PlanningSample& sample);
  /// The tile budget, the halo (estimateHalo; 0 when the scan fits one tile) and the tile tree;
  /// refuses a limit the run cannot keep.
  void planTiles(const PlanningSample& sample);
  /// A binary PCD in a regular file is read again by the split; anything else is copied to scratch
  /// once.
  bool readTwice() const { return records_in_input_; }
  void split();
  /// What every part of the split shares (split(), splitPart()).
  struct SplitJob
  {
    fs::path source;            ///< the input (read twice) or the scan's copy of its finite points
    bool from_input;
    std::size_t record;         ///< bytes a record in `source`
    std::uint64_t records;
    std::uint64_t offset;       ///< of the first record
    int parts;
    std::size_t buffer;         ///< bytes of each tile file's buffer
    Clock::time_point t0;
    std::atomic<std::uint64_t>* done;                       ///< records read by every part
    std::vector<std::vector<std::uint64_t>>* part_halo;     ///< [tile][part] halo points
    std::vector<std::uint64_t>* part_finite;                ///< [part] finite points
  };
  /// One part of the split: a run of consecutive records to its own file per tile core and halo.
  void splitPart(const SplitJob& job, int part);
  TileData loadTile(int t) const;
  /// The point order phase A saved for tile t (n points in its files), checked.
  std::vector<std::uint32_t> savedOrder(int t, std::size_t n) const;
  /// The order of a tile's points (input indices `gids`, positions `pos`, both in file order):
  /// by Hilbert code in the global box, ties by input index, coincident points left out.
  std::vector<std::uint32_t> hilbertOrder(const std::vector<std::uint64_t>& gids,
                                          const std::vector<Eigen::Vector3d>& pos) const;
  /// The tasks of one tile, named for what they compute; each reads its inputs from the scratch
  /// and writes its outputs there atomically (the stage letter of runTask and of the scratch
  /// directories in brackets).
  /// [A] neighbourhoods, normals, weights, feature measure and curvature (eq. 1-3, 7-11), the
  /// tile's sums for δ, and each point's neighbours for eq. 5.
  void geometryTask(int t);
  /// [B] eq. 5 with the global δ, and the tile's sums for the means of eq. 6, 1 and 12.
  void densityTask(int t);
  /// [C] the cover (steps 2-7) of the tile's own points, its output records, its claims on other
  /// tiles' points, and its gap candidates.
  void coverTask(int t);
  /// Per point of tile t: 1 when a ball of a tile of an earlier colour covered it (their claims).
  std::vector<std::uint8_t> coveredByEarlierColours(int t, const TileData& d) const;
  /// The points tile t's balls covered, by the tile that owns them (claims files).
  void writeClaims(int t, const TileData& d, const CoverOutput& cover) const;
  /// The records of the tile's own non-feature points farther than the gap from every output
  /// point the tile knows (phase D's candidates).
  std::vector<std::uint8_t> gapCandidates(const TileData& d, const std::vector<std::uint8_t>& is_feature,
                                          const NormalList& normals, const CoverOutput& cover) const;
  /// [D] the gap bound over the tile's candidates, colour by colour.
  void gapTask(int t);
  /// Writes nrm (turned towards the viewpoint as seen from `at`, local frame) into the record's
  /// normal fields, when the input has them.
  void setRecordNormal(std::uint8_t* rec, Eigen::Vector3f nrm, const Eigen::Vector3d& at) const;
  void writeOutput();
  void runStage(const char* name, int index, const std::vector<int>& todo, const std::function<void(int)>& fn);

  std::vector<std::string> inputs_;
  std::string input_, output_;
  Parameters params_;
  StreamOptions options_;
  Paths paths_;
  Plan plan_;
  io::PcdHeader header_;
  StreamSummary summary_;
  std::mutex report_mutex_;
  std::atomic<std::uint64_t> steps_{0};
  int workers_ = 1;
  int tile_threads_ = 1;  // threads inside one tile (set by runStage for each batch of tiles)
  int threads_ = 1;       // all the run's threads
  std::uint64_t memory_limit_ = 0;
  /// What the plan counts for the process itself (its code and libraries): kProcessAllowance,
  /// a constant, so that the plan (sample, tile size, halo) and so the output depend on the input
  /// and the limit only, not on the process or machine that runs it.
  std::uint64_t baseline_bytes_ = 0;
  /// The input as the scan read it: whether its records can be read again from it and where they
  /// start, its size and time, its LAS header (for a LAS / LAZ input).
  bool records_in_input_ = false;
  std::uint64_t data_offset_ = 0;
  std::unique_ptr<io::LasInfo> las_;
  FileStamp input_stamp_;
  /// Σ measure over the own points of the tiles phase A has finished in this run.
  double measure_done_ = 0.0;
  std::mutex measure_done_mutex_;
  /// Claim files present when the current colour started: target tile -> writers (ascending).
  std::map<int, std::vector<int>> claim_writers_;
  // global statistics
  double delta_ = 0.0, cap_ = 0.0;
  GlobalStats measures_;  ///< step A's sums over the whole scan (eq. 3)
  GlobalStats stats_;     ///< step B's sums over the whole scan, and step A's
  Eigen::Vector3d viewpoint_local_ = Eigen::Vector3d::Zero();
  std::array<int, 3> normal_fields_{{-1, -1, -1}};  // normal_x/y/z in the records, -1: absent
};

}  // namespace detail
}  // namespace stream
}  // namespace pcl_ecs
