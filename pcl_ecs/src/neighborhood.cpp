#include <pcl_ecs/neighborhood.h>

#include "detail/pair_key.h"
#include "detail/simd.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#ifdef __SSE2__
#include <emmintrin.h>
#endif
#ifdef PCL_ECS_HAVE_AVX2_PATH
#include <immintrin.h>
#endif

namespace pcl_ecs
{

namespace
{
using Pair = std::pair<float, int>;  // squared distance, index: ordered by distance, then index

/// Write the k first pairs of `row` (sorted) as row i of the table, repeating the last when short.
void storeRow(std::vector<Pair>& row, int k, std::ptrdiff_t i, NeighborhoodTable& table)
{
  row.resize(std::min<std::size_t>(row.size(), static_cast<std::size_t>(k)));
  // A back end may return fewer than k + 1 (it should not with n > k); repeat the last.
  while (row.size() < static_cast<std::size_t>(k))
    row.push_back(row.empty() ? std::make_pair(0.f, static_cast<int>(i)) : row.back());
  int* out_i = table.row(static_cast<std::size_t>(i));
  for (int j = 0; j < k; ++j)
    out_i[j] = row[static_cast<std::size_t>(j)].second;
}

/// Work space of one thread.
struct Worker
{
  pcl::Indices found, found_far;
  std::vector<float> d2, d2_far;
  std::vector<Pair> row;
  std::vector<float> cx, cy, cz;  // candidates of a block, by coordinate
  std::vector<int> cid;
  std::vector<std::uint64_t> keys;
  std::vector<std::uint32_t> sel;  // candidates within a bound
  std::vector<float> dist;  // squared distances of one point to the candidates
  std::vector<float> rank_d;  // the candidates within the bound, for ranking
  std::vector<int> rank_id;
  std::vector<float> kth;  // K-th distances of the current block
  float margin = 0.f;  // recent K-th neighbour distance: how far around a block to look
  bool wide = detail::useAvx2();  // the AVX2 versions of the loops (the same results)
};

/// The K nearest of point i (returned: the K-th distance) by one query of `search` per attempt.
/// k + 1 because the point finds itself (or a duplicate of itself) first, + 1 to see past the k-th
/// distance: when points tie at that distance, which of them a back end returns depends on its tree, so ask for more until
/// every tied point is in (then the smallest indices win, whatever the tree: a tile of the
/// out-of-core path and the whole cloud agree).
float nearestOfOne(const LocalCloud& cloud, const pcl::search::Search<pcl::PointXYZ>& search, int k,
                   std::ptrdiff_t i, Worker& w, NeighborhoodTable& table)
{
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(cloud.size());
  int ask = k + 2;
  for (;;)
  {
    search.nearestKSearch(cloud[i], std::min<int>(ask, static_cast<int>(n)), w.found, w.d2);
    w.row.clear();
    bool self_seen = false;
    for (std::size_t j = 0; j < w.found.size(); ++j)
    {
      if (!self_seen && w.found[j] == i)
      {
        self_seen = true;
        continue;
      }
      w.row.emplace_back(w.d2[j], w.found[j]);
    }
    std::sort(w.row.begin(), w.row.end());  // distance, then index: independent of the back end
    const bool complete = static_cast<std::ptrdiff_t>(w.found.size()) < ask || ask >= n ||
                          w.row.size() <= static_cast<std::size_t>(k) ||
                          w.row.back().first > w.row[static_cast<std::size_t>(k) - 1].first;
    if ((complete && self_seen) || ask >= n)
      break;
    ask = static_cast<int>(std::min<std::ptrdiff_t>(n, 2 * static_cast<std::ptrdiff_t>(ask)));
  }
  const float kth = w.row.empty() ? 0.f : std::sqrt(w.row[std::min<std::size_t>(w.row.size(), k) - 1].first);
  storeRow(w.row, k, i, table);
  return kth;
}

/// Keep `key` among the k smallest so far: keys[0, filled) sorted, filled <= k.
inline void offerKey(std::uint64_t key, std::size_t k, std::uint64_t* keys, std::size_t& filled)
{
  if (filled == k && key >= keys[k - 1])
    return;
  std::size_t pos = filled < k ? filled++ : k - 1;
  while (pos > 0 && keys[pos - 1] > key)
  {
    keys[pos] = keys[pos - 1];
    --pos;
  }
  keys[pos] = key;
}

/// The positions j < m with d[j] <= bound, in order, into sel; returns how many. d and sel have
/// room for m rounded up to a multiple of 4. Four candidates per instruction, no branch: each
/// quadruple's mask picks a precomputed packing of its positions.
std::size_t selectWithinPortable(const float* d, std::size_t m, float bound, std::uint32_t* sel)
{
  const std::size_t m4 = (m + 3) & ~std::size_t{3};
  std::size_t c = 0;
#ifdef __SSE2__
  struct Packing
  {
    alignas(16) std::uint32_t lane[4];
    std::uint32_t count;
  };
  static const auto kPack = [] {
    std::array<Packing, 16> t{};
    for (unsigned mask = 0; mask < 16; ++mask)
    {
      t[mask].count = 0;
      for (std::uint32_t l = 0; l < 4; ++l)
        if (mask & (1u << l))
          t[mask].lane[t[mask].count++] = l;
    }
    return t;
  }();
  const __m128 limit = _mm_set1_ps(bound);
  for (std::size_t j = 0; j < m4; j += 4)
  {
    const int mask = _mm_movemask_ps(_mm_cmple_ps(_mm_loadu_ps(d + j), limit));
    const Packing& p = kPack[static_cast<std::size_t>(mask)];
    const __m128i lanes = _mm_add_epi32(_mm_load_si128(reinterpret_cast<const __m128i*>(p.lane)),
                                        _mm_set1_epi32(static_cast<int>(j)));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(sel + c), lanes);  // c + 4 <= m4: in room
    c += p.count;
  }
#else
  for (std::size_t j = 0; j < m4; ++j)
  {
    sel[c] = static_cast<std::uint32_t>(j);
    c += d[j] <= bound ? 1 : 0;
  }
#endif
  while (c > 0 && sel[c - 1] >= m)
    --c;  // padding past m (only an infinite bound reaches it)
  return c;
}

#ifdef PCL_ECS_HAVE_AVX2_PATH
/// selectWithin eight candidates per instruction: d and sel have room for m rounded up to a
/// multiple of 8 (d padded with +inf).
PCL_ECS_AVX2_TARGET std::size_t selectWithinAvx2(const float* d, std::size_t m, float bound,
                                                 std::uint32_t* sel)
{
  const std::size_t m8 = (m + 7) & ~std::size_t{7};
  const __m256 limit = _mm256_set1_ps(bound);
  std::size_t c = 0;
  for (std::size_t j = 0; j < m8; j += 8)
  {
    const int mask = _mm256_movemask_ps(_mm256_cmp_ps(_mm256_loadu_ps(d + j), limit, _CMP_LE_OQ));
    const __m256i lanes = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(detail::kCompress8.lanes[mask]));
    const __m256i positions = _mm256_add_epi32(lanes, _mm256_set1_epi32(static_cast<int>(j)));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(sel + c), positions);  // c + 8 <= m8: in room
    c += detail::kCompress8.count[mask];
  }
  while (c > 0 && sel[c - 1] >= m)
    --c;  // padding past m (only an infinite bound reaches it)
  return c;
}
#endif

