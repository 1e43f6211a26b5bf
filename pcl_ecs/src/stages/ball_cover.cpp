#include <pcl_ecs/stages/ball_cover.h>

#include <pcl_ecs/stages/adaptive_tolerance.h>
#include <pcl_ecs/stages/hull_coverage.h>
#include <pcl_ecs/stages/kernel.h>
#include <pcl_ecs/stages/radius_solver.h>
#include <pcl_ecs/stages/representative_fit.h>
#include <pcl_ecs/stages/seeded_order.h>

#include "../detail/radix_sort.h"
#include "../detail/simd.h"
#include "../detail/uninitialised_allocator.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>

#ifdef __SSE2__
#include <emmintrin.h>
#endif

namespace pcl_ecs
{

namespace
{
/// out[i] = sqrt(d2[i]) in double, correctly rounded (the same bits in every build): two per
/// instruction by SSE2 intrinsics (GCC leaves the plain loop scalar for SSE2), four in the AVX2
/// build (where it vectorises the plain loop).
void squareRootsPortable(const float* d2, std::size_t n, double* out)
{
  std::size_t i = 0;
#ifdef __SSE2__
  for (; i + 1 < n; i += 2)
  {
    const __m128 pair = _mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(d2 + i)));
    _mm_storeu_pd(out + i, _mm_sqrt_pd(_mm_cvtps_pd(pair)));
  }
#endif
  for (; i < n; ++i)
    out[i] = std::sqrt(static_cast<double>(d2[i]));
}

#ifdef PCL_ECS_HAVE_AVX2_PATH
PCL_ECS_AVX2_TARGET void squareRootsAvx2(const float* d2, std::size_t n, double* out)
{
  for (std::size_t i = 0; i < n; ++i)
    out[i] = std::sqrt(static_cast<double>(d2[i]));
}
#endif

void squareRoots(const float* d2, std::size_t n, double* out)
{
#ifdef PCL_ECS_HAVE_AVX2_PATH
  if (detail::useAvx2())
    return squareRootsAvx2(d2, n, out);
#endif
  squareRootsPortable(d2, n, out);
}

/// Candidates of one ball: the non-feature points of a radius search, grown on demand. A larger
/// query appends only the shell it adds (points past the previous query's radius): those held
/// keep their place, and the solver their planes.
class RadiusQuerySource : public CandidateSource
{
public:
  RadiusQuerySource(const pcl::search::Search<pcl::PointXYZ>& search,
                    const std::vector<std::uint8_t>& is_feature, const pcl::PointXYZ& centre,
                    double max_radius, double first_radius, pcl::Indices& found, std::vector<float>& d2,
                    std::vector<double>& distance)
    : search_(search), is_feature_(is_feature), centre_(centre), max_radius_(max_radius),
      next_radius_(first_radius), found_(found), d2_(d2), distance_(distance)
  {
  }

  bool ensure(double needed, std::vector<BallCandidate>& candidates) override
  {
    if (needed <= queried_)
      return false;
    const double radius = std::min(max_radius_, std::max(needed, next_radius_));
    search_.radiusSearch(centre_, radius, found_, d2_);
    if (queried_ < 0.0)
      candidates.clear();
    const std::size_t before = candidates.size();
    // A point is within a query when its squared distance, as the search computes it in float,
    // is <= the float square of the radius: the points past held_r2_ are exactly the new ones.
    // Distances first (vectorised), then the new non-feature points appended without a branch per
    // point (in a grown query, old and new points alternate unpredictably).
    const std::size_t found = found_.size();
    distance_.resize(found);
    double* dist = distance_.data();
    const float* d2 = d2_.data();
    squareRoots(d2, found, dist);
    candidates.resize(before + found);
    BallCandidate* out = candidates.data() + before;
    std::size_t added = 0;
    for (std::size_t i = 0; i < found; ++i)
    {
      const int index = found_[i];
      out[added] = {dist[i], index};
      added += (d2[i] > held_r2_) & (is_feature_[static_cast<std::size_t>(index)] == 0) ? 1 : 0;
    }
    candidates.resize(before + added);
    held_r2_ = static_cast<float>(radius * radius);
    // Anything at or below the radius asked for is complete; tell the solver so.
    queried_ = radius >= max_radius_ ? std::numeric_limits<double>::infinity() : radius;
    next_radius_ = kGrowth * radius;
    return candidates.size() != before;
  }

