#include <pcl_ecs/search/box_tree_search.h>

#include "../detail/pair_key.h"
#include "../detail/simd.h"

#include <pcl/common/point_tests.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#ifdef _OPENMP
#include <omp.h>
#endif
#ifdef __SSE__
#include <xmmintrin.h>
#endif
#ifdef PCL_ECS_HAVE_AVX2_PATH
#include <immintrin.h>
#endif

namespace pcl_ecs
{

namespace
{
constexpr int kWide = 8;  // children per node (a multiple of 4: whole SIMD quadruples)

/// The boxes of a node's kWide children, coordinate by coordinate (an empty slot has lo = +inf,
/// hi = -inf: never within reach), so that a query tests all of them in one vectorised pass.
struct Node
{
  float lo[3][kWide], hi[3][kWide];
};

/// Squared distances from (x, y, z) to the node's kWide child boxes (0 inside).
inline void childDistances(const Node& n, float x, float y, float z, float* d)
{
#ifdef __SSE__
  // Four boxes per instruction (the compiler does not vectorise the max of floats by itself).
  const __m128 zero = _mm_setzero_ps();
  const __m128 q[3] = {_mm_set1_ps(x), _mm_set1_ps(y), _mm_set1_ps(z)};
  for (int c = 0; c < kWide; c += 4)
  {
    __m128 sum = zero;
    for (int a = 0; a < 3; ++a)
    {
      const __m128 below = _mm_sub_ps(_mm_loadu_ps(&n.lo[a][c]), q[a]);
      const __m128 above = _mm_sub_ps(q[a], _mm_loadu_ps(&n.hi[a][c]));
      const __m128 gap = _mm_max_ps(_mm_max_ps(below, above), zero);
      sum = _mm_add_ps(sum, _mm_mul_ps(gap, gap));
    }
    _mm_storeu_ps(d + c, sum);
  }
#else
  for (int c = 0; c < kWide; ++c)
  {
    float s = 0.f;
    const float q[3] = {x, y, z};
    for (int a = 0; a < 3; ++a)
    {
      const float gap = std::max(std::max(n.lo[a][c] - q[a], q[a] - n.hi[a][c]), 0.f);
      s += gap * gap;
    }
    d[c] = s;
  }
#endif
}

/// The distance of an empty child slot (its box is lo = +inf, hi = -inf); real boxes are finite.
constexpr float kEmpty = std::numeric_limits<float>::infinity();

struct Visit
{
  int level;
  int node;
  float distance;  // squared distance from the query to the node's box (K-nearest search)
};
// Depth-first stacks hold at most (kWide - 1) entries per level plus one; 16 levels of 8-wide
// nodes over runs of 32 points reach past 2^50 points.
constexpr int kStack = 16 * kWide;
/// The points of one run (kRun coordinates from x, y, z; padding is NaN: never within reach) with
/// squared distance <= r2 from (px, py, pz): their ids and squared distances, in run order, into
/// out_i and out_d (room for kRun). Returns how many.
int scanRunPortable(const float* x, const float* y, const float* z, const int* ids, float px,
                    float py, float pz, float r2, int* out_i, float* out_d)
{
  float d2[BoxTreeSearch::kRun];
  for (int j = 0; j < BoxTreeSearch::kRun; ++j)  // vectorises
  {
    const float dx = px - x[j], dy = py - y[j], dz = pz - z[j];
    d2[j] = dx * dx + dy * dy + dz * dz;
  }
  // Gathered without a branch per point.
  int kept = 0;
  for (int j = 0; j < BoxTreeSearch::kRun; ++j)
  {
    out_i[kept] = ids[j];
    out_d[kept] = d2[j];
    kept += d2[j] <= r2 ? 1 : 0;
  }
  return kept;
}

#ifdef PCL_ECS_HAVE_AVX2_PATH

/// The same as scanRunPortable, eight points per instruction: distances by the same operations
/// in the same order (no fused multiply-add: the same bits), the points within reach packed to
/// the front of each group of eight by one permutation (a group stores eight lanes at `kept`,
/// at most its own start: within the kRun entries).
PCL_ECS_AVX2_TARGET int scanRunAvx2(const float* x, const float* y, const float* z, const int* ids,
                                    float px, float py, float pz, float r2, int* out_i, float* out_d)
{
  const __m256 qx = _mm256_set1_ps(px), qy = _mm256_set1_ps(py), qz = _mm256_set1_ps(pz);
  const __m256 limit = _mm256_set1_ps(r2);
  int kept = 0;
  for (int j = 0; j < BoxTreeSearch::kRun; j += 8)
  {
    const __m256 dx = _mm256_sub_ps(qx, _mm256_loadu_ps(x + j));
    const __m256 dy = _mm256_sub_ps(qy, _mm256_loadu_ps(y + j));
    const __m256 dz = _mm256_sub_ps(qz, _mm256_loadu_ps(z + j));
    const __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)),
                                    _mm256_mul_ps(dz, dz));
    const int mask = _mm256_movemask_ps(_mm256_cmp_ps(d2, limit, _CMP_LE_OQ));
    const __m256i lanes = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(detail::kCompress8.lanes[mask]));
    _mm256_storeu_ps(out_d + kept, _mm256_permutevar8x32_ps(d2, lanes));
    const __m256i id = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(ids + j));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out_i + kept), _mm256_permutevar8x32_epi32(id, lanes));
    kept += detail::kCompress8.count[mask];
  }
  return kept;
}
#endif