/// The positions j < m with d[j] <= bound, in order, into sel; returns how many. d and sel have
/// room for m rounded up to a multiple of 8, d padded with +inf.
std::size_t selectWithin(const float* d, std::size_t m, float bound, std::uint32_t* sel, bool wide)
{
#ifdef PCL_ECS_HAVE_AVX2_PATH
  if (wide)
    return selectWithinAvx2(d, m, bound, sel);
#endif
  (void)wide;
  return selectWithinPortable(d, m, bound, sel);
}

/// Candidates within a bound ranked by counting (below) when at most this many: the count is
/// quadratic, the insertion it replaces linear but with a mispredicted branch per shift.
constexpr std::size_t kRankMax = 32;

/// The k smallest (distance, index) pairs of c candidates as sorted keys, c >= k, indices
/// distinct, distances finite and >= 0; `d` and `id` have room for c rounded up to a multiple of
/// 8 (smallestByRank below). Each candidate's place is the number of candidates that order before
/// it (a smaller distance, or the same and a smaller index), counted without a branch (the loop
/// vectorises: compares and a masked count).
void smallestByRankPortable(float* d, int* id, std::size_t c, std::size_t k, std::uint64_t* keys)
{
  const std::size_t padded = (c + 3) & ~std::size_t{3};
  for (std::size_t b = c; b < padded; ++b)
  {
    d[b] = std::numeric_limits<float>::infinity();  // orders before no finite distance
    id[b] = std::numeric_limits<int>::max();
  }
  for (std::size_t a = 0; a < c; ++a)
  {
    const float x = d[a];
    const int xi = id[a];
    int before = 0;
    for (std::size_t b = 0; b < padded; ++b)
      before += (d[b] < x) | ((d[b] == x) & (id[b] < xi));
    if (static_cast<std::size_t>(before) < k)
      keys[before] = pairKey(d[a], id[a]);
  }
}

