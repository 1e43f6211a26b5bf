// cocone_test.cpp — steps 3 and 4 of the Cocone reconstruction (cocone.h): the cocone test, the
// regular samples and the candidate triangles.
#include "cocone_detail.h"

#include <cmath>
#include <deque>
#include <limits>

namespace pcl_ecs
{
namespace surface
{
namespace detail
{

/// Step 3: the cocone test of every Delaunay triangle. `radius` gets r_p per vertex: how far the
/// accepted dual edges stay in its cocone.
std::vector<Facet> coconeFacets(const std::vector<Eigen::Vector3d>& points, const CellArrays& ca, const Poles& poles,
                                const CoconeParameters& params, std::vector<double>& radius)
{
  const std::size_t n = points.size();
  const std::uint32_t cell_count = ca.count;
  const auto& cell_v = ca.v;
  const auto& cell_n = ca.n;
  const auto& cc = poles.cc;
  const auto& cell_kind = poles.cell_kind;
  const auto& has_axis = poles.has_axis;
  const auto& axis = poles.axis;
  const auto cells = static_cast<std::int64_t>(cell_count);
  std::vector<Facet> facets;
  radius.assign(n, 0.0);
  const double cos_limit = std::sin(params.cocone_angle);  // cos(π/2 − θ)
  // Facet (c, i) is visited from the cell with the smaller index; results land in a slot per
  // (cell, i), so the parallel loop gives the same array whatever the thread count.
  std::vector<Facet> slots(static_cast<std::size_t>(cell_count) * 4);
#pragma omp parallel for schedule(dynamic, 256)
  for (std::int64_t ci = 0; ci < cells; ++ci)
  {
    const auto c = static_cast<std::uint32_t>(ci);
    for (int i = 0; i < 4; ++i)
    {
      Facet& fc = slots[static_cast<std::size_t>(c) * 4 + i];
      fc.accept = 0;
      const std::uint32_t nb = cell_n[c][i];
      if (nb < c)
        continue;
      // The facet opposite vertex i must be finite.
      const std::uint32_t f0 = cell_v[c][(i + 1) & 3], f1 = cell_v[c][(i + 2) & 3], f2 = cell_v[c][(i + 3) & 3];
      if (f0 == kNone || f1 == kNone || f2 == kNone)
        continue;
      Eigen::Vector3d start, end;
      bool ray = false;
      const char s1 = cell_kind[c], s2 = cell_kind[nb];
      if (s1 == 1 && s2 == 1)
      {
        start = cc[c];
        end = cc[nb];
      }
      else if (s1 == 1 && s2 == 2)
      {
        start = cc[c];
        end = cc[nb];
        ray = true;
      }
      else if (s1 == 2 && s2 == 1)
      {
        start = cc[nb];
        end = cc[c];
        ray = true;
      }
      else if (s1 == 1 || s2 == 1)
        start = end = (s1 == 1 ? cc[c] : cc[nb]);  // the other circumcentre is not representable
      else
        continue;
      fc.v = {f0, f1, f2};
      for (int k = 0; k < 3; ++k)
      {
        const std::uint32_t v = fc.v[k];
        fc.radius[k] = 0;
        if (!has_axis[v])
          continue;
        const CoconeHit h = coconeIntersect(points[v], axis[v], cos_limit, start, end, ray);
        if (h.hit)
        {
          fc.accept |= static_cast<std::uint8_t>(1u << k);
          fc.radius[k] = static_cast<float>(std::min<double>(h.radius, std::numeric_limits<float>::max()));
          if (std::isinf(h.radius))
            fc.radius[k] = std::numeric_limits<float>::infinity();
        }
      }
    }
  }
  for (const Facet& f : slots)
    if (f.accept)
    {
      facets.push_back(f);
      for (int k = 0; k < 3; ++k)
        if (f.accept & (1u << k))
          radius[f.v[k]] = std::max(radius[f.v[k]], static_cast<double>(f.radius[k]));
    }
  return facets;
}

/// Step 4 (Dey-Giesen): the regular samples, those whose cocone is thin and agrees with their
/// cocone neighbours'; the others are boundary samples. Without boundary detection every vertex
/// with an axis is regular.
std::vector<char> regularSamples(const std::vector<Eigen::Vector3d>& points, const Poles& poles,
                                 const std::vector<Facet>& facets, const std::vector<double>& radius,
                                 const CoconeParameters& params, CoconeStats& st)
{
  const std::size_t n = points.size();
  const auto& has_axis = poles.has_axis;
  const auto& axis = poles.axis;
  const auto& height = poles.height;
  const auto& is_vertex = poles.is_vertex;
  std::vector<char> regular(n, 0);
  for (std::uint32_t i = 0; i < n; ++i)
    regular[i] = has_axis[i];
  if (params.detect_boundaries)
  {
    std::vector<char> ratio_ok(n, 0);
    for (std::uint32_t i = 0; i < n; ++i)
    {
      const double h = height[i] > 0 ? height[i] : std::numeric_limits<double>::infinity();
      ratio_ok[i] = has_axis[i] && std::isfinite(radius[i]) && radius[i] <= params.boundary_ratio * h;
    }
    // Cocone neighbours: q is one for p when a triangle pq* passes p's cocone.
    std::vector<std::uint32_t> off(n + 1, 0);
    for (const Facet& f : facets)
      for (int k = 0; k < 3; ++k)
        if (f.accept & (1u << k))
          off[f.v[k] + 1] += 2;
    for (std::size_t i = 0; i < n; ++i)
      off[i + 1] += off[i];
    std::vector<std::uint32_t> nbr(off.back());
    std::vector<std::uint32_t> pos(off.begin(), off.end() - 1);
    for (const Facet& f : facets)
      for (int k = 0; k < 3; ++k)
        if (f.accept & (1u << k))
        {
          nbr[pos[f.v[k]]++] = f.v[(k + 1) % 3];
          nbr[pos[f.v[k]]++] = f.v[(k + 2) % 3];
        }
    const double cos_normal = std::cos(params.boundary_normal_angle);
    auto agree = [&](std::uint32_t p, std::uint32_t q) {
      return has_axis[q] && std::abs(axis[p].dot(axis[q])) >= cos_normal;
    };
    std::fill(regular.begin(), regular.end(), 0);
    std::deque<std::uint32_t> queue;
    for (std::uint32_t p = 0; p < n; ++p)
    {
      if (!ratio_ok[p] || off[p] == off[p + 1])
        continue;
      bool all = true;
      for (std::uint32_t k = off[p]; k < off[p + 1] && all; ++k)
        all = agree(p, nbr[k]);
      if (all)
      {
        regular[p] = 1;
        queue.push_back(p);
      }
    }
    while (!queue.empty())
    {
      const std::uint32_t p = queue.front();
      queue.pop_front();
      for (std::uint32_t k = off[p]; k < off[p + 1]; ++k)
      {
        const std::uint32_t q = nbr[k];
        if (!regular[q] && ratio_ok[q] && agree(p, q))
        {
          regular[q] = 1;
          queue.push_back(q);
        }
      }
    }
    for (std::uint32_t i = 0; i < n; ++i)
      st.boundary_samples += (is_vertex[i] && !regular[i]) ? 1 : 0;
  }

  return regular;
}

/// The radius each sample is judged by in the ball-overlap rule (kApartBallRatio): its own, or,
/// for a sample of radius 0 (a feature point, a point the gap bound or the target size kept as it
/// is), the radius of its nearest Delaunay neighbour that has one (ties: the larger radius), so
/// that such a point is not a neighbour on the surface of samples far from overlapping the balls
/// around it. Samples whose radius is not finite, and radius-0 samples with no such neighbour,
/// stay unknown (0): the gap guard alone judges their triangles. Independent of the facets' order.
std::vector<double> overlapRadii(const std::vector<Eigen::Vector3d>& points, const std::vector<Facet>& facets,
                                 const std::vector<double>& sample_radius)
{
  auto known = [&](std::uint32_t v) { return std::isfinite(sample_radius[v]) && sample_radius[v] > 0.0; };
  std::vector<double> radius(sample_radius.size(), 0.0);
  std::vector<double> nearest(sample_radius.size(), std::numeric_limits<double>::infinity());
  for (std::size_t v = 0; v < radius.size(); ++v)
    if (known(static_cast<std::uint32_t>(v)))
      radius[v] = sample_radius[v];
  for (const Facet& f : facets)
    for (int k = 0; k < 3; ++k)
    {
      const std::uint32_t v = f.v[k];
      if (sample_radius[v] != 0.0)
        continue;
      for (int j = 1; j < 3; ++j)
      {
        const std::uint32_t u = f.v[(k + j) % 3];
        if (!known(u))
          continue;
        const double d2 = (points[u] - points[v]).squaredNorm();
        if (d2 < nearest[v] || (d2 == nearest[v] && sample_radius[u] > radius[v]))
        {
          nearest[v] = d2;
          radius[v] = sample_radius[u];
        }
      }
    }
  return radius;
}

/// The candidate triangles: those accepted by the cocones of all their regular vertices (at least
/// one), without the ones that span a gap in the sampling or, given each sample's ball radius,
/// join two balls that do not overlap, in a canonical order. `spacing` gets the local sample
/// spacing per vertex (the median candidate edge length there).
std::vector<Triangle> candidateTriangles(const std::vector<Eigen::Vector3d>& points, const std::vector<Facet>& facets,
                                         const std::vector<char>& regular, const CoconeParameters& params,
                                         CoconeStats& st, std::vector<double>& spacing, const std::vector<double>& sample_radius)
{
  const std::size_t n = points.size();
  std::vector<Triangle> cand;
  cand.reserve(facets.size());
  for (const Facet& f : facets)
  {
    bool ok = true, any_regular = false;
    for (int k = 0; k < 3 && ok; ++k)
    {
      if (!regular[f.v[k]])
        continue;
      any_regular = true;
      ok = (f.accept >> k) & 1u;
    }
    if (ok && any_regular)
      cand.push_back(f.v);
  }
  // Local sample spacing: the median length of the candidate edges at a vertex (robust to the
  // clumps of random sampling, which make nearest-neighbour distances tiny).
  spacing.assign(n, 0.0);
  {
    std::vector<std::uint32_t> off(n + 1, 0);
    for (const Triangle& t : cand)
      for (std::uint32_t x : t)
        off[x + 1] += 2;
    for (std::size_t i = 0; i < n; ++i)
      off[i + 1] += off[i];
    std::vector<float> len(off.back());
    std::vector<std::uint32_t> pos(off.begin(), off.end() - 1);
    for (const Triangle& t : cand)
      for (int k = 0; k < 3; ++k)
      {
        const auto d = static_cast<float>((points[t[k]] - points[t[(k + 1) % 3]]).norm());
        len[pos[t[k]]++] = d;
        len[pos[t[(k + 1) % 3]]++] = d;
      }
    for (std::size_t i = 0; i < n; ++i)
    {
      if (off[i + 1] == off[i])
        continue;
      auto first = len.begin() + off[i], last = len.begin() + off[i + 1];
      auto mid = first + (last - first) / 2;
      std::nth_element(first, mid, last);
      spacing[i] = *mid;
    }
  }
  if (params.max_edge_ratio > 0)
  {
    // Undersampled spot: an edge far longer than the sample spacing at all three vertices spans a
    // gap in the sampling, not the surface.
    std::size_t kept = 0;
    for (const Triangle& t : cand)
    {
      const double local = std::max({spacing[t[0]], spacing[t[1]], spacing[t[2]]});
      const double longest = std::max({(points[t[0]] - points[t[1]]).norm(), (points[t[1]] - points[t[2]]).norm(),
                                       (points[t[2]] - points[t[0]]).norm()});
      if (longest > params.max_edge_ratio * local)
        ++st.gap_triangles;
      else
        cand[kept++] = t;
    }
    cand.resize(kept);
  }
  if (!sample_radius.empty())
  {
    // Samples whose balls do not overlap are not neighbours on the surface (kApartBallRatio).
    const std::vector<double> radius = overlapRadii(points, facets, sample_radius);
    auto known = [&](std::uint32_t v) { return radius[v] > 0.0; };
    std::size_t kept = 0;
    for (const Triangle& t : cand)
    {
      bool apart = false;
      for (int k = 0; k < 3 && !apart; ++k)
      {
        const std::uint32_t a = t[k], b = t[(k + 1) % 3];
        apart = known(a) && known(b) &&
                (points[a] - points[b]).norm() > kApartBallRatio * (radius[a] + radius[b]);
      }
      if (apart)
        ++st.apart_triangles;
      else
        cand[kept++] = t;
    }
    cand.resize(kept);
  }
  // Canonical order (and vertex order within a triangle) so that what follows does not depend on
  // the order in which CGAL stores its cells.
  for (Triangle& t : cand)
    std::sort(t.begin(), t.end());
  sortTriangles(cand, n);
  st.candidate_triangles = cand.size();
  return cand;
}


}  // namespace detail
}  // namespace surface
}  // namespace pcl_ecs
