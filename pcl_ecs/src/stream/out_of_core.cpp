// The out-of-core path: see out_of_core.h and docs/STREAMING.md.
#include <pcl_ecs/stream/out_of_core.h>

#include <pcl_ecs/io/record_stream.h>
#include <pcl_ecs/neighborhood.h>
#include <pcl_ecs/search/box_tree_search.h>
#include <pcl_ecs/simplify_core.h>
#include <pcl_ecs/spatial_order.h>
#include <pcl_ecs/stages/ball_cover.h>
#include <pcl_ecs/stages/density_weights.h>
#include <pcl_ecs/stages/feature_measure.h>
#include <pcl_ecs/stages/gap_fill.h>
#include <pcl_ecs/stages/local_density.h>
#include <pcl_ecs/stages/normals.h>
#include <pcl_ecs/stages/paraboloid_curvature.h>
#include <pcl_ecs/stages/seeded_order.h>

#include "../radix_sort.h"

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

namespace fs = std::filesystem;

namespace
{
using Clock = std::chrono::steady_clock;
constexpr const char* kScratchMarker = "pcl_ecs-scratch";
constexpr int kFormatVersion = 2;
constexpr std::size_t kChunk = 1 << 16;          // points per read
constexpr std::size_t kSampleTarget = 1000000;   // points in the planning sample (at most)
constexpr std::size_t kMinSample = 50000;        // ... and at least, when the memory limit is small
constexpr double kPlanBytesPerSample = 160.0;    // the plan's memory per sample point (sample, tree, tiles)
constexpr std::uint64_t kMinTilePoints = 20000;  // the smallest tile (own points + halo) worth running
constexpr int kConcurrentTiles = 2;              // the plan assumes this many tiles in memory
constexpr std::uint64_t kProcessAllowance = 48ull << 20;  // what the plan counts for the process itself
constexpr std::size_t kAttrBytes = 12 + 3 * 8;   // normal (3 f32), weight, measure, curvature (f64)

double secondsSince(Clock::time_point t0)
{
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// The process's resident memory now (0 when /proc cannot tell).
std::uint64_t residentBytes()
{
  std::ifstream statm("/proc/self/statm");
  std::uint64_t size = 0, resident = 0;
  if (!(statm >> size >> resident))
    return 0;
  return resident * static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE));
}

[[noreturn]] void failRun(const std::string& what)
{
  throw std::runtime_error(what);
}

/// A scratch file that does not match what the run wrote: `what` says which and how.
[[noreturn]] void failDamaged(const std::string& what)
{
  failRun(what + ": the scratch directory is damaged; remove it and run again");
}

// ---- scratch files: written under a temporary name, renamed when complete -------------------
void writeFileAtomic(const fs::path& path, const void* data, std::size_t bytes)
{
  // A name of this process and call: two processes that write the same file (a task run again
  // while a worker thought lost still runs it) never write into one temporary; the last rename
  // wins, with the same bytes.
  static std::atomic<std::uint64_t> serial{0};
  const fs::path tmp = path.string() + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(serial++);
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f.write(static_cast<const char*>(data), static_cast<std::streamsize>(bytes));
    f.flush();
    if (!f)
      failRun("cannot write " + tmp.string() + " (disk full?)");
  }
  fs::rename(tmp, path);
}

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
std::size_t appendFile(const fs::path& path, std::vector<std::uint8_t>& into)
{
  std::ifstream f(path, std::ios::binary | std::ios::ate);
  if (!f)
    failRun("cannot read the scratch file " + path.string());
  const auto bytes = static_cast<std::size_t>(f.tellg());
  f.seekg(0);
  const std::size_t at = into.size();
  into.resize(at + bytes);
  f.read(reinterpret_cast<char*>(into.data() + at), static_cast<std::streamsize>(bytes));
  if (!f)
    failRun("cannot read the scratch file " + path.string());
  return bytes;
}

/// File descriptors this process can still open: its soft limit less those open now.
std::uint64_t freeFileDescriptors()
{
  rlimit limit{};
  if (::getrlimit(RLIMIT_NOFILE, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY)
    return std::uint64_t{1} << 20;
  std::uint64_t open = 0;
  std::error_code ec;
  for (auto it = fs::directory_iterator("/proc/self/fd", ec); !ec && it != fs::directory_iterator(); it.increment(ec))
    ++open;
  if (ec)
    open = 16;  // no /proc: a guess
  return limit.rlim_cur > open ? limit.rlim_cur - open : 0;
}

std::uint64_t directoryBytes(const fs::path& dir)
{
  std::uint64_t total = 0;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(dir, ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec))
    if (it->is_regular_file(ec))
      total += it->file_size(ec);
  return total;
}

// ---- the tile tree: recursive median splits of the sample ------------------------------------
struct KdNode
{
  int axis = -1;       // -1: a leaf
  double split = 0.0;  // left: coordinate < split
  int left = -1, right = -1;
  int tile = -1;
};

/// Squared distance in the plane from p to the rectangle [lo, hi] (0 inside; bounds may be infinite).
double rectDistance2(const std::array<double, 2>& p, const std::array<double, 2>& lo, const std::array<double, 2>& hi)
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
                       double halo)
{
  TileTree tree;
  const double inf = std::numeric_limits<double>::infinity();
  const double h2 = halo * halo;
  // The samples with their index, moved around by the selections below (sorting the points
  // themselves rather than indices to them: no scattered reads).
  struct Item
  {
    std::array<double, 2> p;
    std::uint32_t id;
  };
  std::vector<Item> items(sample.size());
  for (std::size_t i = 0; i < sample.size(); ++i)
    items[i] = {sample[i], static_cast<std::uint32_t>(i)};
  struct Job
  {
    int node;
    std::size_t begin, end;
    std::array<double, 2> lo, hi;        // the rectangle (may be infinite)
    std::array<double, 2> slo, shi;      // the samples' extent, to choose the split axis
    std::vector<std::uint32_t> reach;    // halo > 0: the samples outside the part within halo of it
  };
  auto extent = [&](std::size_t b, std::size_t e, std::array<double, 2>& lo, std::array<double, 2>& hi) {
    lo = {inf, inf};
    hi = {-inf, -inf};
    for (std::size_t i = b; i < e; ++i)
      for (std::size_t a = 0; a < 2; ++a)
      {
        lo[a] = std::min(lo[a], items[i].p[a]);
        hi[a] = std::max(hi[a], items[i].p[a]);
      }
  };
  // The halo samples of a child: the parent's halo samples and the sibling's own ones within reach.
  auto reachOf = [&](const Job& child, const Job& parent, std::size_t sib_begin, std::size_t sib_end) {
    std::vector<std::uint32_t> r;
    if (!(halo > 0.0))
      return r;
    for (const std::uint32_t i : parent.reach)
      if (rectDistance2(sample[i], child.lo, child.hi) <= h2)
        r.push_back(i);
    for (std::size_t k = sib_begin; k < sib_end; ++k)
      if (rectDistance2(items[k].p, child.lo, child.hi) <= h2)
        r.push_back(items[k].id);
    return r;
  };
  tree.nodes.push_back({});
  std::vector<Job> jobs;
  Job root{0, 0, items.size(), {-inf, -inf}, {inf, inf}, {}, {}, {}};
  extent(0, items.size(), root.slo, root.shi);
  jobs.push_back(std::move(root));
  // Depth-first, left before right: tiles are numbered in a deterministic, spatially coherent order.
  while (!jobs.empty())
  {
    Job j = std::move(jobs.back());
    jobs.pop_back();
    const std::size_t count = j.end - j.begin;
    const std::size_t load = count + j.reach.size();
    const int axis = (j.shi[1] - j.slo[1]) > (j.shi[0] - j.slo[0]) ? 1 : 0;
    const double side = j.shi[static_cast<std::size_t>(axis)] - j.slo[static_cast<std::size_t>(axis)];
    // A part narrower than a quarter of the halo is split for its own samples only: its load is
    // then mostly halo, which smaller parts would not shrink (the halo's disc stays), and
    // splitting on would only make tiles of single points.
    const bool too_loaded = load > max_load && side > 0.25 * halo;
    bool split = (count > max_core || too_loaded) && count >= 2 && side > 0.0;
    double value = 0.0;
    std::size_t mid = 0;
    if (split)
    {
      const std::size_t a = static_cast<std::size_t>(axis);
      auto first = items.begin() + static_cast<std::ptrdiff_t>(j.begin);
      auto last = items.begin() + static_cast<std::ptrdiff_t>(j.end);
      // Split into the fewest tiles that respect the bound, as evenly as possible: a tile count m
      // splits m / 2 : m - m / 2 (not always in halves, which would leave tiles at half the bound).
      const std::size_t m = std::max<std::size_t>(
          {2, (count + max_core - 1) / max_core, (load + max_load - 1) / max_load});
      const std::size_t k = j.begin + count * (m / 2) / m;
      // The sample at rank k (by coordinate, then index: a total order, so the same sample
      // whatever the algorithm); a selection, not a sort: linear in the part's size.
      std::nth_element(first, items.begin() + static_cast<std::ptrdiff_t>(k), last, [&](const Item& x, const Item& y) {
        return x.p[a] < y.p[a] || (x.p[a] == y.p[a] && x.id < y.id);
      });
      value = items[k].p[a];
      // Everything below `value` goes left.
      mid = static_cast<std::size_t>(
          std::partition(first, last, [&](const Item& x) { return x.p[a] < value; }) - items.begin());
      if (mid == j.begin)
      {
        // The lower part is one value: split just above it instead.
        mid = static_cast<std::size_t>(
            std::partition(first, last, [&](const Item& x) { return x.p[a] <= value; }) - items.begin());
        if (mid == j.end)
          split = false;
        else
        {
          value = inf;
          for (std::size_t i = mid; i < j.end; ++i)
            value = std::min(value, items[i].p[a]);
        }
      }
    }
    KdNode& node = tree.nodes[static_cast<std::size_t>(j.node)];
    if (!split)
    {
      node.tile = static_cast<int>(tree.tiles.size());
      Tile t;
      t.lo = j.lo;
      t.hi = j.hi;
      t.core_points = count;
      t.halo_points = j.reach.size();
      tree.tiles.push_back(t);
      continue;
    }
    node.axis = axis;
    node.split = value;
    node.left = static_cast<int>(tree.nodes.size());
    node.right = node.left + 1;
    tree.nodes.push_back({});
    tree.nodes.push_back({});
    const std::size_t a = static_cast<std::size_t>(axis);
    Job left{tree.nodes[static_cast<std::size_t>(j.node)].left, j.begin, mid, j.lo, j.hi, {}, {}, {}};
    Job right{tree.nodes[static_cast<std::size_t>(j.node)].right, mid, j.end, j.lo, j.hi, {}, {}, {}};
    left.hi[a] = value;
    right.lo[a] = value;
    extent(left.begin, left.end, left.slo, left.shi);
    extent(right.begin, right.end, right.slo, right.shi);
    left.reach = reachOf(left, j, mid, j.end);
    right.reach = reachOf(right, j, j.begin, mid);
    jobs.push_back(std::move(right));
    jobs.push_back(std::move(left));
  }
  return tree;
}

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