/// Squared distances (float, as the search computes them) from q to the m candidates.
PCL_ECS_ALWAYS_INLINE void squaredDistancesBody(const pcl::PointXYZ& q, const float* cx,
                                                 const float* cy, const float* cz, std::size_t m,
                                                 float* d2)
{
  for (std::size_t j = 0; j < m; ++j)
  {
    const float dx = q.x - cx[j], dy = q.y - cy[j], dz = q.z - cz[j];
    d2[j] = dx * dx + dy * dy + dz * dz;
  }
}

void squaredDistancesPortable(const pcl::PointXYZ& q, const float* cx, const float* cy,
                              const float* cz, std::size_t m, float* d2)
{
  squaredDistancesBody(q, cx, cy, cz, m, d2);
}

#ifdef PCL_ECS_HAVE_AVX2_PATH
/// smallestByRank with the roles turned: eight candidates' places counted at once, one pass over
/// the c candidates each (a broadcast and three compares per candidate, no horizontal sums).
/// `d` and `id` have room for c rounded up to a multiple of 8.
PCL_ECS_AVX2_TARGET void smallestByRankAvx2(float* d, int* id, std::size_t c, std::size_t k,
                                            std::uint64_t* keys)
{
  const std::size_t padded = (c + 7) & ~std::size_t{7};
  for (std::size_t b = c; b < padded; ++b)
  {
    d[b] = std::numeric_limits<float>::infinity();  // lanes past c: computed, never stored
    id[b] = std::numeric_limits<int>::max();
  }
  for (std::size_t a = 0; a < c; a += 8)
  {
    const __m256 ad = _mm256_loadu_ps(d + a);
    const __m256i ai = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(id + a));
    __m256i before = _mm256_setzero_si256();
    for (std::size_t b = 0; b < c; ++b)
    {
      const __m256 bd = _mm256_broadcast_ss(d + b);
      const __m256i bi = _mm256_set1_epi32(id[b]);
      const __m256 tie_first = _mm256_and_ps(_mm256_cmp_ps(bd, ad, _CMP_EQ_OQ),
                                             _mm256_castsi256_ps(_mm256_cmpgt_epi32(ai, bi)));
      const __m256 orders_before = _mm256_or_ps(_mm256_cmp_ps(bd, ad, _CMP_LT_OQ), tie_first);
      before = _mm256_sub_epi32(before, _mm256_castps_si256(orders_before));  // mask is -1
    }
    alignas(32) std::int32_t place[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(place), before);
    const std::size_t lanes = std::min<std::size_t>(8, c - a);
    for (std::size_t l = 0; l < lanes; ++l)
      if (static_cast<std::size_t>(place[l]) < k)
        keys[place[l]] = pairKey(d[a + l], id[a + l]);
  }
}

PCL_ECS_AVX2_TARGET void squaredDistancesAvx2(const pcl::PointXYZ& q, const float* cx,
                                              const float* cy, const float* cz, std::size_t m,
                                              float* d2)
{
  squaredDistancesBody(q, cx, cy, cz, m, d2);
}
#endif

void smallestByRank(float* d, int* id, std::size_t c, std::size_t k, std::uint64_t* keys, bool wide)
{
#ifdef PCL_ECS_HAVE_AVX2_PATH
  if (wide)
    return smallestByRankAvx2(d, id, c, k, keys);
#endif
  (void)wide;
  smallestByRankPortable(d, id, c, k, keys);
}