  /// A query that falls short grows to at least this multiple of its radius (only the shell is
  /// new work, so the first query can be tight: the kernel's support 2r at the guessed r).
  static constexpr double kGrowth = 1.3;

private:
  const pcl::search::Search<pcl::PointXYZ>& search_;
  const std::vector<std::uint8_t>& is_feature_;
  pcl::PointXYZ centre_;
  double max_radius_;
  double next_radius_;
  double queried_ = -1.0;
  float held_r2_ = -1.0f;
  pcl::Indices& found_;
  std::vector<float>& d2_;
  std::vector<double>& distance_;
};

/// E grows about like r² near the root, so a ball whose tolerance step 5 scaled by f has a radius
/// about sqrt(f) times that of a ball at the base tolerance: radii divided by this are comparable
/// across the tolerance classes (the running guess and each colour's start are kept at the base).
double toleranceClassScale(double tolerance, double base_tolerance)
{
  return std::sqrt(tolerance / base_tolerance);
}

/// Scratch space of one worker, reused from ball to ball.
struct Scratch
{
  std::vector<BallCandidate> candidates;
  pcl::Indices found;  // radius query results, reused
  std::vector<float> d2;
  std::vector<double> found_distance;  // sqrt(d2)
  std::vector<Eigen::Vector3d> offsets;
  std::vector<double> distances;  // |offset|, as the radius query measured it
  std::vector<int> members;
  std::vector<std::uint32_t> picked;  // positions of the members among the candidates
  std::vector<std::uint8_t> inside;
  double typical_radius = 0.0;  // first query guess; adapts to the balls of this worker's cell
};

}  // namespace

double ballRoughness(const RadiusSolution& sol)
{
  return sol.radius > 0.0 && sol.quadric.weight_sum > 0.0 ? std::sqrt(sol.residual / sol.quadric.weight_sum) / sol.radius
                                                          : 0.0;
}

std::optional<Eigen::Vector3d> representativeOffset(const RadiusSolution& sol, double roughness, const Parameters& params)
{
  if (tooRough(roughness, params))
    return std::nullopt;  // the points do not agree on a surface: c stands for them
  const Eigen::Vector3d x = params.representative_cutoff == kQuadricCutoff
                                ? sol.x_min
                                : minimizeQuadric(sol.quadric, params.representative_cutoff).x;
  if (!(x.norm() < params.max_representative_offset * sol.radius))
    return std::nullopt;  // outside the ball's core: a sharp feature slipped past the test
  return x;
}

namespace
{
/// The member nearest to `v_offset` (offsets from the centre) among those `eligible` accepts, ties
/// to the lower index; `fallback` when none is nearer than `fallback_d2` (squared).
template <class Eligible>
int nearestMember(const std::vector<int>& members, const std::vector<Eigen::Vector3d>& offsets,
                  const Eigen::Vector3d& v_offset, Eligible eligible, int fallback, double fallback_d2)
{
  int chosen = fallback;
  double best = fallback_d2;
  for (std::size_t m = 0; m < members.size(); ++m)
  {
    if (!eligible(members[m]))
      continue;
    const double d = (offsets[m] - v_offset).squaredNorm();
    if (d < best || (d == best && members[m] < chosen))
    {
      best = d;
      chosen = members[m];
    }
  }
  return chosen;
}
}  // namespace

BallAttributes ballAttributes(const std::vector<int>& members, const std::vector<Eigen::Vector3d>& offsets,
                              const std::vector<double>& distances, const Eigen::Vector3d& v_offset,
                              const NormalList& normals, int centre, double radius)
{
  BallAttributes a;
  a.source = nearestMember(members, offsets, v_offset, [](int) { return true; }, a.source,
                           std::numeric_limits<double>::infinity());
  const Eigen::Vector3d nc = normals[static_cast<std::size_t>(centre)].cast<double>();
  Eigen::Vector3d normal_sum = Eigen::Vector3d::Zero();
  for (std::size_t m = 0; m < members.size(); ++m)
  {
    Eigen::Vector3d nm = normals[static_cast<std::size_t>(members[m])].cast<double>();
    if (nm.dot(nc) < 0.0)
      nm = -nm;
    const double weight = radius > 0.0 ? kernelG(distances[m], radius) : 1.0;
    normal_sum += weight * nm;
  }
  const double len = normal_sum.norm();
  a.normal = (len > 0.0 ? Eigen::Vector3d(normal_sum / len) : nc).cast<float>();
  return a;
}