/// radiusSearch's walk: depth first, children in tree order, the points of each run within reach
/// (squared distance <= r2) appended to indices / sqr_distances in run order.
void radiusWalkPortable(const std::vector<std::vector<Node>>& levels, const float* x, const float* y,
                        const float* z, const int* ids, float px, float py, float pz, float r2,
                        pcl::Indices& indices, std::vector<float>& sqr_distances)
{
  Visit stack[kStack];
  int top = 0;
  stack[top++] = {static_cast<int>(levels.size()) - 1, 0, 0.f};
  float d[kWide];
  while (top > 0)
  {
    const Visit v = stack[--top];
    childDistances(levels[static_cast<std::size_t>(v.level)][static_cast<std::size_t>(v.node)], px, py, pz, d);
    if (v.level > 0)
    {
      // Children pushed last to first: they come out (and their points) in tree order.
      for (int c = kWide; c-- > 0;)
        if (d[c] <= r2 && d[c] < kEmpty)
          stack[top++] = {v.level - 1, v.node * kWide + c, 0.f};
      continue;
    }
    for (int c = 0; c < kWide; ++c)
    {
      if (!(d[c] <= r2 && d[c] < kEmpty))
        continue;
      const std::size_t b = (static_cast<std::size_t>(v.node) * kWide + static_cast<std::size_t>(c)) * BoxTreeSearch::kRun;
      int in_i[BoxTreeSearch::kRun];
      float in_d[BoxTreeSearch::kRun];
      const int kept = scanRunPortable(x + b, y + b, z + b, ids + b, px, py, pz, r2, in_i, in_d);
      indices.insert(indices.end(), in_i, in_i + kept);
      sqr_distances.insert(sqr_distances.end(), in_d, in_d + kept);
    }
  }
}