void squaredDistances(const pcl::PointXYZ& q, const float* cx, const float* cy, const float* cz,
                      std::size_t m, float* d2, bool wide)
{
#ifdef PCL_ECS_HAVE_AVX2_PATH
  if (wide)
    return squaredDistancesAvx2(q, cx, cy, cz, m, d2);
#endif
  (void)wide;
  squaredDistancesPortable(q, cx, cy, cz, m, d2);
}

/// The k smallest (squared distance, index) keys of point i, q itself left out, into `keys` (sorted)
/// from one radius query of `radius`, which should hold at least k other points (the caller knows k
/// points that near). Returns how many keys it found (k unless a back end rounds differently).
std::size_t nearestWithin(const LocalCloud& cloud, const pcl::search::Search<pcl::PointXYZ>& search, int k,
                          std::ptrdiff_t i, double radius, Worker& w, std::uint64_t* keys)
{
  search.radiusSearch(cloud[i], radius, w.found_far, w.d2_far);
  const std::size_t ku = static_cast<std::size_t>(k);
  std::size_t filled = 0;
  for (std::size_t j = 0; j < w.found_far.size(); ++j)
  {
    if (w.found_far[j] == i)
      continue;
    offerKey(pairKey(w.d2_far[j], w.found_far[j]), ku, keys, filled);
  }
  return filled;
}

/// The margin for the next block: the K-th distance that three quarters of this block's points
/// do not exceed (an isolated outlier does not inflate it; points beyond are answered alone).
void learnMargin(Worker& w)
{
  if (w.kth.empty())
    return;
  const auto q = w.kth.begin() + static_cast<std::ptrdiff_t>((3 * (w.kth.size() - 1)) / 4);
  std::nth_element(w.kth.begin(), q, w.kth.end());
  if (*q > 0.f)
    w.margin = *q;
}

constexpr std::ptrdiff_t kBlock = 32;          // consecutive points answered together
constexpr std::size_t kMaxCandidates = 4096;   // beyond this a block's points are answered alone

/// The gathered candidates' coordinates and indices in the worker's arrays (distances padded to
/// whole groups of 8 for the selection).
inline void loadCandidates(const LocalCloud& cloud, Worker& w)
{
  const std::size_t m = w.found.size();
  w.cx.resize(m);
  w.cy.resize(m);
  w.cz.resize(m);
  w.cid.resize(m);
  const std::size_t m8 = (m + 7) & ~std::size_t{7};  // whole groups of 8 for the selection
  w.dist.resize(m8);
  for (std::size_t j = m; j < m8; ++j)
    w.dist[j] = std::numeric_limits<float>::infinity();  // within no bound
  for (std::size_t j = 0; j < m; ++j)
  {
    const pcl::PointXYZ& p = cloud[w.found[j]];
    w.cx[j] = p.x;
    w.cy[j] = p.y;
    w.cz[j] = p.z;
    w.cid[j] = w.found[j];
  }
}

/// How many of the m candidates (their squared distances in d2) to rank for point q: their
/// positions in w.sel, or m when every candidate must be ranked.
inline std::size_t candidatesWithinBound(const LocalCloud& cloud, const pcl::PointXYZ& q, std::ptrdiff_t prev,
                                         float prev_kth, std::size_t ku, std::size_t m, const float* d2, Worker& w)
{
  // Only candidates within a bound can be among the k nearest when at least k others are (q
  // itself is inside every bound): the previous point's k neighbours and that point itself lie
  // within its k-th distance plus the step between the two. Collected without branches, then
  // ranked; if fewer than k + 1 fall inside (rounding), every candidate is ranked. Either way
  // the result is the k smallest keys.
  //
  // First a guess a little past the previous k-th distance (neighbouring points have similar
  // ones): 1.1 × it holds ~1.2 k candidates on a surface (the ranking below is quadratic in
  // their number, so a tight guess pays; 1.06-1.2 were measured); when fewer than k others
  // fall inside it, the sure bound: the previous k-th distance plus the step. The block's first
  // point has no previous one: its guess is the margin (a recent k-th distance), and no sure
  // bound.
  std::size_t inside = m;
  {
    float guess = w.margin * 1.10f, sure = 0.f;
    if (prev >= 0)
    {
      const float step = (q.getVector3fMap() - cloud[prev].getVector3fMap()).norm();
      guess = prev_kth * 1.10f;
      sure = (prev_kth + step) * 1.0001f;
    }
    std::uint32_t* sel = w.sel.data();
    for (const float b : {guess, sure})
    {
      const float bound = b * b;
      const std::size_t c = selectWithin(d2, m, bound, sel, w.wide);
      if (c > ku)
      {
        inside = c;
        if (c > kRankMax)
        {
          // Too many to rank (the density fell since the previous point): try a bound that on
          // a surface (count ~ bound²) would hold ~1.3 (k + 1); kept only if it holds more than k.
          const float tighter = bound * (1.3f * static_cast<float>(ku + 1) / static_cast<float>(c));
          const std::size_t ct = selectWithin(d2, m, tighter, sel, w.wide);
          if (ct > ku)
            inside = ct;
          else
            selectWithin(d2, m, bound, sel, w.wide);
        }
        break;
      }
      if (guess >= sure)
        break;
    }
  }
  return inside;
}

