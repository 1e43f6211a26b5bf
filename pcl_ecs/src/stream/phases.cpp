// phases.cpp — the out-of-core run's steps of one tile: A (neighbourhoods, normals, eq. 1-3, 7-11),
// B (features, eq. 5), C (the cover), D (the gap bound) (tiled_run.h).
#include "tiled_run.h"

namespace pcl_ecs
{
namespace stream
{
namespace detail
{

/// The per-point values of phase A, packed.
struct AttrView
{
  const std::vector<std::uint8_t>& bytes;
  Eigen::Vector3f normal(std::size_t i) const { return PointAttr::loadNormal(bytes.data() + i * kAttrBytes); }
  double value(std::size_t i, int which) const  // 0 weight, 1 measure, 2 curvature
  {
    return PointAttr::value(bytes.data() + i * kAttrBytes, which);
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

void Runner::geometryTask(int t)
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
  // Sums over this tile's own points (each point counted once in all): Σ measure (in point order,
  // so that its rounding does not depend on the threads), count, neighbourhoods that reach past
  // the halo.
  const Tile& tile = plan_.tree.tiles[static_cast<std::size_t>(t)];
  TileSumsA sums;
  sums.merged = static_cast<double>(d.merged_core);
  for (std::size_t i = 0; i < n; ++i)
    if (d.is_core[i])
      sums.stats.addMeasure(measure[i]);
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
  // The points in one block per thread, each block's lists in its own buffer, joined in order:
  // the same bytes for any thread count.
  const int blocks = std::max(1, tile_threads_);
  std::vector<std::vector<std::uint8_t>> fronts(static_cast<std::size_t>(blocks));
  std::vector<std::size_t> incomplete(static_cast<std::size_t>(blocks), 0);
  std::vector<std::uint8_t> front_count(n, 0xFF);  // 0xFF: a halo point (not needed)
#pragma omp parallel for num_threads(blocks) schedule(static, 1)
  for (int b = 0; b < blocks; ++b)
  {
    const std::size_t first = n * static_cast<std::size_t>(b) / static_cast<std::size_t>(blocks);
    const std::size_t last = n * static_cast<std::size_t>(b + 1) / static_cast<std::size_t>(blocks);
    std::vector<std::uint8_t>& front = fronts[static_cast<std::size_t>(b)];
    front.reserve((last - first) * 2 * FrontierEntry::kBytes);
    for (std::size_t i = first; i < last; ++i)
    {
      PointAttr a;
      a.normal = normals[i];
      a.weight = weights[i];
      a.measure = measure[i];
      a.curvature = curvature[i];
      a.store(attr.data() + i * kAttrBytes);
      if (!d.is_core[i])
        continue;
      const int* nb = table.neighbors(i);
      const Eigen::Vector3d p = plan_.toWorld((*d.cloud)[i].getVector3fMap().cast<double>());
      const double u = p[plan_.axis_u], v = p[plan_.axis_v];
      const double room = std::min({u - (tile.lo[0] - plan_.halo), (tile.hi[0] + plan_.halo) - u,
                                    v - (tile.lo[1] - plan_.halo), (tile.hi[1] + plan_.halo) - v});
      if (std::sqrt(static_cast<double>(sqrDistance(*d.cloud, i, static_cast<std::size_t>(nb[k - 1])))) >
          room * plan_.scale())
        ++incomplete[static_cast<std::size_t>(b)];
      double lowest = std::numeric_limits<double>::infinity();
      std::uint8_t count = 0;
      // Room for all k entries, cut to the ones written: one resize each way per point.
      const std::size_t start = front.size();
      front.resize(start + static_cast<std::size_t>(k) * FrontierEntry::kBytes);
      for (int j = 0; j < k; ++j)
      {
        const auto q = static_cast<std::size_t>(nb[j]);
        const double m = measure[q];
        if (!(m < lowest))
          continue;
        lowest = m;
        FrontierEntry e;
        e.d2 = sqrDistance(*d.cloud, i, q);
        e.index = static_cast<std::uint32_t>(q);
        e.store(front.data() + start + count * FrontierEntry::kBytes);
        ++count;
        if (m <= not_feature)
          break;
      }
      front.resize(start + count * FrontierEntry::kBytes);
      front_count[i] = count;
    }
  }
  std::size_t front_bytes = 0;
  for (std::size_t b = 0; b < fronts.size(); ++b)
  {
    sums.incomplete += static_cast<double>(incomplete[b]);
    front_bytes += fronts[b].size();
  }
  front_count.reserve(n + front_bytes);
  for (std::vector<std::uint8_t>& f : fronts)
  {
    front_count.insert(front_count.end(), f.begin(), f.end());
    std::vector<std::uint8_t>().swap(f);
  }
  fs::create_directories(paths_.root / "a");
  writeVectorAtomic(paths_.frontier(t), front_count);
  {
    // The tile's point count and the count loaded first: loadTile checks the order against both.
    std::vector<std::uint32_t> saved{static_cast<std::uint32_t>(d.file_points), static_cast<std::uint32_t>(d.order.size())};
    saved.insert(saved.end(), d.order.begin(), d.order.end());
    writeVectorAtomic(paths_.order(t), saved);
  }
  writeVectorAtomic(paths_.attr(t), attr);
  writeVectorAtomic(paths_.sumA(t), sums.values());  // the marker: written last
  std::lock_guard<std::mutex> lock(measure_done_mutex_);
  measure_done_ += sums.stats.measure_sum;
}

void Runner::densityTask(int t)
{
  const auto attr_bytes = readVector<std::uint8_t>(paths_.attr(t));
  const AttrView attr{attr_bytes};
  const std::size_t n = attr.size();
  std::vector<double> density(n, 0.0);
  TileSumsB sums;  // over the tile's own points
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
      for (std::uint8_t e = 0; e < count; ++e, at += FrontierEntry::kBytes)
      {
        if (found)
          continue;
        if (at + FrontierEntry::kBytes > front.size())
          failDamaged(lists_damaged);
        const FrontierEntry entry = FrontierEntry::load(front.data() + at);
        const float d2 = entry.d2;
        const std::uint32_t index = entry.index;
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
        sums.features += 1.0;
      else
        sums.stats.addNonFeature(density[i], attr.value(i, 0), attr.value(i, 2));
    }
    if (complete)
    {
      fs::create_directories(paths_.root / "b");
      writeVectorAtomic(paths_.dens(t), density);
      writeVectorAtomic(paths_.sumB(t), sums.values());
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
  sums = TileSumsB{};
  sums.searched = 1.0;
  for (std::size_t i = 0; i < n; ++i)
  {
    if (!d.is_core[i])
      continue;
    if (is_feature[i])
      sums.features += 1.0;
    else
      sums.stats.addNonFeature(density[i], attr.value(i, 0), attr.value(i, 2));
  }
  fs::create_directories(paths_.root / "b");
  writeVectorAtomic(paths_.dens(t), density);
  writeVectorAtomic(paths_.sumB(t), sums.values());
  dropScratch({paths_.frontier(t)});
}

void Runner::coverTask(int t)
{
  TileData d = loadTile(t);
  const std::size_t n = d.size();
  const std::size_t step = header_.point_step;
  const auto attr_bytes = readVector<std::uint8_t>(paths_.attr(t));
  const AttrView attr{attr_bytes};
  const auto density = readVector<double>(paths_.dens(t));
  NormalList normals(n);
  std::vector<double> weights(n), curvature(n);
#pragma omp parallel for schedule(static) num_threads(tile_threads_) if (n >= 8192)
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
  const std::vector<std::uint8_t> pre_covered = coveredByEarlierColours(t, d);

  BoxTreeSearch tree(/*sorted=*/false, tile_threads_);  // unsorted radius results; a tile is in Hilbert order
  tree.setInputCloud(d.cloud);
  CoverInput in = makeCoverInput(*d.cloud, normals, weights, is_feature, curvature, density, stats_,
                                 summary_.bbox_diagonal * plan_.scale(), tree);
  in.centre_allowed = &d.is_core;
  in.pre_covered = &pre_covered;
  Parameters p = params_;
  p.threads = tile_threads_;
  CoverOutput cover;
  coverWithBalls(in, p, params_.error_threshold, cover);
  relaxRepresentatives(in, p, cover);

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

  writeClaims(t, d, cover);
  if (params_.max_gap_factor > 0.0)
    writeVectorAtomic(paths_.gapCandidates(t), gapCandidates(d, is_feature, normals, cover));
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

std::vector<std::uint8_t> Runner::coveredByEarlierColours(int t, const TileData& d) const
{
  const std::size_t n = d.size();
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

  return pre_covered;
}

void Runner::writeClaims(int t, const TileData& d, const CoverOutput& cover) const
{
  if (plan_.tree.tiles.size() < 2)
    return;  // one tile: no other tile reads claims
  const std::size_t n = d.size();
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
}

// Gap candidates for phase D: the tile's own non-feature points farther than the gap from every
// output point this tile knows (its balls, the feature points of its core and halo). Points
// within it are within it of the final output too, so phase D reads only these.
std::vector<std::uint8_t> Runner::gapCandidates(const TileData& d, const std::vector<std::uint8_t>& is_feature,
                                                const NormalList& normals, const CoverOutput& cover) const
{
  const std::size_t n = d.size();
  const std::size_t step = header_.point_step;
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
  return candidates;
}

void Runner::setRecordNormal(std::uint8_t* rec, Eigen::Vector3f nrm, const Eigen::Vector3d& at) const
{
  const std::array<int, 3>& f = normal_fields_;
  if (f[0] < 0 || f[1] < 0 || f[2] < 0)
    return;
  nrm = orientTowards(nrm, at, viewpoint_local_);
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
void Runner::gapTask(int t)
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

}  // namespace detail
}  // namespace stream
}  // namespace pcl_ecs