void savePlan(const Paths& paths, const Plan& plan)
{
  std::ostringstream os;
  os << std::setprecision(17);
  os << plan.fingerprint << '\n'
     << plan.input_points << ' ' << plan.finite_points << '\n'
     << plan.lo.x() << ' ' << plan.lo.y() << ' ' << plan.lo.z() << ' ' << plan.hi.x() << ' ' << plan.hi.y()
     << ' ' << plan.hi.z() << '\n'
     << plan.axis_u << ' ' << plan.axis_v << ' ' << plan.halo << ' ' << plan.tile_point_budget << '\n'
     << plan.tree.nodes.size() << '\n';
  for (const KdNode& n : plan.tree.nodes)
    os << n.axis << ' ' << n.split << ' ' << n.left << ' ' << n.right << ' ' << n.tile << '\n';
  os << plan.tree.tiles.size() << '\n';
  for (const Tile& t : plan.tree.tiles)
    os << t.lo[0] << ' ' << t.lo[1] << ' ' << t.hi[0] << ' ' << t.hi[1] << ' ' << t.core_points << ' '
       << t.halo_points << '\n';
  os << plan.parts << '\n';
  for (const auto& counts : plan.part_core)
  {
    for (const std::uint64_t c : counts)
      os << c << ' ';
    os << '\n';
  }
  const std::string text = os.str();
  writeFileAtomic(paths.plan(), text.data(), text.size());
}

bool loadPlan(const Paths& paths, const std::string& fingerprint, Plan& plan)
{
  std::ifstream f(paths.plan());
  if (!f)
    return false;
  std::string line;
  if (!std::getline(f, line) || line != fingerprint)
    return false;
  plan.fingerprint = line;
  // Numbers through strtod: operator>> does not read back "inf" (the outer tiles' edges).
  bool ok = true;
  auto num = [&]() -> double {
    std::string token;
    if (!(f >> token))
    {
      ok = false;
      return 0.0;
    }
    char* end = nullptr;
    const double v = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0')
      ok = false;
    return v;
  };
  auto count = [&]() { return static_cast<std::uint64_t>(num()); };
  auto integer = [&]() { return static_cast<int>(num()); };
  plan.input_points = count();
  plan.finite_points = count();
  for (int a = 0; a < 3; ++a)
    plan.lo[a] = num();
  for (int a = 0; a < 3; ++a)
    plan.hi[a] = num();
  plan.axis_u = integer();
  plan.axis_v = integer();
  plan.halo = num();
  plan.tile_point_budget = count();
  const std::uint64_t nodes = count();
  if (!ok || nodes > 10000000)
    return false;
  plan.tree.nodes.resize(nodes);
  for (KdNode& n : plan.tree.nodes)
  {
    n.axis = integer();
    n.split = num();
    n.left = integer();
    n.right = integer();
    n.tile = integer();
  }
  const std::uint64_t tiles = count();
  if (!ok || tiles > 10000000)
    return false;
  plan.tree.tiles.resize(tiles);
  for (Tile& t : plan.tree.tiles)
  {
    t.lo[0] = num();
    t.lo[1] = num();
    t.hi[0] = num();
    t.hi[1] = num();
    t.core_points = count();
    t.halo_points = count();
  }
  plan.parts = integer();
  if (!ok || plan.parts < 1 || plan.parts > 4096)
    return false;
  plan.part_core.assign(tiles, std::vector<std::uint64_t>(static_cast<std::size_t>(plan.parts)));
  for (std::size_t t = 0; t < tiles; ++t)
  {
    std::uint64_t sum = 0;
    for (std::uint64_t& c : plan.part_core[t])
      sum += c = count();
    ok = ok && sum == plan.tree.tiles[t].core_points;
  }
  return ok;
}

/// A file's size and modification time: what the fingerprint records of the input, and what the
/// split checks has not changed since the scan.
struct FileStamp
{
  std::uintmax_t size = 0;
  fs::file_time_type::rep mtime = 0;
  bool known = false;  ///< both could be read
  bool same(const FileStamp& o) const { return known && o.known && size == o.size && mtime == o.mtime; }
};

FileStamp stampOf(const fs::path& file)
{
  std::error_code size_error, time_error;
  FileStamp s;
  s.size = fs::file_size(file, size_error);
  s.mtime = fs::last_write_time(file, time_error).time_since_epoch().count();
  s.known = !size_error && !time_error;
  return s;
}

std::string fingerprintOf(const std::vector<std::string>& inputs, const Parameters& p, std::uint64_t memory_limit)
{
  std::ostringstream os;
  os << std::setprecision(17) << "v" << kFormatVersion;
  for (const std::string& input : inputs)
  {
    std::error_code ec;
    const FileStamp stamp = stampOf(input);
    os << " in=" << fs::absolute(input, ec).string() << " size=" << stamp.size << " mtime=" << stamp.mtime;
  }
  os << " terr=" << p.error_threshold << " alpha=" << p.feature_factor
     << " k=" << p.k_neighbors << " form=" << toString(p.error_form) << " adaptive=" << p.adaptive
     << " af=" << p.adaptive_factor << " cap=" << p.radius_cap_factor << " rep=" << p.max_representative_offset
     << " repcut=" << p.representative_cutoff << " rough=" << p.max_roughness
     << " gap=" << p.max_gap_factor
     << " seed=" << p.seed << " mem=" << memory_limit;
  return os.str();
}

/// A fixed pseudo-random choice per point: the planning sample does not depend on chunking.
bool inSample(std::uint64_t gid, double fraction)
{
  if (fraction >= 1.0)
    return true;
  SplitMix64 rng(gid ^ 0x5eed5eed5eedull);
  return static_cast<double>(rng.next() >> 11) * 0x1.0p-53 < fraction;
}

/// Runs fn(tile) for every tile in `tiles` on `workers` threads; the first exception wins.
void forEachTile(const std::vector<int>& tiles, int workers, const std::function<void(int)>& fn)
{
  std::atomic<std::size_t> next{0};
  std::mutex m;
  std::exception_ptr error;
  auto work = [&]() {
    for (;;)
    {
      {
        std::lock_guard<std::mutex> lock(m);
        if (error)
          return;
      }
      const std::size_t i = next++;
      if (i >= tiles.size())
        return;
      try
      {
        fn(tiles[i]);
      }
      catch (...)
      {
        std::lock_guard<std::mutex> lock(m);
        if (!error)
          error = std::current_exception();
        return;
      }
    }
  };
  std::vector<std::thread> pool;
  for (int w = 1; w < std::min<int>(workers, static_cast<int>(tiles.size())); ++w)
    pool.emplace_back(work);
  work();
  for (auto& t : pool)
    t.join();
  if (error)
    std::rethrow_exception(error);
}

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
  /// A binary PCD in a regular file is read again by the split; anything else is copied to scratch
  /// once.
  bool readTwice() const { return records_in_input_; }
  void split();
  TileData loadTile(int t) const;
  void phaseA(int t);
  void phaseB(int t);
  void phaseC(int t);
  void phaseD(int t);
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
  double delta_ = 0.0, mean_spacing_ = 0.0, mean_abs_h_ = 0.0, neighborhood_radius_ = 0.0, cap_ = 0.0;
  Eigen::Vector3d viewpoint_local_ = Eigen::Vector3d::Zero();
  std::array<int, 3> normal_fields_{{-1, -1, -1}};  // normal_x/y/z in the records, -1: absent
};