/// The k smallest (distance, index) keys of point i among the candidates (`inside` of them in
/// w.sel, or all m), sorted; returns how many were found (k, or fewer when the candidates are).
inline std::size_t rankCandidates(std::ptrdiff_t i, std::size_t inside, std::size_t m, std::size_t ku,
                                  const float* d2, std::uint64_t* keys, Worker& w)
{
  std::size_t filled = 0;
  auto consider = [&](std::size_t j) {
    if (w.cid[j] != i)
      offerKey(pairKey(d2[j], w.cid[j]), ku, keys, filled);
  };
  if (inside < m && inside <= kRankMax)
  {
    // A bound holds more than k candidates (q among them at most once): k or more others.
    std::size_t c = 0;
    for (std::size_t s = 0; s < inside; ++s)
    {
      const std::uint32_t j = w.sel[s];
      w.rank_d[c] = d2[j];
      w.rank_id[c] = w.cid[j];
      c += w.cid[j] != i ? 1 : 0;
    }
    smallestByRank(w.rank_d.data(), w.rank_id.data(), c, ku, keys, w.wide);
    filled = ku;
  }
  else if (inside < m)
    for (std::size_t s = 0; s < inside; ++s)
      consider(w.sel[s]);
  else
    for (std::size_t j = 0; j < m; ++j)
      consider(j);
  return filled;
}

