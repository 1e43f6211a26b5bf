// plan.cpp — the out-of-core plan: the tile tree, its colours, the plan on disk and its fingerprint (tiled_run.h).
#include "tiled_run.h"

namespace pcl_ecs
{
namespace stream
{
namespace detail
{

namespace
{
/// A sample of the tile tree with its index, moved around by the selections (sorting the points
/// themselves rather than indices to them: no scattered reads).
struct TreeItem
{
  std::array<double, 2> p;
  std::uint32_t id;
};

/// Where to split the part [begin, end) of `items` across `axis` into the fewest tiles that respect
/// the bounds, as evenly as possible (a tile count m splits m / 2 : m - m / 2): the items below
/// `value` are moved before `mid`. False when the part cannot be split (one value on the axis).
bool choosePartSplit(std::vector<TreeItem>& items, std::size_t begin, std::size_t end, int axis, std::size_t load,
                     std::size_t max_core, std::size_t max_load, double& value, std::size_t& mid)
{
  const double inf = std::numeric_limits<double>::infinity();
  const std::size_t count = end - begin;
  const std::size_t a = static_cast<std::size_t>(axis);
  auto first = items.begin() + static_cast<std::ptrdiff_t>(begin);
  auto last = items.begin() + static_cast<std::ptrdiff_t>(end);
  const std::size_t m = std::max<std::size_t>({2, (count + max_core - 1) / max_core, (load + max_load - 1) / max_load});
  const std::size_t k = begin + count * (m / 2) / m;
  // The sample at rank k (by coordinate, then index: a total order, so the same sample
  // whatever the algorithm); a selection, not a sort: linear in the part's size.
  std::nth_element(first, items.begin() + static_cast<std::ptrdiff_t>(k), last, [&](const TreeItem& x, const TreeItem& y) {
    return x.p[a] < y.p[a] || (x.p[a] == y.p[a] && x.id < y.id);
  });
  value = items[k].p[a];
  // Everything below `value` goes left.
  mid = static_cast<std::size_t>(std::partition(first, last, [&](const TreeItem& x) { return x.p[a] < value; }) -
                                 items.begin());
  if (mid != begin)
    return true;
  // The lower part is one value: split just above it instead.
  mid = static_cast<std::size_t>(std::partition(first, last, [&](const TreeItem& x) { return x.p[a] <= value; }) -
                                 items.begin());
  if (mid == end)
    return false;
  value = inf;
  for (std::size_t i = mid; i < end; ++i)
    value = std::min(value, items[i].p[a]);
  return true;
}
}  // namespace

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
  std::vector<TreeItem> items(sample.size());
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
    double value = 0.0;
    std::size_t mid = 0;
    const bool split = (count > max_core || too_loaded) && count >= 2 && side > 0.0 &&
                       choosePartSplit(items, j.begin, j.end, axis, load, max_core, max_load, value, mid);
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
  // Every parameter that changes the output (parameter_table.h), at full precision.
  for (const ParameterInfo& info : parameterTable())
    if (info.changes_output)
      os << ' ' << info.name << '=' << parameterText(info, p);
  os << " memory-limit=" << memory_limit;
  return os.str();
}

}  // namespace detail

std::vector<Tile> planTiles(const std::vector<std::array<double, 2>>& sample, std::size_t max_per_tile, double halo)
{
  const std::size_t bound = std::max<std::size_t>(1, max_per_tile);
  return detail::buildTileTree(sample, bound, bound, halo).tiles;
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