namespace
{
/// The owner of a point a neighbouring tile covers (CoverInput::pre_covered).
constexpr std::int64_t kPreCovered = std::numeric_limits<std::int64_t>::max();

/// Steps 4-6 for the centre c: solve the ball, then claim (owner = ball_key) the points it
/// covers that nobody owns yet. Returns the ball.
CoverBall makeBall(const CoverInput& in, const Parameters& params, double error_threshold,
                   double cap, int c, std::int64_t ball_key, std::vector<std::int64_t>& owner,
                   std::vector<std::uint8_t>& taken, Scratch& w)
{
  const std::size_t cs = static_cast<std::size_t>(c);
  CoverBall ball;
  ball.centre = c;
  ball.tolerance = adaptTolerance(error_threshold, params.adaptive, params.adaptive_factor,
                                  in.curvature[cs], in.mean_abs_curvature, in.density[cs],
                                  in.mean_density);
  const Eigen::Vector3d centre = in.cloud[c].getVector3fMap().cast<double>();

  // Steps 4-5: the radius and the optimised point. The floor is dens_c (eq. 5), the cap a
  // multiple of the mean neighbourhood radius.
  const QuadricSamples samples{in.cloud, in.normals, in.weights};
  const double class_scale = toleranceClassScale(ball.tolerance, error_threshold);
  const double guess = std::max(w.typical_radius * class_scale, in.density[cs]);
  RadiusQuerySource source(in.search, in.is_feature, in.cloud[c], 2.0 * cap, 2.0 * guess, w.found, w.d2,
                           w.found_distance);
  w.candidates.clear();
  const RadiusSolution sol = solveRadius(samples, centre, in.density[cs], cap, guess,
                                         ball.tolerance, in.bbox_diagonal, params.error_form,
                                         source, w.candidates);
  ball.evaluations = static_cast<std::size_t>(sol.evaluations);
  ball.radius = sol.radius;
  ball.error = sol.error;
  if (sol.radius > 0.0)
    w.typical_radius = 0.8 * w.typical_radius + 0.2 * sol.radius / class_scale;

  // The representative (representativeOffset): the optimised point, or c itself.
  ball.roughness = ballRoughness(sol);
  const std::optional<Eigen::Vector3d> offset = representativeOffset(sol, ball.roughness, params);
  ball.used_centre = !offset;
  Eigen::Vector3d v_offset = offset ? *offset : Eigen::Vector3d::Zero();
  ball.representative = centre + v_offset;

  // Members: the non-feature points within r (c among them, at distance 0).
  // Picked without a branch per candidate (about one in eight is a member: a branch would
  // mispredict on most members), then gathered.
  w.picked.resize(w.candidates.size());
  std::size_t picked = 0;
  for (std::size_t j = 0; j < w.candidates.size(); ++j)
  {
    w.picked[picked] = static_cast<std::uint32_t>(j);
    picked += w.candidates[j].distance <= sol.radius ? 1 : 0;
  }
  w.offsets.resize(picked);
  w.distances.resize(picked);
  w.members.resize(picked);
  for (std::size_t m = 0; m < picked; ++m)
  {
    const BallCandidate& cand = w.candidates[w.picked[m]];
    w.members[m] = cand.index;
    w.distances[m] = cand.distance;
    w.offsets[m] = in.cloud[cand.index].getVector3fMap().cast<double>() - centre;
  }
  if (std::find(w.members.begin(), w.members.end(), c) == w.members.end())
  {
    w.members.push_back(c);
    w.distances.push_back(0.0);
    w.offsets.push_back(Eigen::Vector3d::Zero());
  }

  // The representative on the surface the members describe (representative_fit.h): in smooth
  // balls, and in curved ones that the quadratic fits closely; a large ball's only where the
  // quadratic fits as closely as the scan's noise and no cubic fits them better (kCubicTermsF).
  const Eigen::Vector3d nc = in.normals[cs].cast<double>();
  if (params.representative_fit && offset)
    if (const auto fitted = fitRepresentativeHeight(w.offsets, w.distances, sol.radius, nc, v_offset))
    {
      if ((smoothQuadric(sol.quadric, kSmoothQuadricRatio) || fitted->residual < kCurvedBallFitResidual) &&
          fitWithinNoise(fitted->residual, sol.radius, in.neighborhood_radius, in.mean_measure) &&
          !(heldToNoise(sol.radius, in.neighborhood_radius, in.mean_measure) &&
            bendsBeyondQuadratic(w.offsets, w.distances, sol.radius, nc)))
      {
        RepresentativeFit kept = *fitted;
        // A large ball whose quadratic leaves more than the noise: the height of the quadratic
        // near the representative, when that one fits within the noise (representative_fit.h).
        if (heldToNoise(sol.radius, in.neighborhood_radius, in.mean_measure) &&
            fitted->residual * sol.radius > in.mean_measure)
        {
          const double support = kLocalFitSupport * sol.radius;
          const auto local = fitLocalHeight(w.offsets, sol.radius, nc, v_offset, support);
          if (local && fitWithinNoise(local->residual, sol.radius, in.neighborhood_radius, in.mean_measure))
          {
            kept = *local;
            ball.fit_at = v_offset;
            ball.fit_support = support;
          }
        }
        v_offset = kept.offset;
        ball.representative = centre + v_offset;
        ball.fitted = true;
        ball.fit = kept.coefficients;
      }
    }

  // Attributes: from the member nearest to v; normal averaged over the ball with c's sign.
  const BallAttributes attributes =
      ballAttributes(w.members, w.offsets, w.distances, v_offset, in.normals, c, sol.radius);
  ball.attribute_source = attributes.source;
  ball.normal = attributes.normal;

  // Step 6: cover c and the members projected strictly inside the hull.
  auto claim = [&](int idx) {
    std::int64_t& o = owner[static_cast<std::size_t>(idx)];
    if (o < 0)
    {
      o = ball_key;
      ++ball.replaced;
    }
  };
  claim(c);
  // The hull decides only for members nobody owns yet: when every other member is owned already
  // (about a quarter of the balls on a scan, late in the cover), it changes nothing.
  bool open_member = false;
  for (const int m : w.members)
    open_member |= owner[static_cast<std::size_t>(m)] < 0;
  if (open_member && w.members.size() >= 3)
  {
    hullCoverage(nc, w.offsets, w.inside);
    for (std::size_t m = 0; m < w.members.size(); ++m)
      if (w.inside[m])
        claim(w.members[m]);
  }

  // A minimiser the quadratic could not place on the surface (a large ball around a bend, whose
  // tangent planes meet off it, or a noisy one) gives way to the member nearest to it, a point of
  // the surface (representative_fit.h); to c when that member lies as far from c as
  // representativeOffset allows. Only a covered member that no other ball stands at (`taken`) is
  // chosen: a point left uncovered could start a ball later, at the same place, and a point a
  // neighbouring tile covers may stand for a ball there. c is always one (it started this ball),
  // so no two output points coincide; what is covered does not depend on the choice.
  if (params.representative_fit && offset && !ball.fitted)
  {
    auto eligible = [&](int p) {
      const auto ps = static_cast<std::size_t>(p);
      return !taken[ps] && owner[ps] >= 0 && owner[ps] != kPreCovered;
    };
    const int chosen = nearestMember(w.members, w.offsets, v_offset, eligible, c, v_offset.squaredNorm());
    const Eigen::Vector3d member = in.cloud[chosen].getVector3fMap().cast<double>();
    const bool within = (member - centre).norm() < params.max_representative_offset * sol.radius;
    ball.used_centre = !within;
    ball.representative = within ? member : centre;
    // The member onto the quadratic of the members near it, where that fits them within the noise
    // (kMemberFitSupport).
    if (within)
      if (const auto local = fitLocalHeight(w.offsets, sol.radius, nc, member - centre, kMemberFitSupport * sol.radius);
          local && residualWithinNoise(local->residual, sol.radius, in.mean_measure))
        ball.representative = centre + local->offset;
    ball.attribute_source = within ? chosen : c;
    taken[static_cast<std::size_t>(within ? chosen : c)] = 1;
  }
  else if (ball.used_centre)
    taken[cs] = 1;
  return ball;
}
/// A point that may start a ball (step 3): not a feature, allowed (a tile's own point), not
/// covered already by a neighbouring tile.
bool mayBeCentre(const CoverInput& in, std::size_t i)
{
  return !in.is_feature[i] && (!in.centre_allowed || (*in.centre_allowed)[i]) && (!in.pre_covered || !(*in.pre_covered)[i]);
}

/// The box of the points that may start a ball; false when there are none.
bool centreBox(const CoverInput& in, int threads, Eigen::Vector3d& lo, Eigen::Vector3d& hi)
{
  const auto count = static_cast<std::ptrdiff_t>(in.cloud.size());
  lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  hi = -lo;
#pragma omp parallel num_threads(threads)
  {
    Eigen::Vector3d lo_t = lo, hi_t = hi;
#pragma omp for schedule(static) nowait
    for (std::ptrdiff_t ii = 0; ii < count; ++ii)
    {
      const auto i = static_cast<std::size_t>(ii);
      if (!mayBeCentre(in, i))
        continue;
      const Eigen::Vector3d q = in.cloud[i].getVector3fMap().cast<double>();
      lo_t = lo_t.cwiseMin(q);
      hi_t = hi_t.cwiseMax(q);
    }
#pragma omp critical(pcl_ecs_cover_box)
    {
      lo = lo.cwiseMin(lo_t);  // min and max: the same whatever the order threads arrive in
      hi = hi.cwiseMax(hi_t);
    }
  }
  return lo.x() <= hi.x();
}

/// The centres sorted into cells and each cell's centres in a seeded order (cellOrder()).
struct CellOrder
{
  struct Entry
  {
    std::uint64_t cell;  // colour in the bits from colour_shift up, then the cell coordinates
    int point;
  };
  std::vector<Entry, UninitialisedAllocator<Entry>> entries;  ///< the centres, cell by cell
  std::vector<std::size_t> cell_begin;    ///< first entry of each cell, and the end
  std::vector<std::size_t> colour_begin;  ///< first cell of colour >= c, for c in 0..8
  std::size_t cells = 0;
};

CellOrder cellOrder(const CoverInput& in, const Parameters& params, double cap, const Eigen::Vector3d& lo,
                    const Eigen::Vector3d& hi, int threads)
{
  const std::size_t n = in.cloud.size();
  const auto count = static_cast<std::ptrdiff_t>(n);
  CellOrder order;
  using Entry = CellOrder::Entry;
  auto& entries = order.entries;
  // Cells of side s > 2·cap, coloured by the parity of their grid coordinates: two cells of one
  // colour are at least s apart, so balls centred in them (radius <= cap) cover disjoint sets and
  // can be made concurrently. The eight colours run one after another; inside a cell the centres
  // come in a seeded order of their own. The result depends on the cells, never on the thread count.
  const double side = std::max(2.0 * cap * 1.001, 1e-12);
  // Cell coordinates packed into as few bits as the box needs (the sort below passes over the
  // bits in use): colour, then x, y, z, most significant first.
  constexpr double kMaxCell = 1048575.0;  // 2^20 - 1 per axis
  int width[3];
  for (int a = 0; a < 3; ++a)
  {
    const auto top = static_cast<std::uint64_t>(std::min((hi(a) - lo(a)) / side, kMaxCell));
    width[a] = 0;
    while ((top >> width[a]) != 0)
      ++width[a];
  }
  const int colour_shift = width[0] + width[1] + width[2];
  // Points that are not centres get "colour 8": after every cell, one bit above the colours.
  const std::uint64_t not_a_centre = std::uint64_t{8} << colour_shift;
  entries.resize(n);  // every entry written below
#pragma omp parallel for schedule(static) num_threads(threads)
  for (std::ptrdiff_t ii = 0; ii < count; ++ii)
  {
    const auto i = static_cast<std::size_t>(ii);
    if (!mayBeCentre(in, i))
    {
      entries[i] = {not_a_centre, static_cast<int>(i)};
      continue;
    }
    const Eigen::Vector3d q = (in.cloud[i].getVector3fMap().cast<double>() - lo) / side;
    const std::uint64_t ix = static_cast<std::uint64_t>(std::min(q.x(), kMaxCell));
    const std::uint64_t iy = static_cast<std::uint64_t>(std::min(q.y(), kMaxCell));
    const std::uint64_t iz = static_cast<std::uint64_t>(std::min(q.z(), kMaxCell));
    const std::uint64_t colour = (ix & 1u) | ((iy & 1u) << 1) | ((iz & 1u) << 2);
    entries[i] = {(colour << colour_shift) | (ix << (width[1] + width[2])) | (iy << width[2]) | iz,
                  static_cast<int>(i)};
  }
  // By cell (points read in cloud order, the sort stable: one order whatever the threads).
  radixSortStable(entries, [](const Entry& e) { return e.cell; }, threads);
  while (!entries.empty() && entries.back().cell == not_a_centre)
    entries.pop_back();
  // Cell boundaries, and where each colour starts.
  std::vector<std::size_t>& cell_begin = order.cell_begin;
  for (std::size_t e = 0; e < entries.size(); ++e)
    if (e == 0 || entries[e].cell != entries[e - 1].cell)
      cell_begin.push_back(e);
  const std::size_t cells = order.cells = cell_begin.size();
  cell_begin.push_back(entries.size());
  // Each cell's centres in a seeded order drawn from the run's seed and the cell's key (a uniform
  // order within each cell, as a global shuffle would give, without its scattered reads).
  const auto cell_count = static_cast<std::ptrdiff_t>(cells);
#pragma omp parallel for schedule(static) num_threads(threads)
  for (std::ptrdiff_t k = 0; k < cell_count; ++k)
  {
    const std::size_t b = cell_begin[static_cast<std::size_t>(k)];
    seededShuffle(entries.data() + b, cell_begin[static_cast<std::size_t>(k) + 1] - b,
                  partSeed(params.seed, entries[b].cell));
  }
  // Cells are candidates colour-major: colour_begin[col] is the first cell of colour >= col.
  order.colour_begin.assign(9, cells);
  std::vector<std::size_t>& colour_begin = order.colour_begin;
  std::size_t next_colour = 0;
  for (std::size_t k = 0; k < cells; ++k)
    while (next_colour <= (entries[cell_begin[k]].cell >> colour_shift))
      colour_begin[next_colour++] = k;

  return order;
}

/// The balls of the cells of colours [from, to), colour after colour (cells of one colour in
/// parallel), added to `cell_balls`. Ball keys while running: cell index << 32 | index in the
/// cell; `owner` holds them, `taken` the points that are representatives (makeBall).
void coverCells(const CoverInput& in, const Parameters& params, double error_threshold, double cap,
                const CellOrder& order, int threads, int from, int to, std::vector<std::int64_t>& owner,
                std::vector<std::uint8_t>& taken,
                std::vector<std::vector<CoverBall>>& cell_balls)
{
  const std::vector<std::size_t>& cell_begin = order.cell_begin;
  const std::vector<std::size_t>& colour_begin = order.colour_begin;
  const auto& entries = order.entries;
  // A cell's first guess: the geometric mean of the base-tolerance radii of the balls of the
  // colours before (known and fixed before the colour starts: the same whatever the threads).
  double log_sum = 0.0;
  std::size_t log_count = 0;
  for (int col = 0; col < to; ++col)
  {
    if (col > 0)
    {
      const auto c = static_cast<std::size_t>(col);
      for (std::size_t k = colour_begin[c - 1]; k < colour_begin[c]; ++k)
        for (const CoverBall& b : cell_balls[k])
          if (b.radius > 0.0)
          {
            log_sum += std::log(b.radius / toleranceClassScale(b.tolerance, error_threshold));
            ++log_count;
          }
    }
    if (col < from)
      continue;
    const double start_radius = log_count > 0 ? std::exp(log_sum / static_cast<double>(log_count)) : in.neighborhood_radius;
    const std::ptrdiff_t first = static_cast<std::ptrdiff_t>(colour_begin[static_cast<std::size_t>(col)]);
    const std::ptrdiff_t last = static_cast<std::ptrdiff_t>(colour_begin[static_cast<std::size_t>(col) + 1]);
#pragma omp parallel num_threads(threads)
    {
      Scratch w;
#pragma omp for schedule(dynamic, 1)
      for (std::ptrdiff_t k = first; k < last; ++k)
      {
        const std::size_t cell = static_cast<std::size_t>(k);
        w.typical_radius = start_radius;
        std::vector<CoverBall>& balls = cell_balls[cell];
        for (std::size_t e = cell_begin[cell]; e < cell_begin[cell + 1]; ++e)
        {
          const int c = entries[e].point;
          if (owner[static_cast<std::size_t>(c)] >= 0)
            continue;
          const std::int64_t key = (static_cast<std::int64_t>(cell) << 32) | static_cast<std::int64_t>(balls.size());
          balls.push_back(makeBall(in, params, error_threshold, cap, c, key, owner, taken, w));
        }
      }
    }
  }
}

}  // namespace