#ifdef PCL_ECS_HAVE_AVX2_PATH
/// radiusWalkPortable with a node's eight child boxes measured in one instruction (childDistances'
/// operations in its order: the same bits), the children within reach taken from a bit mask in the
/// same order, and each run scanned eight points at a time: the same results in the same order.
PCL_ECS_AVX2_TARGET void radiusWalkAvx2(const std::vector<std::vector<Node>>& levels, const float* x,
                                        const float* y, const float* z, const int* ids, float px,
                                        float py, float pz, float r2, pcl::Indices& indices,
                                        std::vector<float>& sqr_distances)
{
  const __m256 q[3] = {_mm256_set1_ps(px), _mm256_set1_ps(py), _mm256_set1_ps(pz)};
  const __m256 zero = _mm256_setzero_ps(), limit = _mm256_set1_ps(r2), empty = _mm256_set1_ps(kEmpty);
  struct Step
  {
    int level, node;
  };
  Step stack[kStack];
  int top = 0;
  stack[top++] = {static_cast<int>(levels.size()) - 1, 0};
  // Scanned into buffers of this thread (kept at their largest size: no zeroing), copied out once.
  thread_local std::vector<int> found_i;
  thread_local std::vector<float> found_d;
  std::size_t found = 0;
  while (top > 0)
  {
    const Step v = stack[--top];
    const Node& n = levels[static_cast<std::size_t>(v.level)][static_cast<std::size_t>(v.node)];
    __m256 sum = zero;
    for (int a = 0; a < 3; ++a)
    {
      const __m256 below = _mm256_sub_ps(_mm256_loadu_ps(n.lo[a]), q[a]);
      const __m256 above = _mm256_sub_ps(q[a], _mm256_loadu_ps(n.hi[a]));
      const __m256 gap = _mm256_max_ps(_mm256_max_ps(below, above), zero);
      sum = _mm256_add_ps(sum, _mm256_mul_ps(gap, gap));
    }
    unsigned mask = static_cast<unsigned>(_mm256_movemask_ps(
        _mm256_and_ps(_mm256_cmp_ps(sum, limit, _CMP_LE_OQ), _mm256_cmp_ps(sum, empty, _CMP_LT_OQ))));
    if (v.level > 0)
    {
      // Children pushed last to first: they come out (and their points) in tree order.
      while (mask != 0)
      {
        const int c = 31 - __builtin_clz(mask);
        mask &= ~(1u << c);
        stack[top++] = {v.level - 1, v.node * kWide + c};
      }
      continue;
    }
    for (; mask != 0; mask &= mask - 1)
    {
      const int c = __builtin_ctz(mask);
      const std::size_t b = (static_cast<std::size_t>(v.node) * kWide + static_cast<std::size_t>(c)) * BoxTreeSearch::kRun;
      if (found_i.size() < found + BoxTreeSearch::kRun)
      {
        found_i.resize(2 * (found + BoxTreeSearch::kRun));
        found_d.resize(found_i.size());
      }
      found += static_cast<std::size_t>(scanRunAvx2(x + b, y + b, z + b, ids + b, px, py, pz, r2,
                                                     found_i.data() + found, found_d.data() + found));
    }
  }
  indices.insert(indices.end(), found_i.data(), found_i.data() + found);
  sqr_distances.insert(sqr_distances.end(), found_d.data(), found_d.data() + found);
}
#endif

}  // namespace

struct BoxTreeSearch::Impl
{
  std::size_t count = 0;          // finite points in the tree
  std::vector<float> x, y, z;     // tree order, padded to whole runs with NaN (never within reach)
  std::vector<int> to_cloud;      // tree position -> cloud index (padded like x, y, z)
  // levels[0][j] holds the boxes of runs kWide j ... kWide j + kWide - 1; levels[l + 1][j] those
  // of levels[l][kWide j ...]; the last level is one node (the root's children).
  std::vector<std::vector<Node>> levels;
};

BoxTreeSearch::BoxTreeSearch(bool sorted, int threads)
  : pcl::search::Search<pcl::PointXYZ>("BoxTreeSearch", sorted), impl_(std::make_unique<Impl>()),
    threads_(threads)
{
}

BoxTreeSearch::~BoxTreeSearch() = default;

namespace
{
Node emptyNode()
{
  Node n;
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < kWide; ++c)
    {
      n.lo[a][c] = std::numeric_limits<float>::infinity();
      n.hi[a][c] = -std::numeric_limits<float>::infinity();
    }
  return n;
}
}  // namespace