/// The K nearest of the points [first, last) together: one radius query of `search` around the
/// block gathers every point that can be among their neighbours, then each point picks its K
/// nearest from those by brute force. A point whose K-th distance does not stay inside the
/// gathered ball (by a safety margin) is answered on its own, so the table is exact whatever the
/// blocks, the margin or the thread (the same pairs, ordered by distance then index).
void nearestOfBlock(const LocalCloud& cloud, const pcl::search::Search<pcl::PointXYZ>& search, int k,
                    std::ptrdiff_t first, std::ptrdiff_t last, Worker& w, NeighborhoodTable& table)
{
  if (w.margin <= 0.f)
  {
    w.margin = nearestOfOne(cloud, search, k, first, w, table);  // learn a first margin
    if (++first == last)
      return;
  }
  Eigen::Vector3f lo = cloud[first].getVector3fMap(), hi = lo;
  for (std::ptrdiff_t i = first + 1; i < last; ++i)
  {
    lo = lo.cwiseMin(cloud[i].getVector3fMap());
    hi = hi.cwiseMax(cloud[i].getVector3fMap());
  }
  // The query centre is a float point, as the search sees it: distances to it from the points
  // (floats too) are then accurate relative to the distance, not to the coordinates.
  const Eigen::Vector3f centre_f = 0.5f * (lo + hi);
  const Eigen::Vector3d centre = centre_f.cast<double>();
  const double half_diagonal = std::max((lo.cast<double>() - centre).norm(), (hi.cast<double>() - centre).norm());
  const std::ptrdiff_t count = last - first;
  if (count > 1 && half_diagonal > 2.0 * w.margin)
  {
    // A spread-out run (the points straddle a gap or a fold of the surface): halves gather fewer
    // useless candidates.
    const std::ptrdiff_t mid = first + count / 2;
    nearestOfBlock(cloud, search, k, first, mid, w, table);
    nearestOfBlock(cloud, search, k, mid, last, w, table);
    return;
  }
  const double radius = half_diagonal + 1.2 * static_cast<double>(w.margin);
  pcl::PointXYZ c;
  c.getVector3fMap() = centre_f;
  search.radiusSearch(c, radius, w.found, w.d2);
  const std::size_t m = w.found.size();
  w.kth.clear();
  if (m > kMaxCandidates)
  {
    // Far too many candidates (an outlier made the margin large, or the points pile up): answer
    // these points one by one.
    for (std::ptrdiff_t i = first; i < last; ++i)
      w.kth.push_back(nearestOfOne(cloud, search, k, i, w, table));
    learnMargin(w);
    return;
  }
  loadCandidates(cloud, w);
  const std::size_t ku = static_cast<std::size_t>(k);
  w.keys.resize(ku);
  w.sel.resize(w.dist.size());  // whole groups of 8 (loadCandidates)
  w.rank_d.resize(kRankMax + 8);
  w.rank_id.resize(kRankMax + 8);
  std::ptrdiff_t prev = -1;  // the last point of the block answered from the candidates
  float prev_kth = 0.f;
  for (std::ptrdiff_t i = first; i < last; ++i)
  {
    const pcl::PointXYZ& q = cloud[i];
    // Anything not gathered lies farther than `reach` from q.
    const double reach = (radius - (q.getVector3fMap().cast<double>() - centre).norm()) * (1.0 - 1e-4);
    // The k smallest (distance, index) pairs, as integer keys whose order is that of the pairs
    // (the bits of a non-negative float order like the float), kept sorted by insertion.
    std::uint64_t* keys = w.keys.data();
    std::size_t filled = 0;
    float* d2 = w.dist.data();
    squaredDistances(q, w.cx.data(), w.cy.data(), w.cz.data(), m, d2, w.wide);
    const std::size_t inside = candidatesWithinBound(cloud, q, prev, prev_kth, ku, m, d2, w);
    filled = rankCandidates(i, inside, m, ku, d2, keys, w);
    float kth = filled ? keyDistance(keys[filled - 1]) : 0.f;
    // q's k-th neighbour may lie outside the gathered ball, but no farther than the k-th of the
    // candidates: one radius query that far holds every point of the k nearest (ties at that
    // distance included), ranked the same way; the block's candidates stay as they are. Fewer
    // than k candidates (or that query returning fewer than k others): q's own k-nearest search.
    const bool far = filled == ku && !(static_cast<double>(std::sqrt(kth)) <= reach);
    if (filled < ku ||
        (far && nearestWithin(cloud, search, k, i, std::sqrt(static_cast<double>(kth)) * (1.0 + 1e-5), w, keys) < ku))
    {
      w.kth.push_back(nearestOfOne(cloud, search, k, i, w, table));
      continue;
    }
    if (far)
      kth = keyDistance(keys[ku - 1]);
    w.kth.push_back(std::sqrt(kth));
    prev = i;
    prev_kth = std::sqrt(kth);
    int* out_i = table.row(static_cast<std::size_t>(i));
    for (std::size_t j = 0; j < ku; ++j)
      out_i[j] = keyIndex(keys[j]);
  }
  learnMargin(w);
}
}  // namespace

Status computeNeighborhoods(const LocalCloud& cloud, const pcl::search::Search<pcl::PointXYZ>& search,
                            int k, int threads, NeighborhoodTable& table)
{
  table = NeighborhoodTable{};
  if (k < 1)
    return Status::InvalidArgument;
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(cloud.size());
  if (n <= k)
    return Status::TooFewPoints;
  table.allocate(static_cast<std::size_t>(n), k);
  const std::ptrdiff_t blocks = (n + kBlock - 1) / kBlock;

#pragma omp parallel num_threads(threads)
  {
    Worker w;
#pragma omp for schedule(dynamic, 64)
    for (std::ptrdiff_t b = 0; b < blocks; ++b)
      nearestOfBlock(cloud, search, k, b * kBlock, std::min(n, (b + 1) * kBlock), w, table);
  }
  return Status::Ok;
}

}  // namespace pcl_ecs
