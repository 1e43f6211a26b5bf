// scan_split.cpp — the out-of-core run's scan (count, bounds, sample, plan) and split into tiles, and a
// tile loaded back (tiled_run.h).
#include "tiled_run.h"

namespace pcl_ecs
{
namespace stream
{
namespace detail
{

/// A fixed pseudo-random choice per point: the planning sample does not depend on chunking.
bool inSample(std::uint64_t gid, double fraction)
{
  if (fraction >= 1.0)
    return true;
  SplitMix64 rng(gid ^ 0x5eed5eed5eedull);
  return static_cast<double>(rng.next() >> 11) * 0x1.0p-53 < fraction;
}

void Runner::scanAndPlan(io::RecordSource& reader)
{
  const auto t0 = Clock::now();
  header_ = reader.header();
  // The sample fits half of what the limit leaves beside the process itself.
  const std::size_t sample_target = std::max<std::size_t>(
      kMinSample, std::min<std::size_t>(kSampleTarget, static_cast<std::size_t>(0.5 * usableBytes() / kPlanBytesPerSample)));
  PlanningSample sample;
  sample.fraction = std::min(1.0, static_cast<double>(sample_target) / std::max<double>(1.0, static_cast<double>(header_.points)));
  sample.points.reserve(std::min<std::uint64_t>(header_.points, sample_target + sample_target / 10));
  const std::uint64_t finite = scanInput(reader, sample);
  plan_.input_points = header_.points;
  plan_.finite_points = finite;
  plan_.lo = sample.lo;
  plan_.hi = sample.hi;
  const int k = params_.k_neighbors;
  if (finite <= static_cast<std::uint64_t>(k) || sample.points.size() <= static_cast<std::size_t>(k))
  {
    std::ostringstream os;
    os << input_ << ": only " << finite << " finite points; the neighbourhood size K = " << k << " needs at least "
       << k + 1;
    failRun(os.str());
  }
  // The tiles live in the plane of the two longest axes.
  const Eigen::Vector3d ext = sample.hi - sample.lo;
  int order[3] = {0, 1, 2};
  std::sort(order, order + 3, [&](int a, int b) { return ext[a] > ext[b] || (ext[a] == ext[b] && a < b); });
  plan_.axis_u = std::min(order[0], order[1]);
  plan_.axis_v = std::max(order[0], order[1]);
  if (!(ext[order[1]] > 0.0))
    failRun(input_ + ": all points lie on one line: there is no surface to simplify");
  if (!(ext.maxCoeff() > 1e-30))
    failRun(input_ + ": the cloud's extent (" + std::to_string(ext.maxCoeff()) + ") is too small for float precision");
  planTiles(sample);
  summary_.stage_seconds[0] = secondsSince(t0);
  std::ostringstream os;
  os << "plan: " << finite << " finite points, " << plan_.tree.tiles.size() << " tile(s) of at most "
     << plan_.tile_point_budget << " points with halo " << plan_.halo << " (scan " << std::fixed
     << std::setprecision(1) << summary_.stage_seconds[0] << " s)";
  report(os.str());
}

std::uint64_t Runner::scanInput(io::RecordSource& reader, PlanningSample& sample)
{
  const io::XyzAccess xyz(header_);
  const std::size_t step = header_.point_step;
  const double fraction = sample.fraction;
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
    out.reserve(kChunk * (SplitHeader::kCoreBytes + step));
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
        // points.bin: the split's core record layout (input index, then the record).
        SplitHeader h;
        h.gid = gid;
        const std::size_t at = out.size();
        out.resize(at + SplitHeader::kCoreBytes);
        h.storeCore(out.data() + at);
        out.insert(out.end(), rec, rec + step);
      }
      ++finite;
      const Eigen::Vector3d p(x, y, z);
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
      if (inSample(gid, fraction))
        sample.points.push_back(p);
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
  sample.lo = lo;
  sample.hi = hi;
  return finite;
}

double Runner::estimateHalo(const PlanningSample& planning)
{
  const std::vector<Eigen::Vector3d>& sample = planning.points;
  const double fraction = planning.fraction;
  const Eigen::Vector3d lo = planning.lo, hi = planning.hi;
  const int k = params_.k_neighbors;
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
  return 1.25 * cap_estimate + 3.0 * rk_high;
}

void Runner::planTiles(const PlanningSample& planning)
{
  const std::vector<Eigen::Vector3d>& sample = planning.points;
  const double fraction = planning.fraction;
  const std::size_t step = header_.point_step;
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
  // A sample that fits the first tree's core is one tile (the root is not split): a tile with no
  // neighbour needs no halo, and the spacing estimate (a neighbour search over the sample) is
  // skipped; nor has it a halo share to even out below.
  const bool one_tile = sample.size() <= samples(0.8 * max_load);
  plan_.halo = one_tile ? 0.0 : estimateHalo(planning);
  plan_.tree = buildTileTree(sample2, samples(0.8 * max_load), samples(max_load), plan_.halo);
  if (one_tile)
    return;
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
}

/// A buffered scratch file of the split (one per tile core and halo, per part).
struct TileSink
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

void Runner::split()
{
  const auto t0 = Clock::now();
  const std::size_t step = header_.point_step;
  const std::size_t tiles = plan_.tree.tiles.size();
  // Where the finite points are: a binary input's own records (input index = record number,
  // the non-finite ones skipped again), else pass 1's copy (input index, record).
  const bool from_input = readTwice();
  const fs::path source = from_input ? fs::path(inputs_[0]) : paths_.points();
  const std::size_t record = from_input ? step : SplitHeader::kCoreBytes + step;
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
  const SplitJob job{source, from_input, record, records, offset, parts, buffer, t0, &done, &part_halo, &part_finite};
  std::vector<int> all(static_cast<std::size_t>(parts));
  std::iota(all.begin(), all.end(), 0);
  forEachTile(all, parts, [&](int part) { splitPart(job, part); });
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

void Runner::splitPart(const SplitJob& job, int part)
{
  const io::XyzAccess xyz(header_);
  const std::size_t step = header_.point_step;
  const std::size_t tiles = plan_.tree.tiles.size();
  const auto p = static_cast<std::size_t>(part);
  std::vector<TileSink> core(tiles), halo(tiles);
  for (std::size_t t = 0; t < tiles; ++t)
  {
    core[t].buf.resize(job.buffer);
    halo[t].buf.resize(job.buffer);
    core[t].file.rdbuf()->pubsetbuf(nullptr, 0);  // the sink buffers: no second buffer per file
    halo[t].file.rdbuf()->pubsetbuf(nullptr, 0);
    core[t].file.open(paths_.core(static_cast<int>(t), part).string() + ".tmp", std::ios::binary | std::ios::trunc);
    halo[t].file.open(paths_.halo(static_cast<int>(t), part).string() + ".tmp", std::ios::binary | std::ios::trunc);
    if (!core[t].file || !halo[t].file)
      failRun("cannot create the scratch files in " + (paths_.root / "tiles").string());
  }
  const std::uint64_t first = job.records * p / static_cast<std::uint64_t>(job.parts);
  const std::uint64_t last = job.records * (p + 1) / static_cast<std::uint64_t>(job.parts);
  std::ifstream in(job.source, std::ios::binary);
  if (!in || !in.seekg(static_cast<std::streamoff>(job.offset + first * job.record)))
    failRun("cannot read " + job.source.string());
  std::vector<std::uint8_t> chunk(kChunk * job.record);
  std::vector<int> near;
  std::uint64_t finite = 0;
  std::vector<std::uint64_t> own_count(tiles, 0), halo_count(tiles, 0);  // this part's
  for (std::uint64_t at = first; at < last;)
  {
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(kChunk, last - at));
    in.read(reinterpret_cast<char*>(chunk.data()), static_cast<std::streamsize>(n * job.record));
    if (static_cast<std::size_t>(in.gcount()) != n * job.record)
      failRun(job.source.string() + (job.from_input ? " changed while it was being read (it ended early)" : " is truncated"));
    for (std::size_t i = 0; i < n; ++i)
    {
      const std::uint8_t* rec = chunk.data() + i * job.record;
      std::uint64_t gid = at + i;
      if (!job.from_input)
      {
        gid = SplitHeader::loadCore(rec).gid;
        rec += SplitHeader::kCoreBytes;
      }
      double c[3];
      xyz.get(rec, c[0], c[1], c[2]);
      if (job.from_input && !(std::isfinite(c[0]) && std::isfinite(c[1]) && std::isfinite(c[2])))
        continue;  // the copy of pass 1 holds finite points only
      ++finite;
      const std::array<double, 2> pt{{c[plan_.axis_u], c[plan_.axis_v]}};
      near.clear();
      const int own = plan_.tree.locateAndNear(pt, plan_.halo, near);
      std::uint64_t& count = own_count[static_cast<std::size_t>(own)];
      // The index among the tile's own points found by this part; loadTile adds the earlier parts'.
      SplitHeader header;
      header.gid = gid;
      header.tile = static_cast<std::uint32_t>(own);
      header.index = static_cast<std::uint32_t>(count);
      if (++count >= std::numeric_limits<std::uint32_t>::max())
        failRun("a tile holds more than 4 billion points: raise --memory-limit less or split the input");
      std::uint8_t core_header[SplitHeader::kCoreBytes], halo_header[SplitHeader::kHaloBytes];
      header.storeCore(core_header);
      header.storeHalo(halo_header);
      core[static_cast<std::size_t>(own)].put(core_header, SplitHeader::kCoreBytes);
      core[static_cast<std::size_t>(own)].put(rec, step);
      for (int t : near)
        if (t != own)
        {
          TileSink& s = halo[static_cast<std::size_t>(t)];
          ++halo_count[static_cast<std::size_t>(t)];
          s.put(halo_header, SplitHeader::kHaloBytes);
          s.put(rec, step);
        }
    }
    at += n;
    const std::uint64_t before = job.done->fetch_add(n);
    if ((before >> 22) != ((before + n) >> 22))
    {
      const double s = secondsSince(job.t0);
      std::ostringstream os;
      os << "split: " << before + n << " / " << job.records << " points, " << std::fixed << std::setprecision(2)
         << (s > 0 ? static_cast<double>(before + n) / s / 1e6 : 0.0) << " M points/s";
      report(os.str());
    }
  }
  (*job.part_finite)[p] = finite;
  for (std::size_t t = 0; t < tiles; ++t)
  {
    plan_.part_core[t][p] = own_count[t];
    (*job.part_halo)[t][p] = halo_count[t];
    core[t].flush();
    halo[t].flush();
    core[t].file.close();
    halo[t].file.close();
    if (!core[t].file || !halo[t].file)
      failRun("cannot write the scratch files in " + (paths_.root / "tiles").string() + " (disk full?)");
  }
}

std::vector<std::uint32_t> Runner::savedOrder(int t, std::size_t n) const
{
  // Saved as: the tile's point count, the count loaded (the others coincide with one), the order.
  std::vector<std::uint32_t> order = readVector<std::uint32_t>(paths_.order(t));
  bool valid = order.size() >= 2 && order[0] == n && order[1] == order.size() - 2 && order[1] <= n;
  if (valid)
    order.erase(order.begin(), order.begin() + 2);
  std::vector<std::uint8_t> seen(n, 0);
  for (std::size_t o = 0; valid && o < order.size(); ++o)
  {
    valid = order[o] < n && !seen[order[o]];
    if (valid)
      seen[order[o]] = 1;
  }
  if (!valid)
    failDamaged("the saved point order of tile " + std::to_string(t) + " does not match its points");
  return order;
}

std::vector<std::uint32_t> Runner::hilbertOrder(const std::vector<std::uint64_t>& gids,
                                                const std::vector<Eigen::Vector3d>& pos) const
{
  // The (code, input index) pairs are distinct (input indices are): one order.
  struct Key
  {
    std::uint64_t code, gid;
    std::uint32_t at;
  };
  const std::size_t n = gids.size();
  std::vector<Key> keys(n);
  for (std::size_t i = 0; i < n; ++i)
    keys[i] = {0, gids[i], static_cast<std::uint32_t>(i)};
  {
    std::vector<std::uint64_t> codes(n);
    // On the grid the in-memory filter orders the whole cloud on: one tile gives its run exactly.
    spatialCodes(pos.data(), n, plan_.lo, plan_.hi, codes.data(),
                 spatialOrderBits(static_cast<std::size_t>(plan_.finite_points)), tile_threads_);
    for (std::size_t i = 0; i < n; ++i)
      keys[i].code = codes[i];
  }
  // Stable, so the same order for any thread count.
  radixSortThenTies(keys, [](const Key& k) { return k.code; },
                    [](const Key& a, const Key& b) { return a.gid < b.gid; }, tile_threads_);
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
  std::vector<std::uint32_t> order(ids.size());
  for (std::size_t o = 0; o < ids.size(); ++o)
    order[o] = keys[static_cast<std::size_t>(ids[o])].at;
  return order;
}

TileData Runner::loadTile(int t) const
{
  const std::size_t step = header_.point_step;
  const std::size_t core_record = SplitHeader::kCoreBytes + step, halo_record = SplitHeader::kHaloBytes + step;
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
    if ((halo.size() - first) % (halo_record) != 0)
      failDamaged("the halo files of tile " + std::to_string(t) + " do not hold whole points");
    for (std::size_t at = first; at < halo.size(); at += halo_record)
    {
      SplitHeader h = SplitHeader::loadHalo(halo.data() + at);
      if (h.tile >= tile_parts.size())
        failDamaged("the halo files of tile " + std::to_string(t) + " name a tile that does not exist");
      for (int q = 0; q < p; ++q)
        h.index += static_cast<std::uint32_t>(tile_parts[h.tile][static_cast<std::size_t>(q)]);
      h.storeHalo(halo.data() + at);
    }
  }
  const std::size_t nc = core.size() / core_record, nh = halo.size() / halo_record;
  const Tile& tile = plan_.tree.tiles[static_cast<std::size_t>(t)];
  if (core.size() % core_record != 0 || nc != tile.core_points || nh != tile.halo_points)
    failDamaged("the point files of tile " + std::to_string(t) + " do not hold the points the plan counted");
  const std::size_t n = nc + nh;
  auto at = [&](std::size_t i) -> const std::uint8_t* {
    return i < nc ? core.data() + i * core_record : halo.data() + (i - nc) * halo_record;
  };
  auto position = [&](std::size_t i) {
    Eigen::Vector3d p;
    xyz.get(at(i) + (i < nc ? SplitHeader::kCoreBytes : SplitHeader::kHaloBytes), p.x(), p.y(), p.z());
    return p;
  };
  TileData d;
  // Sorted by Hilbert code in the global box, ties by input index: the same order for a point
  // whichever tile loads it, so neighbour ties break the same way everywhere. Phase A saves the
  // order it found; later loads of the tile read it instead of sorting again.
  if (fs::exists(paths_.order(t)))
    d.order = savedOrder(t, n);
  else
  {
    std::vector<std::uint64_t> gids(n);
    std::vector<Eigen::Vector3d> pos(n);  // by file order
    for (std::size_t i = 0; i < n; ++i)
    {
      gids[i] = SplitHeader::loadCore(at(i)).gid;  // a halo record starts the same way
      pos[i] = position(i);
    }
    d.order = hilbertOrder(gids, pos);
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
  // Each o fills its own slots: the threads' shares do not change what is loaded.
#pragma omp parallel for schedule(static) num_threads(tile_threads_) if (m >= 8192)
  for (std::size_t o = 0; o < m; ++o)
  {
    if (o + kAhead < m)
      __builtin_prefetch(at(d.order[o + kAhead]));
    const std::size_t i = d.order[o];
    const std::uint8_t* r = at(i);
    // From the record, which is fetched ahead (a position kept from the sort would be one more
    // scattered read).
    (*d.cloud)[o].getVector3fMap() = ((position(i) - origin) * scale).cast<float>();  // plan_.toLocal
    d.is_core[o] = i < nc;
    if (i < nc)
    {
      d.gid[o] = SplitHeader::loadCore(r).gid;
      d.src_tile[o] = static_cast<std::uint32_t>(t);
      d.src_index[o] = static_cast<std::uint32_t>(i);
      std::memcpy(d.records.data() + o * step, r + SplitHeader::kCoreBytes, step);
    }
    else
    {
      const SplitHeader h = SplitHeader::loadHalo(r);
      d.gid[o] = h.gid;
      d.src_tile[o] = h.tile;
      d.src_index[o] = h.index;
      std::memcpy(d.records.data() + o * step, r + SplitHeader::kHaloBytes, step);
    }
  }
  return d;
}

}  // namespace detail
}  // namespace stream
}  // namespace pcl_ecs