void BoxTreeSearch::setInputCloud(const PointCloudConstPtr& cloud, const IndicesConstPtr& indices)
{
  input_ = cloud;
  indices_ = indices;
  Impl& t = *impl_;
  t = Impl{};
  auto finite = [&](int i) { return pcl::isFinite((*cloud)[static_cast<std::size_t>(i)]); };
  if (indices)
  {
    for (const auto i : *indices)
      if (finite(i))
        t.to_cloud.push_back(i);
  }
  else
  {
    t.to_cloud.reserve(cloud->size());
    for (std::size_t i = 0; i < cloud->size(); ++i)
      if (finite(static_cast<int>(i)))
        t.to_cloud.push_back(static_cast<int>(i));
  }
  t.count = t.to_cloud.size();
  if (t.count == 0)
    return;
  const std::size_t runs = (t.count + kRun - 1) / kRun;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  t.to_cloud.resize(runs * kRun, 0);  // padding: never within reach, but read by the scans
  t.x.assign(runs * kRun, nan);
  t.y.assign(runs * kRun, nan);
  t.z.assign(runs * kRun, nan);
  t.levels.emplace_back((runs + kWide - 1) / kWide, emptyNode());
  const auto run_count = static_cast<std::ptrdiff_t>(runs);
#ifdef _OPENMP
  const int threads = threads_ > 0 ? threads_ : omp_get_max_threads();
#endif
  // One pass: copy each run's points and take its box (runs are independent).
#pragma omp parallel for schedule(static) num_threads(threads)
  for (std::ptrdiff_t r = 0; r < run_count; ++r)
  {
    const std::size_t b = static_cast<std::size_t>(r) * kRun;
    const std::size_t e = std::min(b + kRun, t.count);
    float lo[3], hi[3];
    for (int a = 0; a < 3; ++a)
    {
      lo[a] = std::numeric_limits<float>::infinity();
      hi[a] = -std::numeric_limits<float>::infinity();
    }
    for (std::size_t j = b; j < e; ++j)
    {
      const pcl::PointXYZ& p = (*cloud)[static_cast<std::size_t>(t.to_cloud[j])];
      t.x[j] = p.x;
      t.y[j] = p.y;
      t.z[j] = p.z;
      const float c[3] = {p.x, p.y, p.z};
      for (int a = 0; a < 3; ++a)
      {
        lo[a] = std::min(lo[a], c[a]);
        hi[a] = std::max(hi[a], c[a]);
      }
    }
    Node& node = t.levels[0][static_cast<std::size_t>(r) / kWide];
    for (int a = 0; a < 3; ++a)
    {
      node.lo[a][r % kWide] = lo[a];
      node.hi[a][r % kWide] = hi[a];
    }
  }
  // Nodes of boxes up to the root (kWide times fewer each level: cheap, sequential).
  while (t.levels.back().size() > 1)
  {
    const std::vector<Node>& below = t.levels.back();
    std::vector<Node> above((below.size() + kWide - 1) / kWide, emptyNode());
    for (std::size_t j = 0; j < below.size(); ++j)
    {
      Node& n = above[j / kWide];
      for (int a = 0; a < 3; ++a)
      {
        float lo = n.lo[a][j % kWide], hi = n.hi[a][j % kWide];
        for (int c = 0; c < kWide; ++c)
        {
          lo = std::min(lo, below[j].lo[a][c]);
          hi = std::max(hi, below[j].hi[a][c]);
        }
        n.lo[a][j % kWide] = lo;
        n.hi[a][j % kWide] = hi;
      }
    }
    t.levels.push_back(std::move(above));
  }
}

int BoxTreeSearch::radiusSearch(const pcl::PointXYZ& point, double radius, pcl::Indices& k_indices,
                                std::vector<float>& k_sqr_distances, unsigned int max_nn) const
{
  k_indices.clear();
  k_sqr_distances.clear();
  const Impl& t = *impl_;
  if (t.count == 0 || !(radius >= 0.0) || !pcl::isFinite(point))
    return 0;
  const float r2 = static_cast<float>(radius * radius);
  const float px = point.x, py = point.y, pz = point.z;
#ifdef PCL_ECS_HAVE_AVX2_PATH
  if (detail::useAvx2())
    radiusWalkAvx2(t.levels, t.x.data(), t.y.data(), t.z.data(), t.to_cloud.data(), px, py, pz, r2,
                   k_indices, k_sqr_distances);
  else
#endif
    radiusWalkPortable(t.levels, t.x.data(), t.y.data(), t.z.data(), t.to_cloud.data(), px, py, pz, r2,
                       k_indices, k_sqr_distances);
  if (sorted_results_ || max_nn > 0)
  {
    thread_local std::vector<std::uint64_t> keys;
    keys.resize(k_indices.size());
    for (std::size_t i = 0; i < keys.size(); ++i)
      keys[i] = pairKey(k_sqr_distances[i], k_indices[i]);
    std::sort(keys.begin(), keys.end());
    if (max_nn > 0 && keys.size() > max_nn)
      keys.resize(max_nn);
    k_indices.resize(keys.size());
    k_sqr_distances.resize(keys.size());
    unpackKeys(keys.data(), keys.size(), k_indices.data(), k_sqr_distances.data());
  }
  return static_cast<int>(k_indices.size());
}