struct ColourCover::State
{
  State(const CoverInput& in_, const Parameters& params_, double error_threshold_)
    : in(in_), params(params_), error_threshold(error_threshold_)
  {
  }
  const CoverInput& in;
  Parameters params;
  double error_threshold;
  double cap = 0.0;
  int threads = 1;
  bool any_centre = false;
  int colours_done = 0;
  CellOrder order;
  std::vector<std::int64_t> owner;
  std::vector<std::uint8_t> taken;  // points that are a ball's representative (makeBall)
  std::vector<std::vector<CoverBall>> cell_balls;
};

ColourCover::ColourCover(const CoverInput& in, const Parameters& params, double error_threshold)
  : state_(std::make_unique<State>(in, params, error_threshold))
{
  State& st = *state_;
  const std::size_t n = in.cloud.size();
  st.cap = std::max(params.radius_cap_factor * in.neighborhood_radius, 0.0);
  st.threads = resolveThreads(params.threads);
  // The centres (step 3): the non-feature points allowed to start a ball, and their box.
  Eigen::Vector3d lo, hi;
  st.any_centre = centreBox(in, st.threads, lo, hi);
  if (!st.any_centre)
    return;
  st.order = cellOrder(in, params, st.cap, lo, hi, st.threads);
  st.owner.assign(n, -1);
  st.taken.assign(n, 0);
  if (in.pre_covered)
    for (std::size_t i = 0; i < n; ++i)
      if ((*in.pre_covered)[i])
        st.owner[i] = kPreCovered;
  st.cell_balls.resize(st.order.cells);
}