void Runner::scanAndPlan(io::RecordSource& reader)
{
  const auto t0 = Clock::now();
  header_ = reader.header();
  const io::XyzAccess xyz(header_);
  const std::size_t step = header_.point_step;
  // The sample fits half of what the limit leaves beside the process itself.
  const std::size_t sample_target = std::max<std::size_t>(
      kMinSample, std::min<std::size_t>(kSampleTarget, static_cast<std::size_t>(0.5 * usableBytes() / kPlanBytesPerSample)));
  const double fraction = std::min(1.0, static_cast<double>(sample_target) / std::max<double>(1.0, static_cast<double>(header_.points)));
  std::vector<Eigen::Vector3d> sample;
  sample.reserve(std::min<std::uint64_t>(header_.points, sample_target + sample_target / 10));
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  std::vector<std::uint8_t> chunk;
  // A binary input is read again by the split, straight from its records (two reads of the input
  // are less I/O than a read, a copy written to scratch and its read). An ASCII or compressed one
  // is parsed once: its finite points go to scratch as they come (with their input index), and
  // the split reads them from there; the input is not opened again. So is any input that is not
  // a regular file (a pipe, a FIFO): it can be read only once.
  const bool copy_points = !readTwice();
  const std::string copy_tmp = paths_.points().string() + ".tmp";
  std::ofstream copy;
  if (copy_points)
  {
    copy.open(copy_tmp, std::ios::binary | std::ios::trunc);
    if (!copy)
      failRun("cannot create " + copy_tmp);
  }
  std::vector<std::uint8_t> out;
  if (copy_points)
    out.reserve(kChunk * (8 + step));
  std::uint64_t gid = 0, finite = 0;
  std::size_t n;
  while ((n = reader.read(kChunk, chunk)) > 0)
  {
    out.clear();
    for (std::size_t i = 0; i < n; ++i, ++gid)
    {
      double x, y, z;
      const std::uint8_t* rec = chunk.data() + i * step;
      xyz.get(rec, x, y, z);
      if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
        continue;
      if (copy_points)
      {
        const auto* g = reinterpret_cast<const std::uint8_t*>(&gid);
        out.insert(out.end(), g, g + 8);
        out.insert(out.end(), rec, rec + step);
      }
      ++finite;
      const Eigen::Vector3d p(x, y, z);
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
      if (inSample(gid, fraction))
        sample.push_back(p);
    }
    if (copy_points)
    {
      copy.write(reinterpret_cast<const char*>(out.data()), static_cast<std::streamsize>(out.size()));
      if (!copy)
        failRun("cannot write " + copy_tmp + " (disk full?)");
    }
    if ((gid & ((1u << 22) - 1)) < kChunk)
    {
      std::ostringstream os;
      os << "scan: " << gid << " / " << header_.points << " points read";
      report(os.str());
    }
  }
  if (copy_points)
  {
    copy.close();
    if (!copy)
      failRun("cannot write " + copy_tmp + " (disk full?)");
    fs::rename(copy_tmp, paths_.points());
  }
  plan_.input_points = header_.points;
  plan_.finite_points = finite;
  plan_.lo = lo;
  plan_.hi = hi;
  const int k = params_.k_neighbors;
  if (finite <= static_cast<std::uint64_t>(k) || sample.size() <= static_cast<std::size_t>(k))
  {
    std::ostringstream os;
    os << input_ << ": only " << finite << " finite points; the neighbourhood size K = " << k << " needs at least "
       << k + 1;
    failRun(os.str());
  }
  // The tiles live in the plane of the two longest axes.
  const Eigen::Vector3d ext = hi - lo;
  int order[3] = {0, 1, 2};
  std::sort(order, order + 3, [&](int a, int b) { return ext[a] > ext[b] || (ext[a] == ext[b] && a < b); });
  plan_.axis_u = std::min(order[0], order[1]);
  plan_.axis_v = std::max(order[0], order[1]);
  if (!(ext[order[1]] > 0.0))
    failRun(input_ + ": all points lie on one line: there is no surface to simplify");
  if (!(ext.maxCoeff() > 1e-30))
    failRun(input_ + ": the cloud's extent (" + std::to_string(ext.maxCoeff()) + ") is too small for float precision");

  // Neighbourhood size from the sample: the j-th sample neighbour at distance r_j means the K-th
  // neighbour of the full cloud at about r_j sqrt(K f / j) (a surface: counts grow with r²).
  const int threads = resolveThreads(params_.threads);
  // At most kSpacingSample points of the sample serve this estimate: a sparser one gives the same
  // through the scaling below, for a fraction of the search (every `every`-th, in input order).
  constexpr std::size_t kSpacingSample = 200000;
  const std::size_t every = (sample.size() + kSpacingSample - 1) / kSpacingSample;
  const double spacing_fraction = fraction / static_cast<double>(every);
  // That sample in Hilbert order behind the box tree (built in one parallel pass); the queries
  // below return distances only, which do not depend on the order or the back end.
  std::vector<int> morton;
  morton.reserve(sample.size() / every + 1);
  for (std::size_t i = 0; i < sample.size(); i += every)
    morton.push_back(static_cast<int>(i));
  std::vector<std::uint64_t> codes;
  const auto sample_at = [&](int i) { return sample[static_cast<std::size_t>(i)]; };
  sortBySpatialCode(morton, sample_at, lo, hi, threads, &codes);
  // Coincident points are merged before neighbourhoods (as the tiles do): they are left out here,
  // where thousands at one spot would cost a search each over all of them and say nothing of the
  // spacing.
  std::vector<std::uint8_t> coincident(sample.size(), 0);
  for (const auto& merged : removeCoincident(morton, codes, sample_at))
    coincident[static_cast<std::size_t>(merged.first)] = 1;
  auto toLocal = [&](const Eigen::Vector3d& p) {
    pcl::PointXYZ q;
    q.getVector3fMap() = plan_.toLocal(p).cast<float>();
    return q;
  };
  auto local = std::make_shared<LocalCloud>();
  local->resize(morton.size());
  for (std::size_t i = 0; i < morton.size(); ++i)
    (*local)[i] = toLocal(sample[static_cast<std::size_t>(morton[i])]);
  if (morton.size() <= static_cast<std::size_t>(k))
    failRun(input_ + ": only " + std::to_string(morton.size()) + " distinct points in the planning sample; K = " +
            std::to_string(k) + " needs more");
  BoxTreeSearch tree(/*sorted=*/false, threads);
  tree.setInputCloud(local);
  const int j = spacing_fraction >= 1.0 ? k : std::min<int>(8, static_cast<int>(morton.size()) - 1);
  const double scale = spacing_fraction >= 1.0 ? 1.0 : std::sqrt(static_cast<double>(k) * spacing_fraction / j);
  // Every stride-th point of that sample is asked (at most ~25k queries: enough for the mean and
  // the 99.9th percentile below).
  const std::size_t spaced = (sample.size() + every - 1) / every;
  const std::size_t stride = std::max<std::size_t>(1, spaced / 25000) * every;
  std::vector<double> rk((sample.size() + stride - 1) / stride);
#pragma omp parallel num_threads(threads)
  {
    pcl::Indices idx;
    std::vector<float> d2;
#pragma omp for schedule(static)
    for (std::ptrdiff_t q = 0; q < static_cast<std::ptrdiff_t>(rk.size()); ++q)
    {
      const std::size_t at = static_cast<std::size_t>(q) * stride;
      if (coincident[at])
      {
        rk[static_cast<std::size_t>(q)] = -1.0;  // not asked
        continue;
      }
      tree.nearestKSearch(toLocal(sample[at]), j + 1, idx, d2);
      rk[static_cast<std::size_t>(q)] =
          d2.empty() ? 0.0 : std::sqrt(static_cast<double>(d2.back())) * scale / plan_.scale();  // world units
    }
  }
  rk.erase(std::remove(rk.begin(), rk.end(), -1.0), rk.end());
  if (rk.empty())
    failRun(input_ + ": every point of the planning sample lies at the place of another");
  double mean_rk = 0.0;
  for (double r : rk)
    mean_rk += r;
  mean_rk /= static_cast<double>(rk.size());
  std::vector<double> sorted = rk;
  const std::size_t q = std::min(sorted.size() - 1, static_cast<std::size_t>(0.999 * static_cast<double>(sorted.size())));
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(q), sorted.end());
  const double rk_high = sorted[q];
  // The radius unit (eq. 1: RMS distance to the K neighbours) is about 0.7 r_K on a surface.
  const double cap_estimate = params_.radius_cap_factor * 0.75 * mean_rk;
  // A ball (radius <= cap) centred in a tile reaches cap into the halo; the values of its members
  // need their neighbours' neighbours (about 3 r_K further) to be exact.
  plan_.halo = 1.25 * cap_estimate + 3.0 * rk_high;

  // Tile size: a tile and its halo must fit the budget of one of kConcurrentTiles workers.
  const double budget = 0.7 * usableBytes() / kConcurrentTiles;
  plan_.tile_point_budget = options_.max_tile_points > 0
                                ? options_.max_tile_points
                                : static_cast<std::uint64_t>(std::max(static_cast<double>(kMinTilePoints),
                                                                      budget / tileBytesPerPoint(step)));
  std::vector<std::array<double, 2>> sample2(sample.size());
  for (std::size_t i = 0; i < sample.size(); ++i)
    sample2[i] = {sample[i][plan_.axis_u], sample[i][plan_.axis_v]};
  // Tiles of even size whose load (core + halo) is close to the budget: a first tree with a core
  // of 0.8 × the budget gives the typical halo share (the median of load / core over its tiles);
  // the second has cores of 0.95 × the budget over that share, and any tile whose halo still
  // makes it too large (thin tiles, dense neighbours) is split further on its own. The peak memory
  // (two tiles near the budget) then follows the limit, not the input's size or shape.
  const double per_sample = 1.0 / fraction;
  const double max_load = 0.97 * static_cast<double>(plan_.tile_point_budget) / per_sample;
  auto samples = [](double n) { return std::max<std::size_t>(1, static_cast<std::size_t>(n)); };
  plan_.tree = buildTileTree(sample2, samples(0.8 * max_load), samples(max_load), plan_.halo);
  std::vector<double> share;
  for (const Tile& t : plan_.tree.tiles)
    if (t.core_points > 0)
      share.push_back(static_cast<double>(t.core_points + t.halo_points) / static_cast<double>(t.core_points));
  if (!share.empty())
  {
    std::nth_element(share.begin(), share.begin() + static_cast<std::ptrdiff_t>(share.size() / 2), share.end());
    const double typical = std::max(1.0, share[share.size() / 2]);
    plan_.tree = buildTileTree(sample2, samples(0.95 * max_load / typical), samples(max_load), plan_.halo);
  }
  double worst = 0.0;
  for (const Tile& t : plan_.tree.tiles)
    worst = std::max(worst, per_sample * static_cast<double>(t.core_points + t.halo_points));
  if (worst > static_cast<double>(plan_.tile_point_budget))
  {
    // The halo alone fills a tile: the run cannot keep to the limit. Say so before any work.
    const double need = worst / 0.97;
    if (options_.max_tile_points > 0)
      throw LimitError("--tile-points " + std::to_string(options_.max_tile_points) +
                       " is too small for this input: its halo (" + std::to_string(plan_.halo) +
                       ", from its spacing) puts about " + std::to_string(static_cast<std::uint64_t>(worst)) +
                       " points in a tile; use at least --tile-points " + std::to_string(static_cast<std::uint64_t>(need)));
    const double usable = kConcurrentTiles * need * tileBytesPerPoint(step) / 0.7;
    const std::uint64_t limit = baseline_bytes_ + static_cast<std::uint64_t>(usable);
    throw LimitError("--memory-limit " + std::to_string(memory_limit_ >> 20) +
                     "M is below what this input needs: its halo (" + std::to_string(plan_.halo) +
                     ", from its spacing) puts about " + std::to_string(static_cast<std::uint64_t>(worst)) +
                     " points in a tile; use at least " + suggestedLimit(limit));
  }
  summary_.stage_seconds[0] = secondsSince(t0);
  std::ostringstream os;
  os << "plan: " << finite << " finite points, " << plan_.tree.tiles.size() << " tile(s) of at most "
     << plan_.tile_point_budget << " points with halo " << plan_.halo << " (scan " << std::fixed
     << std::setprecision(1) << summary_.stage_seconds[0] << " s)";
  report(os.str());
}