int BoxTreeSearch::nearestKSearch(const pcl::PointXYZ& point, int k, pcl::Indices& k_indices,
                                  std::vector<float>& k_sqr_distances) const
{
  k_indices.clear();
  k_sqr_distances.clear();
  const Impl& t = *impl_;
  if (t.count == 0 || k <= 0 || !pcl::isFinite(point))
    return 0;
  const std::size_t want = std::min<std::size_t>(static_cast<std::size_t>(k), t.count);
  const float px = point.x, py = point.y, pz = point.z;
  // The best keys so far: a sorted array for the usual small k (an insertion is a short shift),
  // a max-heap for large k. A box is skipped only when it is strictly farther than the worst
  // kept distance, so every point tied at that distance is seen: exact by key.
  thread_local std::vector<std::uint64_t> best;
  best.clear();
  const bool small = want <= 64;
  auto worst = [&] {
    if (best.size() < want)
      return std::numeric_limits<float>::infinity();
    return keyDistance(small ? best.back() : best.front());
  };
  auto offer = [&](std::uint64_t key) {
    if (small)
    {
      if (best.size() == want)
      {
        if (!(key < best.back()))
          return;
        best.pop_back();
      }
      best.push_back(key);
      for (std::size_t i = best.size() - 1; i > 0 && best[i - 1] > key; --i)
        std::swap(best[i - 1], best[i]);
    }
    else if (best.size() < want)
    {
      best.push_back(key);
      std::push_heap(best.begin(), best.end());
    }
    else if (key < best.front())
    {
      std::pop_heap(best.begin(), best.end());
      best.back() = key;
      std::push_heap(best.begin(), best.end());
    }
  };
  // Best first: boxes in order of their distance from the query (a min-heap, ties by level and
  // node: deterministic); the search ends when the nearest unseen box is farther than the worst kept.
  thread_local std::vector<Visit> queue;
  queue.clear();
  auto farther = [](const Visit& a, const Visit& b) {
    return a.distance > b.distance ||
           (a.distance == b.distance && (a.level > b.level || (a.level == b.level && a.node > b.node)));
  };
  queue.push_back({static_cast<int>(t.levels.size()) - 1, 0, 0.f});
  float d[kWide];
  while (!queue.empty())
  {
    std::pop_heap(queue.begin(), queue.end(), farther);
    const Visit v = queue.back();
    queue.pop_back();
    if (v.distance > worst())
      break;
    if (v.level < 0)
    {
      // A run: its points, distances first (vectorised; padding is NaN, never offered).
      const std::size_t b = static_cast<std::size_t>(v.node) * kRun;
      float d2[kRun];
      for (int j = 0; j < kRun; ++j)
      {
        const float dx = px - t.x[b + j], dy = py - t.y[b + j], dz = pz - t.z[b + j];
        d2[j] = dx * dx + dy * dy + dz * dz;
      }
      for (int j = 0; j < kRun; ++j)
        if (d2[j] <= worst())
          offer(pairKey(d2[j], t.to_cloud[b + j]));
      continue;
    }
    childDistances(t.levels[static_cast<std::size_t>(v.level)][static_cast<std::size_t>(v.node)], px, py, pz, d);
    for (int c = 0; c < kWide; ++c)
      if (d[c] <= worst() && d[c] < kEmpty)
      {
        // Level -1 stands for the runs below level 0.
        queue.push_back({v.level - 1, v.node * kWide + c, d[c]});
        std::push_heap(queue.begin(), queue.end(), farther);
      }
  }
  if (!small)
    std::sort_heap(best.begin(), best.end());
  k_indices.resize(best.size());
  k_sqr_distances.resize(best.size());
  unpackKeys(best.data(), best.size(), k_indices.data(), k_sqr_distances.data());
  return static_cast<int>(best.size());
}

}  // namespace pcl_ecs