ColourCover::~ColourCover() = default;
ColourCover::ColourCover(ColourCover&&) noexcept = default;
ColourCover& ColourCover::operator=(ColourCover&&) noexcept = default;

ColourCover::State& ColourCover::state() const
{
  if (!state_)
    throw std::logic_error("pcl_ecs::ColourCover: used after finish()");
  return *state_;
}

void ColourCover::run(int colours)
{
  State& st = state();
  colours = std::min(8, colours);
  if (st.any_centre && colours > st.colours_done)
    coverCells(st.in, st.params, st.error_threshold, st.cap, st.order, st.threads, st.colours_done, colours, st.owner, st.taken,
               st.cell_balls);
  st.colours_done = std::max(st.colours_done, colours);
}

std::vector<CoverBall> ColourCover::firstColourBalls() const
{
  const State& st = state();
  std::vector<CoverBall> balls;
  if (!st.any_centre || st.colours_done < 1)
    return balls;
  for (std::size_t k = 0; k < st.order.colour_begin[1]; ++k)
    balls.insert(balls.end(), st.cell_balls[k].begin(), st.cell_balls[k].end());
  return balls;
}

void ColourCover::finish(CoverOutput& out)
{
  run(8);
  State& st = state();
  const std::size_t n = st.in.cloud.size();
  out = CoverOutput{};
  out.owner.assign(n, -1);
  if (!st.any_centre)
    return;  // no centre
  // Canonical ball numbering: by cell (colour-major), then by order within the cell.
  const std::size_t cells = st.order.cells;
  std::vector<std::size_t> first_id(cells + 1, 0);
  for (std::size_t k = 0; k < cells; ++k)
    first_id[k + 1] = first_id[k] + st.cell_balls[k].size();
  out.balls.reserve(first_id[cells]);
  out.first_colour_balls = first_id[st.order.colour_begin[1]];
  for (std::size_t k = 0; k < cells; ++k)
    for (CoverBall& b : st.cell_balls[k])
    {
      out.max_error = std::max(out.max_error, b.error);
      out.radius_evaluations += b.evaluations;
      out.balls.push_back(std::move(b));
    }
  const auto count = static_cast<std::ptrdiff_t>(n);
  const std::vector<std::int64_t>& owner = st.owner;
#pragma omp parallel for schedule(static) num_threads(st.threads)
  for (std::ptrdiff_t ii = 0; ii < count; ++ii)
  {
    const auto i = static_cast<std::size_t>(ii);
    if (owner[i] >= 0 && owner[i] != kPreCovered)
      out.owner[i] = static_cast<int>(first_id[static_cast<std::size_t>(owner[i] >> 32)] +
                                      static_cast<std::size_t>(owner[i] & 0xFFFFFFFF));
  }
  state_.reset();
}

void coverWithBalls(const CoverInput& in, const Parameters& params, double error_threshold,
                    CoverOutput& out)
{
  ColourCover(in, params, error_threshold).finish(out);
}

}  // namespace pcl_ecs