void Runner::split()
{
  const auto t0 = Clock::now();
  const io::XyzAccess xyz(header_);
  const std::size_t step = header_.point_step;
  const std::size_t tiles = plan_.tree.tiles.size();
  // Where the finite points are: a binary input's own records (input index = record number,
  // the non-finite ones skipped again), else pass 1's copy (input index, record).
  const bool from_input = readTwice();
  const fs::path source = from_input ? fs::path(inputs_[0]) : paths_.points();
  const std::size_t record = from_input ? step : 8 + step;
  const std::uint64_t records = from_input ? plan_.input_points : plan_.finite_points;
  const std::uint64_t offset = from_input ? data_offset_ : 0;
  if (from_input)
  {
    // The scan's counts and bounds hold only for the file it read.
    const FileStamp now = stampOf(source);
    if (!now.same(input_stamp_))
      failRun(input_ + " changed while it was being read (its size or modification time); run again on a "
                       "file that stays as it is");
    if (now.size < offset + records * record)
      failRun(input_ + " is shorter than its header says");
  }
  fs::create_directories(paths_.root / "tiles");
  // The input in `parts` consecutive runs, one thread each; each run writes its own file per tile
  // core and halo, and a tile's files read in turn give its points in input order. Buffers: 64 MiB
  // in all at most. A run keeps two files a tile and the input open: no more runs than the
  // process may open files for (with a few to spare).
  const std::uint64_t files_per_run = 2 * tiles + 1, spare = 8;
  const std::uint64_t files = freeFileDescriptors();
  if (files < files_per_run + spare)
  {
    std::ostringstream os;
    os << "the split needs " << files_per_run + spare << " open files (two per tile, " << tiles
       << " tiles) but this process may open only " << files
       << " more: raise the limit (ulimit -n) or the memory limit (fewer, larger tiles)";
    failRun(os.str());
  }
  const int parts = static_cast<int>(std::max<std::uint64_t>(
      1, std::min({static_cast<std::uint64_t>(threads_), records / 8192, (files - spare) / files_per_run})));
  plan_.parts = parts;
  plan_.part_core.assign(tiles, std::vector<std::uint64_t>(static_cast<std::size_t>(parts), 0));
  std::vector<std::vector<std::uint64_t>> part_halo(tiles, std::vector<std::uint64_t>(static_cast<std::size_t>(parts), 0));
  std::vector<std::uint64_t> part_finite(static_cast<std::size_t>(parts), 0);
  // Write buffers: 64 MiB in all, or 40% of what the memory limit leaves if that is less.
  const double buffers = std::min(static_cast<double>(64u << 20), 0.4 * usableBytes());
  const std::size_t buffer = std::max<std::size_t>(
      4096, std::min<std::size_t>(1 << 20, static_cast<std::size_t>(buffers) / (2 * tiles * static_cast<std::size_t>(parts))));
  std::atomic<std::uint64_t> done{0};
  auto run = [&](int part) {
    const auto p = static_cast<std::size_t>(part);
    struct Sink
    {
      std::vector<char> buf;
      std::size_t used = 0;
      std::ofstream file;
      void put(const void* data, std::size_t bytes)
      {
        if (used + bytes > buf.size())
          flush();
        std::memcpy(buf.data() + used, data, bytes);
        used += bytes;
      }
      void flush()
      {
        file.write(buf.data(), static_cast<std::streamsize>(used));
        used = 0;
      }
    };
    std::vector<Sink> core(tiles), halo(tiles);
    for (std::size_t t = 0; t < tiles; ++t)
    {
      core[t].buf.resize(buffer);
      halo[t].buf.resize(buffer);
      core[t].file.rdbuf()->pubsetbuf(nullptr, 0);  // the sink buffers: no second buffer per file
      halo[t].file.rdbuf()->pubsetbuf(nullptr, 0);
      core[t].file.open(paths_.core(static_cast<int>(t), part).string() + ".tmp", std::ios::binary | std::ios::trunc);
      halo[t].file.open(paths_.halo(static_cast<int>(t), part).string() + ".tmp", std::ios::binary | std::ios::trunc);
      if (!core[t].file || !halo[t].file)
        failRun("cannot create the scratch files in " + (paths_.root / "tiles").string());
    }
    const std::uint64_t first = records * p / static_cast<std::uint64_t>(parts);
    const std::uint64_t last = records * (p + 1) / static_cast<std::uint64_t>(parts);
    std::ifstream in(source, std::ios::binary);
    if (!in || !in.seekg(static_cast<std::streamoff>(offset + first * record)))
      failRun("cannot read " + source.string());
    std::vector<std::uint8_t> chunk(kChunk * record);
    std::vector<int> near;
    std::uint64_t finite = 0;
    std::vector<std::uint64_t> own_count(tiles, 0), halo_count(tiles, 0);  // this part's
    for (std::uint64_t at = first; at < last;)
    {
      const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(kChunk, last - at));
      in.read(reinterpret_cast<char*>(chunk.data()), static_cast<std::streamsize>(n * record));
      if (static_cast<std::size_t>(in.gcount()) != n * record)
        failRun(source.string() + (from_input ? " changed while it was being read (it ended early)" : " is truncated"));
      for (std::size_t i = 0; i < n; ++i)
      {
        const std::uint8_t* rec = chunk.data() + i * record;
        std::uint64_t gid = at + i;
        if (!from_input)
        {
          std::memcpy(&gid, rec, 8);
          rec += 8;
        }
        double c[3];
        xyz.get(rec, c[0], c[1], c[2]);
        if (from_input && !(std::isfinite(c[0]) && std::isfinite(c[1]) && std::isfinite(c[2])))
          continue;  // the copy of pass 1 holds finite points only
        ++finite;
        const std::array<double, 2> pt{{c[plan_.axis_u], c[plan_.axis_v]}};
        near.clear();
        const int own = plan_.tree.locateAndNear(pt, plan_.halo, near);
        std::uint64_t& count = own_count[static_cast<std::size_t>(own)];
        // The index among the tile's own points found by this part; loadTile adds the earlier parts'.
        const std::uint32_t src[2] = {static_cast<std::uint32_t>(own), static_cast<std::uint32_t>(count)};
        if (++count >= std::numeric_limits<std::uint32_t>::max())
          failRun("a tile holds more than 4 billion points: raise --memory-limit less or split the input");
        core[static_cast<std::size_t>(own)].put(&gid, 8);
        core[static_cast<std::size_t>(own)].put(rec, step);
        for (int t : near)
          if (t != own)
          {
            Sink& s = halo[static_cast<std::size_t>(t)];
            ++halo_count[static_cast<std::size_t>(t)];
            s.put(&gid, 8);
            s.put(src, 8);
            s.put(rec, step);
          }
      }
      at += n;
      const std::uint64_t before = done.fetch_add(n);
      if ((before >> 22) != ((before + n) >> 22))
      {
        const double s = secondsSince(t0);
        std::ostringstream os;
        os << "split: " << before + n << " / " << records << " points, " << std::fixed << std::setprecision(2)
           << (s > 0 ? static_cast<double>(before + n) / s / 1e6 : 0.0) << " M points/s";
        report(os.str());
      }
    }
    part_finite[p] = finite;
    for (std::size_t t = 0; t < tiles; ++t)
    {
      plan_.part_core[t][p] = own_count[t];
      part_halo[t][p] = halo_count[t];
      core[t].flush();
      halo[t].flush();
      core[t].file.close();
      halo[t].file.close();
      if (!core[t].file || !halo[t].file)
        failRun("cannot write the scratch files in " + (paths_.root / "tiles").string() + " (disk full?)");
    }
  };
  std::vector<int> all(static_cast<std::size_t>(parts));
  std::iota(all.begin(), all.end(), 0);
  forEachTile(all, parts, run);
  std::uint64_t finite = 0;
  for (const std::uint64_t f : part_finite)
    finite += f;
  if (finite != plan_.finite_points)
    failRun(source.string() + (from_input ? " changed while it was being read: it holds another number of points"
                                          : " holds fewer points than the scan found"));
  for (std::size_t t = 0; t < tiles; ++t)
  {
    Tile& tile = plan_.tree.tiles[t];
    tile.core_points = tile.halo_points = 0;
    for (std::size_t p = 0; p < static_cast<std::size_t>(parts); ++p)
    {
      tile.core_points += plan_.part_core[t][p];
      tile.halo_points += part_halo[t][p];
    }
    if (tile.core_points + tile.halo_points >= std::numeric_limits<std::uint32_t>::max())
      failRun("a tile holds more than 4 billion points: raise --memory-limit less or split the input");
    for (int p = 0; p < parts; ++p)
    {
      fs::rename(paths_.core(static_cast<int>(t), p).string() + ".tmp", paths_.core(static_cast<int>(t), p));
      fs::rename(paths_.halo(static_cast<int>(t), p).string() + ".tmp", paths_.halo(static_cast<int>(t), p));
    }
  }
  savePlan(paths_, plan_);  // the split is complete once the plan exists
  std::error_code ec;
  fs::remove(paths_.points(), ec);  // the tiles hold every point now
  summary_.stage_seconds[1] = secondsSince(t0);
}

TileData Runner::loadTile(int t) const
{
  const std::size_t step = header_.point_step;
  const io::XyzAccess xyz(header_);
  // The parts of the split in turn. A halo record names its point's index among the points of
  // its own tile that the same part found: the earlier parts' counts come first.
  std::vector<std::uint8_t> core, halo;
  const auto& tile_parts = plan_.part_core;
  for (int p = 0; p < plan_.parts; ++p)
  {
    appendFile(paths_.core(t, p), core);
    const std::size_t first = halo.size();
    appendFile(paths_.halo(t, p), halo);
    if ((halo.size() - first) % (16 + step) != 0)
      failDamaged("the halo files of tile " + std::to_string(t) + " do not hold whole points");
    for (std::size_t at = first; at < halo.size(); at += 16 + step)
    {
      std::uint32_t src[2];
      std::memcpy(src, halo.data() + at + 8, 8);
      if (src[0] >= tile_parts.size())
        failDamaged("the halo files of tile " + std::to_string(t) + " name a tile that does not exist");
      for (int q = 0; q < p; ++q)
        src[1] += static_cast<std::uint32_t>(tile_parts[src[0]][static_cast<std::size_t>(q)]);
      std::memcpy(halo.data() + at + 12, &src[1], 4);
    }
  }
  const std::size_t nc = core.size() / (8 + step), nh = halo.size() / (16 + step);
  const Tile& tile = plan_.tree.tiles[static_cast<std::size_t>(t)];
  if (core.size() % (8 + step) != 0 || nc != tile.core_points || nh != tile.halo_points)
    failDamaged("the point files of tile " + std::to_string(t) + " do not hold the points the plan counted");
  const std::size_t n = nc + nh;
  auto at = [&](std::size_t i) -> const std::uint8_t* {
    return i < nc ? core.data() + i * (8 + step) : halo.data() + (i - nc) * (16 + step);
  };
  auto position = [&](std::size_t i) {
    Eigen::Vector3d p;
    xyz.get(at(i) + (i < nc ? 8 : 16), p.x(), p.y(), p.z());
    return p;
  };
  TileData d;
  // Sorted by Hilbert code in the global box, ties by input index: the same order for a point
  // whichever tile loads it, so neighbour ties break the same way everywhere. Phase A saves the
  // order it found; later loads of the tile read it instead of sorting again.
  if (fs::exists(paths_.order(t)))
  {
    // Saved as: the tile's point count, the count loaded (the others coincide with one), the order.
    d.order = readVector<std::uint32_t>(paths_.order(t));
    bool valid = d.order.size() >= 2 && d.order[0] == n && d.order[1] == d.order.size() - 2 && d.order[1] <= n;
    if (valid)
      d.order.erase(d.order.begin(), d.order.begin() + 2);
    std::vector<std::uint8_t> seen(n, 0);
    for (std::size_t o = 0; valid && o < d.order.size(); ++o)
    {
      valid = d.order[o] < n && !seen[d.order[o]];
      if (valid)
        seen[d.order[o]] = 1;
    }
    if (!valid)
      failDamaged("the saved point order of tile " + std::to_string(t) + " does not match its points");
  }
  else
  {
    // The (code, input index) pairs are distinct (input indices are): one order.
    struct Key
    {
      std::uint64_t code, gid;
      std::uint32_t at;
    };
    std::vector<Key> keys(n);
    std::vector<Eigen::Vector3d> pos(n);  // by file order
    for (std::size_t i = 0; i < n; ++i)
    {
      std::uint64_t gid;
      std::memcpy(&gid, at(i), 8);
      pos[i] = position(i);
      keys[i] = {0, gid, static_cast<std::uint32_t>(i)};
    }
    {
      std::vector<std::uint64_t> codes(n);
      // On the grid the in-memory filter orders the whole cloud on: one tile gives its run exactly.
      spatialCodes(pos.data(), n, plan_.lo, plan_.hi, codes.data(),
                   spatialOrderBits(static_cast<std::size_t>(plan_.finite_points)));  // several points per instruction
      for (std::size_t i = 0; i < n; ++i)
        keys[i].code = codes[i];
    }
    radixSortThenTies(keys, [](const Key& k) { return k.code; },
                      [](const Key& a, const Key& b) { return a.gid < b.gid; });
    // Coincident points (to the rounding of the input's coordinates), as in the filter: one of each
    // group stands for it, the others are not loaded. A group has one position, so every tile that holds it, as
    // its own or in its halo, holds all of it and keeps the same point.
    std::vector<int> ids(n);
    std::vector<std::uint64_t> sorted_codes(n);
    for (std::size_t o = 0; o < n; ++o)
    {
      ids[o] = static_cast<int>(o);
      sorted_codes[o] = keys[o].code;
    }
    const int fx = header_.fieldIndex("x");
    const bool float_xyz = fx >= 0 && header_.fields[static_cast<std::size_t>(fx)].datatype != pcl::PCLPointField::FLOAT64;
    removeCoincident(ids, sorted_codes, [&](int o) { return pos[keys[static_cast<std::size_t>(o)].at]; },
                     coincidenceTolerance(plan_.lo, plan_.hi, float_xyz, plan_.finite_points));
    d.order.resize(ids.size());
    for (std::size_t o = 0; o < ids.size(); ++o)
      d.order[o] = keys[static_cast<std::size_t>(ids[o])].at;
  }
  for (const std::uint32_t i : d.order)
    d.merged_core += i < nc ? 1 : 0;
  d.merged_core = nc - d.merged_core;
  const std::size_t m = d.order.size();
  d.file_points = n;
  d.cloud->resize(m);
  d.gid.resize(m);
  d.src_tile.resize(m);
  d.src_index.resize(m);
  d.is_core.resize(m);
  d.records.resize(m * step);
  const Eigen::Vector3d origin = plan_.origin();
  const double scale = plan_.scale();
  constexpr std::size_t kAhead = 8;  // records fetched ahead: the gather's reads are scattered
  for (std::size_t o = 0; o < m; ++o)
  {
    if (o + kAhead < m)
      __builtin_prefetch(at(d.order[o + kAhead]));
    const std::size_t i = d.order[o];
    const std::uint8_t* r = at(i);
    // From the record, which is fetched ahead (a position kept from the sort would be one more
    // scattered read).
    (*d.cloud)[o].getVector3fMap() = ((position(i) - origin) * scale).cast<float>();  // plan_.toLocal
    std::memcpy(&d.gid[o], r, 8);
    d.is_core[o] = i < nc;
    if (i < nc)
    {
      d.src_tile[o] = static_cast<std::uint32_t>(t);
      d.src_index[o] = static_cast<std::uint32_t>(i);
      std::memcpy(d.records.data() + o * step, r + 8, step);
    }
    else
    {
      std::memcpy(&d.src_tile[o], r + 8, 4);
      std::memcpy(&d.src_index[o], r + 12, 4);
      std::memcpy(d.records.data() + o * step, r + 16, step);
    }
  }
  return d;
}

