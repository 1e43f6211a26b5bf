// cocone_delaunay.cpp — step 1 of the Cocone reconstruction (cocone.h): the Delaunay triangulation (CGAL).
#include "cocone_detail.h"

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Delaunay_triangulation_cell_base_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Spatial_sort_traits_adapter_3.h>
#include <CGAL/spatial_sort.h>
#include <CGAL/property_map.h>
#include <CGAL/Triangulation_cell_base_with_info_3.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>

namespace pcl_ecs
{
namespace surface
{
namespace detail
{

namespace
{
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_3<std::uint32_t, K>;
using CbBase = CGAL::Delaunay_triangulation_cell_base_3<K>;
using Cb = CGAL::Triangulation_cell_base_with_info_3<std::uint32_t, K, CbBase>;
using Tds = CGAL::Triangulation_data_structure_3<Vb, Cb>;
using Delaunay = CGAL::Delaunay_triangulation_3<K, Tds>;
}  // namespace

/// Step 1: the Delaunay triangulation of the distinct finite points (of several at one position
/// the first in input order is the vertex). False, with `error` set, when there is no volume.
bool delaunayCells(const std::vector<Eigen::Vector3d>& points, CoconeStats& st, CellArrays& cells,
                   std::string& error)
{
  // Distinct finite points; of several at one position the first in input order is the vertex.
  std::vector<std::uint32_t> ids;
  ids.reserve(points.size());
  for (std::uint32_t i = 0; i < points.size(); ++i)
  {
    if (points[i].allFinite())
      ids.push_back(i);
    else
      ++st.non_finite_points;
  }
  std::sort(ids.begin(), ids.end(), [&](std::uint32_t a, std::uint32_t b) {
    const Eigen::Vector3d &p = points[a], &q = points[b];
    if (p.x() != q.x())
      return p.x() < q.x();
    if (p.y() != q.y())
      return p.y() < q.y();
    if (p.z() != q.z())
      return p.z() < q.z();
    return a < b;
  });
  std::vector<std::pair<K::Point_3, std::uint32_t>> input;
  input.reserve(ids.size());
  for (std::size_t k = 0; k < ids.size(); ++k)
  {
    const Eigen::Vector3d& p = points[ids[k]];
    if (k > 0 && p == points[ids[k - 1]])
    {
      ++st.duplicate_points;
      continue;
    }
    input.emplace_back(K::Point_3(p.x(), p.y(), p.z()), ids[k]);
  }
  const std::size_t finite_count = ids.size();
  ids.clear();
  ids.shrink_to_fit();
  if (finite_count < 4)
  {
    error = "Cocone needs at least 4 finite points, got " + std::to_string(finite_count);
    return false;
  }
  // Insertion in CGAL's biased randomised Hilbert order (its shuffle has a fixed seed) with the
  // previous vertex as the hint, as CGAL's own range insertion does.
  CGAL::spatial_sort(input.begin(), input.end(),
                     CGAL::Spatial_sort_traits_adapter_3<K, CGAL::First_of_pair_property_map<std::pair<K::Point_3, std::uint32_t>>>());
  Delaunay dt;
  {
    Delaunay::Vertex_handle hint;
    for (const auto& [p, id] : input)
    {
      hint = dt.insert(p, hint == Delaunay::Vertex_handle() ? Delaunay::Cell_handle() : hint->cell());
      hint->info() = id;
    }
  }
  st.vertices = dt.number_of_vertices();
  if (dt.dimension() < 3)
  {
    error = dt.dimension() == 2   ? "the points are coplanar: they span no volume to triangulate"
            : dt.dimension() == 1 ? "the points are collinear: they span no volume to triangulate"
                                  : "all points are at the same position";
    return false;
  }
  st.delaunay_cells = dt.number_of_finite_cells();
  std::uint32_t& cell_count = cells.count;
  for (auto c = dt.all_cells_begin(); c != dt.all_cells_end(); ++c)
    c->info() = cell_count++;
  auto& cell_v = cells.v;
  auto& cell_n = cells.n;
  cell_v.resize(cell_count);
  cell_n.resize(cell_count);
  for (auto c = dt.all_cells_begin(); c != dt.all_cells_end(); ++c)
    for (int k = 0; k < 4; ++k)
    {
      const auto v = c->vertex(k);
      cell_v[c->info()][k] = dt.is_infinite(v) ? kNone : v->info();
      cell_n[c->info()][k] = c->neighbor(k)->info();
    }
  dt.clear();  // the flat arrays hold all that is needed from here on

  return true;
}


}  // namespace detail
}  // namespace surface
}  // namespace pcl_ecs