/// The per-point values of phase A, packed.
struct AttrView
{
  const std::vector<std::uint8_t>& bytes;
  Eigen::Vector3f normal(std::size_t i) const
  {
    Eigen::Vector3f n;
    std::memcpy(n.data(), bytes.data() + i * kAttrBytes, 12);
    return n;
  }
  double value(std::size_t i, int which) const  // 0 weight, 1 measure, 2 curvature
  {
    double v;
    std::memcpy(&v, bytes.data() + i * kAttrBytes + 12 + 8 * which, 8);
    return v;
  }
  std::size_t size() const { return bytes.size() / kAttrBytes; }
  /// Eq. 4 with the global δ: the measure above δ.
  std::vector<std::uint8_t> features(double delta) const
  {
    std::vector<double> measure(size());
    for (std::size_t i = 0; i < measure.size(); ++i)
      measure[i] = value(i, 1);
    std::vector<std::uint8_t> is_feature;
    classifyFeatures(measure, delta, is_feature);
    return is_feature;
  }
};

void Runner::phaseA(int t)
{
  TileData d = loadTile(t);
  const std::size_t n = d.size();
  const int k = params_.k_neighbors;
  if (n <= static_cast<std::size_t>(k))
    failRun("tile " + std::to_string(t) + " holds only " + std::to_string(n) + " points; K = " + std::to_string(k));
  BoxTreeSearch tree(/*sorted=*/false, tile_threads_);  // unsorted radius results; a tile is in Hilbert order
  tree.setInputCloud(d.cloud);
  NeighborhoodTable table;
  computeNeighborhoods(*d.cloud, tree, k, tile_threads_, table);
  NormalList normals;
  estimateNormals(*d.cloud, table, tile_threads_, normals);
  std::vector<double> weights, measure, curvature;
  computeDensityWeights(*d.cloud, table, weights, tile_threads_);
  computeFeatureMeasure(*d.cloud, normals, table, tile_threads_, measure);
  // Eq. 7-11 only for the own points: |H| enters through the centre's tolerance (step 5) and the
  // mean over all points, and centres are own points.
  std::vector<std::uint8_t> skip(n);
  for (std::size_t i = 0; i < n; ++i)
    skip[i] = d.is_core[i] ? 0 : 1;
  computeMeanCurvature(*d.cloud, normals, table, skip, tile_threads_, curvature);
  std::vector<std::uint8_t> attr(n * kAttrBytes);
  // Sums over this tile's own points (each point counted once in all): Σ measure, count,
  // neighbourhoods that reach past the halo.
  const Tile& tile = plan_.tree.tiles[static_cast<std::size_t>(t)];
  std::vector<double> sums(4, 0.0);
  sums[3] = static_cast<double>(d.merged_core);
  for (std::size_t i = 0; i < n; ++i)
  {
    std::uint8_t* a = attr.data() + i * kAttrBytes;
    std::memcpy(a, normals[i].data(), 12);
    std::memcpy(a + 12, &weights[i], 8);
    std::memcpy(a + 20, &measure[i], 8);
    std::memcpy(a + 28, &curvature[i], 8);
    if (!d.is_core[i])
      continue;
    sums[0] += measure[i];
    sums[1] += 1.0;
    const Eigen::Vector3d p = plan_.toWorld((*d.cloud)[i].getVector3fMap().cast<double>());
    const double u = p[plan_.axis_u], v = p[plan_.axis_v];
    const double room = std::min({u - (tile.lo[0] - plan_.halo), (tile.hi[0] + plan_.halo) - u,
                                  v - (tile.lo[1] - plan_.halo), (tile.hi[1] + plan_.halo) - v});
    if (std::sqrt(static_cast<double>(sqrDistance(*d.cloud, i, static_cast<std::size_t>(table.neighbors(i)[k - 1])))) >
        room * plan_.scale())
      sums[2] += 1.0;
  }
  // Eq. 5 is the distance to the nearest non-feature neighbour, and which neighbours are features
  // depends on δ, known only when every tile has passed this phase. Keep, for each own point, the
  // neighbours whose measure is below that of every nearer one: for any δ the first non-feature
  // neighbour is among them, so phase B needs neither the points nor a search.
  // Entries: the neighbour's squared distance (f32) and its index in the tile (its measure is in
  // the attributes, halo points' too), 8 bytes each after a count byte per point.
  // A list can stop at a neighbour whose measure is at most a lower bound of δ: that one is not a
  // feature whatever δ turns out to be. The bound: α × the measure summed over the tiles done so
  // far (in this run) over the count of all points, since measures are >= 0 (with a margin for the
  // summation order). Which tiles are done first changes the lists, never what phase B finds in
  // them.
  double not_feature = 0.0;
  {
    std::lock_guard<std::mutex> lock(measure_done_mutex_);
    not_feature = (1.0 - 1e-9) * params_.feature_factor * measure_done_ /
                  static_cast<double>(std::max<std::uint64_t>(1, plan_.finite_points));
  }
  std::vector<std::uint8_t> front_count(n, 0xFF);  // 0xFF: a halo point (not needed)
  std::vector<std::uint8_t> front;
  front.reserve(n * 2 * 8);
  for (std::size_t i = 0; i < n; ++i)
  {
    if (!d.is_core[i])
      continue;
    const int* nb = table.neighbors(i);
    double lowest = std::numeric_limits<double>::infinity();
    std::uint8_t count = 0;
    for (int j = 0; j < k; ++j)
    {
      const auto q = static_cast<std::size_t>(nb[j]);
      const double m = measure[q];
      if (!(m < lowest))
        continue;
      lowest = m;
      const float d2 = sqrDistance(*d.cloud, i, q);
      const auto index = static_cast<std::uint32_t>(q);
      const std::size_t at = front.size();
      front.resize(at + 8);
      std::memcpy(front.data() + at, &d2, 4);
      std::memcpy(front.data() + at + 4, &index, 4);
      ++count;
      if (m <= not_feature)
        break;
    }
    front_count[i] = count;
  }
  front_count.insert(front_count.end(), front.begin(), front.end());
  fs::create_directories(paths_.root / "a");
  writeVectorAtomic(paths_.frontier(t), front_count);
  {
    // The tile's point count and the count loaded first: loadTile checks the order against both.
    std::vector<std::uint32_t> saved{static_cast<std::uint32_t>(d.file_points), static_cast<std::uint32_t>(d.order.size())};
    saved.insert(saved.end(), d.order.begin(), d.order.end());
    writeVectorAtomic(paths_.order(t), saved);
  }
  writeVectorAtomic(paths_.attr(t), attr);
  writeVectorAtomic(paths_.sumA(t), sums);  // the marker: written last
  std::lock_guard<std::mutex> lock(measure_done_mutex_);
  measure_done_ += sums[0];
}

void Runner::phaseB(int t)
{
  const auto attr_bytes = readVector<std::uint8_t>(paths_.attr(t));
  const AttrView attr{attr_bytes};
  const std::size_t n = attr.size();
  std::vector<double> density(n, 0.0);
  // Σ dens, Σ sqrt(a), Σ |H|, non-feature count, feature count (own points), 1 if the tile was
  // loaded for a search
  std::vector<double> sums(6, 0.0);
  {
    // From the neighbour lists of phase A; a point whose K neighbours are all features needs a
    // search over the non-feature points: then the tile is loaded (below).
    const auto front = readVector<std::uint8_t>(paths_.frontier(t));
    const std::string lists_damaged =
        "the neighbour lists of tile " + std::to_string(t) + " do not match its points";
    if (front.size() < n)
      failDamaged(lists_damaged);
    std::size_t at = n;
    bool complete = true;
    for (std::size_t i = 0; i < n && complete; ++i)
    {
      const std::uint8_t count = front[i];
      if (count == 0xFF)
        continue;  // a halo point
      const bool feature = attr.value(i, 1) > delta_;
      bool found = feature;
      for (std::uint8_t e = 0; e < count; ++e, at += 8)
      {
        if (found)
          continue;
        if (at + 8 > front.size())
          failDamaged(lists_damaged);
        float d2;
        std::uint32_t index;
        std::memcpy(&d2, front.data() + at, 4);
        std::memcpy(&index, front.data() + at + 4, 4);
        if (index >= n)
          failDamaged(lists_damaged);
        if (!(attr.value(index, 1) > delta_))
        {
          density[i] = std::sqrt(static_cast<double>(d2));
          found = true;
        }
      }
      if (!found)
        complete = false;
      else if (feature)
        sums[4] += 1.0;
      else
      {
        sums[0] += density[i];
        sums[1] += std::sqrt(attr.value(i, 0));
        sums[2] += std::abs(attr.value(i, 2));
        sums[3] += 1.0;
      }
    }
    if (complete)
    {
      fs::create_directories(paths_.root / "b");
      writeVectorAtomic(paths_.dens(t), density);
      writeVectorAtomic(paths_.sumB(t), sums);
      dropScratch({paths_.frontier(t)});
      return;
    }
  }
  TileData d = loadTile(t);
  const std::vector<std::uint8_t> is_feature = attr.features(delta_);
  BoxTreeSearch tree(/*sorted=*/false, tile_threads_);  // unsorted radius results; a tile is in Hilbert order
  tree.setInputCloud(d.cloud);
  NeighborhoodTable table;
  computeNeighborhoods(*d.cloud, tree, params_.k_neighbors, tile_threads_, table);
  computeLocalDensity(*d.cloud, table, is_feature, tree, tile_threads_, density);
  std::fill(sums.begin(), sums.end(), 0.0);
  sums[5] = 1.0;
  for (std::size_t i = 0; i < n; ++i)
  {
    if (!d.is_core[i])
      continue;
    if (is_feature[i])
    {
      sums[4] += 1.0;
      continue;
    }
    sums[0] += density[i];
    sums[1] += std::sqrt(attr.value(i, 0));
    sums[2] += std::abs(attr.value(i, 2));
    sums[3] += 1.0;
  }
  fs::create_directories(paths_.root / "b");
  writeVectorAtomic(paths_.dens(t), density);
  writeVectorAtomic(paths_.sumB(t), sums);
  dropScratch({paths_.frontier(t)});
}

void Runner::phaseC(int t)
{
  TileData d = loadTile(t);
  const std::size_t n = d.size();
  const std::size_t step = header_.point_step;
  const auto attr_bytes = readVector<std::uint8_t>(paths_.attr(t));
  const AttrView attr{attr_bytes};
  const auto density = readVector<double>(paths_.dens(t));
  NormalList normals(n);
  std::vector<double> weights(n), curvature(n);
  for (std::size_t i = 0; i < n; ++i)
  {
    normals[i] = attr.normal(i);
    weights[i] = attr.value(i, 0);
    curvature[i] = attr.value(i, 2);
  }
  const std::vector<std::uint8_t> is_feature = attr.features(delta_);
  for (std::size_t i = 0; i < n; ++i)
    if (is_feature[i])
      curvature[i] = 0.0;  // as computeMeanCurvature gives feature points

  // Points covered already: claims written by tiles of earlier colours (all finished).
  const int colour = plan_.tree.tiles[static_cast<std::size_t>(t)].colour;
  std::vector<std::uint8_t> is_source(plan_.tree.tiles.size(), 0);
  for (std::size_t i = 0; i < n; ++i)
    if (d.src_tile[i] < is_source.size())
      is_source[d.src_tile[i]] = 1;
    else
      failDamaged("tile " + std::to_string(t) + "'s halo names tile " + std::to_string(d.src_tile[i]) +
                  ", which does not exist");
  std::vector<std::uint8_t> pre_covered(n, 0);
  for (int s = 0; s < static_cast<int>(is_source.size()); ++s)
  {
    if (!is_source[static_cast<std::size_t>(s)])
      continue;  // this tile holds no point of tile s
    std::vector<std::uint8_t> covered(plan_.tree.tiles[static_cast<std::size_t>(s)].core_points, 0);
    bool any = false;
    const auto writers = claim_writers_.find(s);
    if (writers == claim_writers_.end())
      continue;
    for (const int w : writers->second)
    {
      if (plan_.tree.tiles[static_cast<std::size_t>(w)].colour >= colour)
        continue;
      for (const std::uint32_t idx : readVector<std::uint32_t>(paths_.claims(s, w)))
        if (idx < covered.size())
        {
          covered[idx] = 1;
          any = true;
        }
    }
    if (!any)
      continue;
    for (std::size_t i = 0; i < n; ++i)
      if (static_cast<int>(d.src_tile[i]) == s && covered[d.src_index[i]])
        pre_covered[i] = 1;
  }

  BoxTreeSearch tree(/*sorted=*/false, tile_threads_);  // unsorted radius results; a tile is in Hilbert order
  tree.setInputCloud(d.cloud);
  CoverInput in{*d.cloud,          normals,      weights,     is_feature, curvature, density, mean_abs_h_,
                mean_spacing_,     neighborhood_radius_, summary_.bbox_diagonal * plan_.scale(), tree};
  in.centre_allowed = &d.is_core;
  in.pre_covered = &pre_covered;
  Parameters p = params_;
  p.threads = tile_threads_;
  CoverOutput cover;
  coverWithBalls(in, p, params_.error_threshold, cover);

  // Output: own feature points in input order, then the balls.
  const io::XyzAccess xyz(header_);
  std::vector<std::size_t> features;
  for (std::size_t i = 0; i < n; ++i)
    if (d.is_core[i] && is_feature[i])
      features.push_back(i);
  std::sort(features.begin(), features.end(), [&](std::size_t a, std::size_t b) { return d.gid[a] < d.gid[b]; });
  std::vector<std::uint8_t> out((features.size() + cover.balls.size()) * step);
  std::vector<double> stats(4, 0.0);  // features, balls, max error, (unused)
  std::size_t o = 0;
  for (const std::size_t i : features)
  {
    std::uint8_t* rec = out.data() + (o++) * step;
    std::memcpy(rec, d.records.data() + i * step, step);
    setRecordNormal(rec, normals[i], (*d.cloud)[i].getVector3fMap().cast<double>());
  }
  for (const CoverBall& b : cover.balls)
  {
    std::uint8_t* rec = out.data() + (o++) * step;
    std::memcpy(rec, d.records.data() + static_cast<std::size_t>(b.attribute_source) * step, step);
    const Eigen::Vector3d world = plan_.toWorld(b.representative);
    // Written through float like the in-memory filter's PCL point types.
    xyz.set(rec, static_cast<float>(world.x()), static_cast<float>(world.y()), static_cast<float>(world.z()));
    setRecordNormal(rec, b.normal, b.representative);
    stats[2] = std::max(stats[2], b.error);
  }
  stats[0] = static_cast<double>(features.size());
  stats[1] = static_cast<double>(cover.balls.size());

  // Claims, by the tile that owns the point (this tile's own included).
  std::vector<std::vector<std::uint32_t>> claims(plan_.tree.tiles.size());
  for (std::size_t i = 0; i < n; ++i)
    if (cover.owner[i] >= 0)
      claims[d.src_tile[i]].push_back(d.src_index[i]);
  fs::create_directories(paths_.root / "c");
  for (std::size_t s = 0; s < claims.size(); ++s)
    if (!claims[s].empty())
    {
      radixSortStable(claims[s], [](std::uint32_t v) { return std::uint64_t{v}; });
      writeVectorAtomic(paths_.claims(static_cast<int>(s), t), claims[s]);
    }
  // Gap candidates for phase D: the tile's own non-feature points farther than the gap from every
  // output point this tile knows (its balls, the feature points of its core and halo). Points
  // within it are within it of the final output too, so phase D reads only these.
  if (params_.max_gap_factor > 0.0)
  {
    const double gap = params_.max_gap_factor * cap_;
    const double gap2 = gap * gap;
    std::vector<Eigen::Vector3d> known, own;
    std::vector<std::size_t> own_index;
    for (std::size_t i = 0; i < n; ++i)
    {
      const Eigen::Vector3d q = (*d.cloud)[i].getVector3fMap().cast<double>();
      if (is_feature[i])
        known.push_back(q);
      else if (d.is_core[i])
      {
        // Within the gap of its own ball's representative: near an output point (as in memory,
        // fillGaps); the others (covered by an earlier tile's ball, or far from their own) are
        // looked up among all the known output points.
        const int b = cover.owner[i];
        if (b >= 0 && (cover.balls[static_cast<std::size_t>(b)].representative - q).squaredNorm() <= gap2)
          continue;
        own.push_back(q);
        own_index.push_back(i);
      }
    }
    for (const CoverBall& b : cover.balls)
      known.push_back(b.representative);
    const std::vector<std::uint8_t> far = farFrom(known, own, gap, tile_threads_);
    std::vector<std::uint8_t> candidates;
    for (std::size_t k = 0; k < own.size(); ++k)
      if (far[k])
      {
        const std::size_t i = own_index[k];
        candidates.insert(candidates.end(), d.records.begin() + static_cast<std::ptrdiff_t>(i * step),
                          d.records.begin() + static_cast<std::ptrdiff_t>((i + 1) * step));
        setRecordNormal(candidates.data() + candidates.size() - step, normals[i], own[k]);
      }
    writeVectorAtomic(paths_.gapCandidates(t), candidates);
  }
  writeVectorAtomic(paths_.out(t), out);
  writeVectorAtomic(paths_.doneC(t), stats);
  // Nothing after the cover reads the tile's points or values (phase D reads the outputs).
  std::vector<fs::path> done{paths_.attr(t), paths_.order(t), paths_.dens(t)};
  for (int p = 0; p < plan_.parts; ++p)
  {
    done.push_back(paths_.core(t, p));
    done.push_back(paths_.halo(t, p));
  }
  dropScratch(done);
}

void Runner::setRecordNormal(std::uint8_t* rec, Eigen::Vector3f nrm, const Eigen::Vector3d& at) const
{
  const std::array<int, 3>& f = normal_fields_;
  if (f[0] < 0 || f[1] < 0 || f[2] < 0)
    return;
  if ((viewpoint_local_ - at).dot(nrm.cast<double>()) < 0.0)
    nrm = -nrm;
  for (int a = 0; a < 3; ++a)
  {
    const auto& field = header_.fields[static_cast<std::size_t>(f[a])];
    io::storeFieldValue(nrm[a], field.datatype, rec + field.offset);
  }
}

// The gap bound (gap_fill.h) once every tile's cover is written: the tile's gap candidates (phase C)
// still farther than the gap from every output point near them (the covers of the tiles within the
// gap, the gap points of those of earlier colours) become output points, greedily in the tile's
// order. Tiles of one colour are more than two radius caps apart: their gap points cannot interact.
void Runner::phaseD(int t)
{
  const double gap = params_.max_gap_factor * cap_;
  const std::size_t step = header_.point_step;
  std::vector<std::uint8_t> out;
  std::vector<double> stats(1, 0.0);  // gap points
  const auto records = readVector<std::uint8_t>(paths_.gapCandidates(t));
  if (gap > 0.0 && !records.empty())
  {
    const io::XyzAccess xyz(header_);
    const Eigen::Vector3d origin = plan_.origin();
    const double scale = plan_.scale();
    auto positions = [&](const std::vector<std::uint8_t>& bytes, std::vector<Eigen::Vector3d>& into) {
      for (std::size_t o = 0; o + step <= bytes.size(); o += step)
      {
        Eigen::Vector3d w;
        xyz.get(bytes.data() + o, w.x(), w.y(), w.z());
        into.push_back((w - origin) * scale);  // plan_.toLocal
      }
    };
    std::vector<Eigen::Vector3d> outputs, candidates;
    positions(records, candidates);
    const Tile& tile = plan_.tree.tiles[static_cast<std::size_t>(t)];
    for (std::size_t s = 0; s < plan_.tree.tiles.size(); ++s)
    {
      const Tile& other = plan_.tree.tiles[s];
      if (tileDistance(tile, other) * plan_.scale() > gap)  // in the tiling plane: at most the 3D distance
        continue;
      positions(readVector<std::uint8_t>(paths_.out(static_cast<int>(s))), outputs);
      if (other.colour < tile.colour)
        positions(readVector<std::uint8_t>(paths_.fill(static_cast<int>(s))), outputs);
    }
    const std::vector<std::size_t> kept = closeGaps(outputs, candidates, gap, tile_threads_);
    out.reserve(kept.size() * step);
    for (const std::size_t k : kept)
      out.insert(out.end(), records.begin() + static_cast<std::ptrdiff_t>(k * step),
                 records.begin() + static_cast<std::ptrdiff_t>((k + 1) * step));
    stats[0] = static_cast<double>(kept.size());
  }
  fs::create_directories(paths_.root / "d");
  writeVectorAtomic(paths_.fill(t), out);
  writeVectorAtomic(paths_.doneD(t), stats);
}

void Runner::runStage(const char* name, int index, const std::vector<int>& todo, const std::function<void(int)>& fn)
{
  const auto t0 = Clock::now();
  std::uint64_t total_points = 0;
  for (const int t : todo)
  {
    const Tile& tile = plan_.tree.tiles[static_cast<std::size_t>(t)];
    total_points += tile.core_points;
  }
  std::atomic<std::uint64_t> done_points{0};
  std::atomic<std::size_t> done_tiles{0};
  auto body = [&](int t) {
    fn(t);
    const Tile& tile = plan_.tree.tiles[static_cast<std::size_t>(t)];
    const std::uint64_t pts = done_points += tile.core_points;
    const std::size_t tiles = ++done_tiles;
    const double s = secondsSince(t0);
    const double rate = s > 0 ? static_cast<double>(pts) / s : 0.0;
    std::ostringstream os;
    os << name << ": tile " << tiles << "/" << todo.size() << ", " << std::fixed << std::setprecision(2)
       << rate / 1e6 << " M points/s, ETA " << std::setprecision(0)
       << (rate > 0 ? static_cast<double>(total_points - pts) / rate : 0.0) << " s";
    report(os.str());
    stepDone();
  };
  // Tiles go `workers_` at a time, the run's threads shared among them; the last few, fewer than
  // the workers, would leave threads idle, so they share all the threads among themselves (a
  // tile's result does not depend on its thread count).
  auto batch = [&](const std::vector<int>& tiles, int workers) {
    tile_threads_ = std::max(1, threads_ / workers);
    forEachTile(tiles, workers, body);
  };
  const std::size_t tail = todo.size() % static_cast<std::size_t>(workers_);
  batch(std::vector<int>(todo.begin(), todo.end() - static_cast<std::ptrdiff_t>(tail)), workers_);
  if (tail > 0)
    batch(std::vector<int>(todo.end() - static_cast<std::ptrdiff_t>(tail), todo.end()), static_cast<int>(tail));
  summary_.stage_seconds[static_cast<std::size_t>(index)] += secondsSince(t0);
}

void Runner::writeOutput()
{
  const auto t0 = Clock::now();
  io::RecordSink writer(output_, header_, las_.get(), {{plan_.lo.x(), plan_.lo.y(), plan_.lo.z()}},
                       {{plan_.hi.x(), plan_.hi.y(), plan_.hi.z()}});
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(header_.point_step) * kChunk);
  for (std::size_t t = 0; t < plan_.tree.tiles.size(); ++t)
  {
    std::ifstream f(paths_.out(static_cast<int>(t)), std::ios::binary);
    if (!f)
      failRun("cannot read the scratch file " + paths_.out(static_cast<int>(t)).string());
    for (;;)
    {
      f.read(reinterpret_cast<char*>(buf.data()), static_cast<std::streamsize>(buf.size()));
      const std::size_t got = static_cast<std::size_t>(f.gcount());
      if (got == 0)
        break;
      writer.append(buf.data(), got / header_.point_step);
    }
    // The tile's gap points (phase D) after its cover.
    if (params_.max_gap_factor > 0.0)
    {
      const auto fill = readVector<std::uint8_t>(paths_.fill(static_cast<int>(t)));
      writer.append(fill.data(), fill.size() / header_.point_step);
    }
  }
  summary_.output_points = writer.written();
  writer.commit();
  summary_.stage_seconds[5] = secondsSince(t0);
}

void Runner::prepare(bool plan_if_missing)
{
  const std::string bad = validate(params_);
  if (!bad.empty())
    failRun(bad);
  if (params_.target_size != 0)
    failRun("--stream works with an error threshold (--terr), not a target size: pick T_err on a "
            "sample of the scan first (docs/STREAMING.md)");
  if (params_.use_input_normals)
    failRun("--stream estimates the normals; --use-input-normals is not supported with it");
  const int threads = resolveThreads(params_.threads);
  threads_ = threads;
  workers_ = std::min(threads, kConcurrentTiles);
  memory_limit_ = options_.memory_limit;
  if (memory_limit_ == 0)
    memory_limit_ = std::max<std::uint64_t>(256ull << 20, physicalMemory() / 4);
  if (memory_limit_ < (64ull << 20))
    failRun("--memory-limit must be at least 64M");
  const std::string why = io::checkWritable(output_);
  if (!why.empty())
    failRun(output_ + ": " + why);

  paths_.root = options_.scratch_dir.empty() ? fs::path(output_ + ".ecs-scratch") : fs::path(options_.scratch_dir);
  const std::string fingerprint =
      fingerprintOf(inputs_, params_, memory_limit_) + " tile=" + std::to_string(options_.max_tile_points);
  // The header first: bad input is refused before any work. The same reader then does the scan
  // (the input is opened and read once).
  io::RecordSource reader(inputs_);
  header_ = reader.header();
  records_in_input_ = reader.recordsInFile(data_offset_);
  if (reader.las())
    las_ = std::make_unique<io::LasInfo>(*reader.las());
  input_stamp_ = stampOf(inputs_[0]);
  // The limit is a promise: refused at once when this process cannot keep to it. The plan counts
  // a fixed allowance for the process itself (pcd_simplify holds about 30 MiB at the start), not
  // its measured size, so that one input and one limit give one plan and one output in any
  // process on any machine (a Dask worker, another libc).
  baseline_bytes_ = kProcessAllowance;
  const std::uint64_t needed = minimumLimit(header_.point_step);
  if (memory_limit_ < needed && options_.max_tile_points == 0)
    throw LimitError("--memory-limit " + std::to_string(memory_limit_ >> 20) + "M is below what this run needs: use at least " +
            suggestedLimit(needed) + " (the process itself counts as " +
            std::to_string(baseline_bytes_ >> 20) + "M; two tiles of " +
            std::to_string(kMinTilePoints) + " points and the planning sample need the rest)");
  (void)io::XyzAccess(header_);
  std::error_code ec;
  // A directory of the user's (not one this tool made: no marker) is never used as the scratch
  // itself, nor removed: the scratch becomes a directory of ours inside it, named for the output,
  // so that `--scratch /tmp` works and a rerun with the same flags finds it again.
  if (!options_.scratch_dir.empty() && fs::is_directory(paths_.root, ec) && !fs::exists(paths_.root / kScratchMarker))
    paths_.root /= fs::path(output_).filename().string() + ".ecs-scratch";
  if (fs::exists(paths_.root, ec) && !fs::exists(paths_.root / kScratchMarker) && !fs::is_empty(paths_.root, ec))
    failRun("the scratch directory " + paths_.root.string() +
            " exists and was not made by pcl_ecs: choose another with --scratch");
  if (loadPlan(paths_, fingerprint, plan_))
  {
    summary_.resumed = true;
    report("resuming from " + paths_.root.string());
  }
  else if (!plan_if_missing)
    failRun("the scratch directory " + paths_.root.string() + " holds no plan for this run: prepare it first");
  else
  {
    const std::uint64_t resident = residentBytes();
    if (resident > baseline_bytes_)
      report("note: this process holds " + std::to_string(resident >> 20) + " MiB before the run, more than the " +
             std::to_string(baseline_bytes_ >> 20) + " MiB the plan counts for it; its peak may pass the limit by the "
             "difference");
    fs::remove_all(paths_.root, ec);
    fs::create_directories(paths_.root, ec);
    if (ec)
      failRun("cannot create the scratch directory " + paths_.root.string() + ": " + ec.message());
    std::ofstream(paths_.root / kScratchMarker) << "scratch space of pcd_simplify --stream; safe to delete\n";
    // Refuse up front when the scratch space cannot hold the run: ~140 B a point, the records in
    // the tiles (1.3 × with their halo) and, until the split is done, the copy of pass 1.
    const std::uint64_t need = header_.points * (148ull + (23ull * header_.point_step) / 10);
    const auto space = fs::space(paths_.root, ec);
    if (!ec && space.available < need)
    {
      fs::remove_all(paths_.root, ec);
      std::ostringstream os;
      os << "the scratch directory " << paths_.root.string() << " has " << (space.available >> 20)
         << " MiB free but this run needs about " << (need >> 20) << " MiB: choose another with --scratch";
      failRun(os.str());
    }
    plan_.fingerprint = fingerprint;
    try
    {
      scanAndPlan(reader);
      split();
    }
    catch (...)
    {
      fs::remove_all(paths_.root, ec);  // nothing worth resuming yet
      throw;
    }
  }
  summary_.input_points = plan_.input_points;
  summary_.finite_points = plan_.finite_points;
  summary_.bbox_diagonal = (plan_.hi - plan_.lo).norm();
  summary_.halo = plan_.halo;
  summary_.axis_u = plan_.axis_u;
  summary_.axis_v = plan_.axis_v;
  summary_.tile_point_budget = plan_.tile_point_budget;
  summary_.split_runs = plan_.parts;
  viewpoint_local_ = plan_.toLocal(Eigen::Vector3d(header_.viewpoint[0], header_.viewpoint[1], header_.viewpoint[2]));
  normal_fields_ = {header_.fieldIndex("normal_x"), header_.fieldIndex("normal_y"), header_.fieldIndex("normal_z")};
}

/// The element-wise sum, in tile order, of the `n` values of every tile's `sum(t)` file; kept in
/// `total` (written atomically by whoever adds them up first: the same bytes whoever does).
std::vector<double> tileTotals(const fs::path& total, int tiles, std::size_t n,
                               const std::function<fs::path(int)>& sum)
{
  if (fs::exists(total))
  {
    auto v = readVector<double>(total);
    if (v.size() == n)
      return v;
  }
  std::vector<double> v(n, 0.0);
  for (int t = 0; t < tiles; ++t)
  {
    const auto s = readVector<double>(sum(t));
    for (std::size_t i = 0; i < n; ++i)
      v[i] += s.at(i);
  }
  writeVectorAtomic(total, v);
  return v;
}

void Runner::globalsAfterA()
{
  const int tiles = static_cast<int>(plan_.tree.tiles.size());
  const auto v = tileTotals(paths_.totalA(), tiles, 4, [&](int t) { return paths_.sumA(t); });
  const double sum_measure = v[0], count = v[1], incomplete = v[2], merged = v[3];
  summary_.merged_points = static_cast<std::uint64_t>(merged);
  delta_ = params_.feature_factor * sum_measure / count;
  summary_.feature_threshold = delta_ / plan_.scale();
  summary_.incomplete_neighbourhoods = static_cast<std::uint64_t>(incomplete);
}

int Runner::globalsAfterB(bool warn)
{
  const int tiles = static_cast<int>(plan_.tree.tiles.size());
  const auto sb = tileTotals(paths_.totalB(), tiles, 6, [&](int t) { return paths_.sumB(t); });
  summary_.search_fallback_tiles = static_cast<std::uint64_t>(sb[5]);
  const double nonfeature = std::max(1.0, sb[3]);
  mean_spacing_ = sb[0] / nonfeature;
  neighborhood_radius_ = sb[1] / nonfeature;
  mean_abs_h_ = sb[2] / nonfeature;
  summary_.mean_spacing = mean_spacing_ / plan_.scale();
  summary_.neighborhood_radius = neighborhood_radius_ / plan_.scale();
  summary_.mean_abs_curvature = mean_abs_h_ * plan_.scale();
  cap_ = params_.radius_cap_factor * neighborhood_radius_;  // local units, as every phase's lengths
  const double cap_world = cap_ / plan_.scale();
  if (cap_world > plan_.halo)
  {
    summary_.halo_too_narrow = true;
    if (warn)
      report("warning: the largest ball (" + std::to_string(cap_world) + ") is wider than the halo (" +
             std::to_string(plan_.halo) + "); balls at tile borders may be cut");
  }
  // Tiles closer than two ball radii interact: they get different colours and run one after another.
  return colourTiles(plan_.tree.tiles, 2.0 * cap_world * 1.001 + 1e-12 / plan_.scale());
}

void Runner::listClaims()
{
  // The claims written so far (phaseC keeps those of earlier colours).
  std::error_code ec;
  claim_writers_.clear();
  for (const auto& e : fs::directory_iterator(paths_.root / "c", ec))
  {
    const std::string name = e.path().filename().string();
    const std::size_t dot = name.find(".from.");
    if (dot == std::string::npos || name.find(".tmp") != std::string::npos)
      continue;
    claim_writers_[std::stoi(name.substr(0, dot))].push_back(std::stoi(name.substr(dot + 6)));
  }
  for (auto& kv : claim_writers_)
    std::sort(kv.second.begin(), kv.second.end());
}

StreamSummary Runner::run()
{
  const auto t0 = Clock::now();
  prepare(true);
  const int tiles = static_cast<int>(plan_.tree.tiles.size());
  auto pending = [&](const std::function<fs::path(int)>& marker) {
    std::vector<int> todo;
    for (int t = 0; t < tiles; ++t)
      if (!fs::exists(marker(t)))
        todo.push_back(t);
    return todo;
  };
  auto track_scratch = [&]() { summary_.scratch_bytes = std::max(summary_.scratch_bytes, directoryBytes(paths_.root)); };

  // Phase A, then δ over all points.
  runStage("A (neighbourhoods, normals, eq. 1-3, 7-11)", 2, pending([&](int t) { return paths_.sumA(t); }),
           [&](int t) { phaseA(t); });
  globalsAfterA();
  track_scratch();

  // Phase B, then the means of eq. 6 and 12 and the radius unit over all non-feature points.
  runStage("B (features, eq. 5)", 3, pending([&](int t) { return paths_.sumB(t); }), [&](int t) { phaseB(t); });
  const int colours = globalsAfterB(true);
  track_scratch();

  std::error_code ec;
  fs::create_directories(paths_.root / "c");
  for (int c = 0; c < colours; ++c)
  {
    std::vector<int> todo;
    for (int t = 0; t < tiles; ++t)
      if (plan_.tree.tiles[static_cast<std::size_t>(t)].colour == c && !fs::exists(paths_.doneC(t)))
        todo.push_back(t);
    listClaims();
    const std::string name = "C (cover, colour " + std::to_string(c + 1) + "/" + std::to_string(colours) + ")";
    runStage(name.c_str(), 4, todo, [&](int t) { phaseC(t); });
  }
  if (params_.max_gap_factor > 0.0)
    for (int c = 0; c < colours; ++c)
    {
      std::vector<int> todo;
      for (int t = 0; t < tiles; ++t)
        if (plan_.tree.tiles[static_cast<std::size_t>(t)].colour == c && !fs::exists(paths_.doneD(t)))
          todo.push_back(t);
      const std::string name = "D (gaps, colour " + std::to_string(c + 1) + "/" + std::to_string(colours) + ")";
      runStage(name.c_str(), 4, todo, [&](int t) { phaseD(t); });
    }
  track_scratch();
  finishRun();
  summary_.seconds = secondsSince(t0);
  return summary_;
}

void Runner::finishRun()
{
  const int tiles = static_cast<int>(plan_.tree.tiles.size());
  for (int t = 0; t < tiles; ++t)
  {
    const auto s = readVector<double>(paths_.doneC(t));
    summary_.feature_points += static_cast<std::uint64_t>(s.at(0));
    summary_.balls += static_cast<std::uint64_t>(s.at(1));
    summary_.max_error = std::max(summary_.max_error, s.at(2));
    if (params_.max_gap_factor > 0.0)
    {
      const auto g = readVector<double>(paths_.doneD(t));
      summary_.gap_points += static_cast<std::uint64_t>(g.at(0));
      summary_.balls += static_cast<std::uint64_t>(g.at(0));
    }
  }
  writeOutput();
  summary_.tiles = plan_.tree.tiles;
  std::error_code ec;
  if (!options_.keep_scratch)
    fs::remove_all(paths_.root, ec);
}

bool Runner::runTask(char stage, int t)
{
  if (t < 0 || static_cast<std::size_t>(t) >= plan_.tree.tiles.size())
    failRun("no tile " + std::to_string(t) + " in this plan");
  const auto done = [&](const fs::path& marker) { return fs::exists(marker); };
  tile_threads_ = threads_;
  switch (stage)
  {
  case 'A':
    if (done(paths_.sumA(t)))
      return false;
    phaseA(t);
    break;
  case 'B':
    if (done(paths_.sumB(t)))
      return false;
    globalsAfterA();
    phaseB(t);
    break;
  case 'C':
  case 'D':
    if (done(stage == 'C' ? paths_.doneC(t) : paths_.doneD(t)))
      return false;
    globalsAfterA();
    globalsAfterB(false);
    if (stage == 'C')
    {
      std::error_code ec;
      fs::create_directories(paths_.root / "c", ec);
      listClaims();
      phaseC(t);
    }
    else
      phaseD(t);
    break;
  default: failRun(std::string("no stage '") + stage + "' (A, B, C, D)");
  }
  stepDone();
  return true;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

struct TiledRun::Impl
{
  Runner runner;
  bool prepared = false;
  Impl(const std::vector<std::string>& inputs, const std::string& output, const Parameters& params,
       const StreamOptions& options)
    : runner(inputs, output, params, options)
  {
  }
};

TiledRun::TiledRun(const std::string& input, const std::string& output, const Parameters& params,
                   const StreamOptions& options)
  : TiledRun(std::vector<std::string>{input}, output, params, options)
{
}

TiledRun::TiledRun(const std::vector<std::string>& inputs, const std::string& output, const Parameters& params,
                   const StreamOptions& options)
  : impl_(std::make_unique<Impl>(inputs, output, params, options))
{
}

TiledRun::~TiledRun() = default;

int TiledRun::prepare(bool plan)
{
  impl_->runner.prepare(plan);
  impl_->prepared = true;
  return static_cast<int>(impl_->runner.plan().tree.tiles.size());
}

std::vector<int> TiledRun::colours()
{
  if (!impl_->prepared)
    prepare(false);
  impl_->runner.globalsAfterA();
  impl_->runner.globalsAfterB(false);
  std::vector<int> c;
  for (const Tile& t : impl_->runner.plan().tree.tiles)
    c.push_back(t.colour);
  return c;
}

bool TiledRun::runTask(char stage, int tile)
{
  if (!impl_->prepared)
    prepare(false);
  return impl_->runner.runTask(stage, tile);
}

StreamSummary TiledRun::finish()
{
  if (!impl_->prepared)
    prepare(false);
  impl_->runner.globalsAfterA();
  impl_->runner.globalsAfterB(false);
  impl_->runner.finishRun();
  return impl_->runner.summary();
}

StreamSummary simplifyOutOfCore(const std::string& input, const std::string& output, const Parameters& params,
                                const StreamOptions& options)
{
  return simplifyOutOfCore(std::vector<std::string>{input}, output, params, options);
}

StreamSummary simplifyOutOfCore(const std::vector<std::string>& inputs, const std::string& output,
                                const Parameters& params, const StreamOptions& options)
{
  Runner runner(inputs, output, params, options);
  return runner.run();
}

bool parseByteSize(const std::string& text, std::uint64_t& bytes)
{
  if (text.empty())
    return false;
  std::size_t used = 0;
  double value = 0.0;
  try
  {
    value = std::stod(text, &used);
  }
  catch (const std::exception&)
  {
    return false;
  }
  std::string unit = text.substr(used);
  if (unit.size() > 1 && (unit.back() == 'B' || unit.back() == 'b'))
    unit.pop_back();
  if (unit.size() > 1 && (unit.back() == 'i'))
    unit.pop_back();
  double mult = 1.0;
  if (unit.empty())
    mult = 1.0;
  else if (unit == "K" || unit == "k")
    mult = 1024.0;
  else if (unit == "M" || unit == "m")
    mult = 1024.0 * 1024.0;
  else if (unit == "G" || unit == "g")
    mult = 1024.0 * 1024.0 * 1024.0;
  else if (unit == "T" || unit == "t")
    mult = 1024.0 * 1024.0 * 1024.0 * 1024.0;
  else
    return false;
  if (!std::isfinite(value) || value <= 0.0 || value * mult > 1e18)
    return false;
  bytes = static_cast<std::uint64_t>(value * mult);
  return true;
}

std::uint64_t physicalMemory()
{
  const long pages = ::sysconf(_SC_PHYS_PAGES);
  const long page = ::sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page) : 0;
}

std::uint64_t availableMemory()
{
  std::ifstream in("/proc/meminfo");
  std::string key, unit;
  std::uint64_t kib = 0;
  while (in >> key >> kib >> unit)
    if (key == "MemAvailable:")
      return kib * 1024;
  return physicalMemory();
}

std::vector<Tile> planTiles(const std::vector<std::array<double, 2>>& sample, std::size_t max_per_tile, double halo)
{
  const std::size_t bound = std::max<std::size_t>(1, max_per_tile);
  return buildTileTree(sample, bound, bound, halo).tiles;
}

double tileDistance(const Tile& a, const Tile& b)
{
  const double du = std::max({0.0, a.lo[0] - b.hi[0], b.lo[0] - a.hi[0]});
  const double dv = std::max({0.0, a.lo[1] - b.hi[1], b.lo[1] - a.hi[1]});
  return std::sqrt(du * du + dv * dv);
}

int colourTiles(std::vector<Tile>& tiles, double separation)
{
  int colours = 0;
  for (std::size_t i = 0; i < tiles.size(); ++i)
  {
    std::vector<std::uint8_t> used(static_cast<std::size_t>(colours) + 1, 0);
    for (std::size_t j = 0; j < i; ++j)
      if (tileDistance(tiles[i], tiles[j]) < separation)
        used[static_cast<std::size_t>(tiles[j].colour)] = 1;
    int c = 0;
    while (used[static_cast<std::size_t>(c)])
      ++c;
    tiles[i].colour = c;
    colours = std::max(colours, c + 1);
  }
  return colours;
}

}  // namespace stream
}  // namespace pcl_ecs
