// out_of_core.cpp — the out-of-core run (out_of_core.h, docs/STREAMING.md): its steps in order, as
// one process (simplifyOutOfCore) or as tasks (TiledRun); the pieces are in tiled_run.h.
#include "tiled_run.h"

namespace pcl_ecs
{
namespace stream
{
namespace detail
{

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
  if (params_.max_deviation > 0.0 || params_.max_deviation_of_L > 0.0 || params_.report_deviation)
    failRun("--stream does not measure or bound the deviation (--max-deviation, --report-deviation); run in "
            "memory for those");
  if (params_.feature_spacing > 0.0)
    failRun("--stream keeps every feature point; --feature-spacing is not supported with it");
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
  if (las_ && io::formatFromPath(output_) == io::Format::Laz)
    if (const std::string why = io::lazCannotWrite(*las_); !why.empty())
      failRun(output_ + ": " + why);
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
  if (params_.error_threshold_abs > 0.0)
  {
    // T_err in input units: a fraction of L, as the tiles take it.
    params_.error_threshold = params_.error_threshold_abs / summary_.bbox_diagonal;
    if (!(params_.error_threshold < 1.0))
    {
      std::ostringstream os;
      os << "--terr-abs " << params_.error_threshold_abs << " is not below the bounding box's diagonal ("
         << summary_.bbox_diagonal << "): T_err must be below 1";
      failRun(os.str());
    }
  }
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
  const TileSumsA a = TileSumsA::from(
      tileTotals(paths_.totalA(), tiles, TileSumsA::kValues, [&](int t) { return paths_.sumA(t); }));
  summary_.merged_points = static_cast<std::uint64_t>(a.merged);
  measures_ = a.stats;
  delta_ = a.stats.featureThreshold(params_.feature_factor);
  summary_.feature_threshold = delta_ / plan_.scale();
  summary_.incomplete_neighbourhoods = static_cast<std::uint64_t>(a.incomplete);
}

int Runner::globalsAfterB(bool warn)
{
  const int tiles = static_cast<int>(plan_.tree.tiles.size());
  const TileSumsB b = TileSumsB::from(
      tileTotals(paths_.totalB(), tiles, TileSumsB::kValues, [&](int t) { return paths_.sumB(t); }));
  summary_.search_fallback_tiles = static_cast<std::uint64_t>(b.searched);
  stats_ = b.stats;  // the whole scan's sums for eq. 6, 1 and 12 (the cover's means)
  stats_.merge(measures_);  // and eq. 3's (the noise level the representatives' fits are held to)
  summary_.mean_spacing = stats_.meanSpacing() / plan_.scale();
  summary_.neighborhood_radius = stats_.neighborhoodRadius() / plan_.scale();
  summary_.mean_abs_curvature = stats_.meanAbsCurvature() * plan_.scale();
  cap_ = params_.radius_cap_factor * stats_.neighborhoodRadius();  // local units, as every phase's lengths
  const double cap_world = cap_ / plan_.scale();
  if (tiles > 1 && cap_world > plan_.halo)  // one tile has no halo, and no border to cut balls at
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
  // The claims written so far (coverTask keeps those of earlier colours).
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
           [&](int t) { geometryTask(t); });
  globalsAfterA();
  track_scratch();

  // Phase B, then the means of eq. 6 and 12 and the radius unit over all non-feature points.
  runStage("B (features, eq. 5)", 3, pending([&](int t) { return paths_.sumB(t); }), [&](int t) { densityTask(t); });
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
    runStage(name.c_str(), 4, todo, [&](int t) { coverTask(t); });
  }
  if (params_.max_gap_factor > 0.0)
    for (int c = 0; c < colours; ++c)
    {
      std::vector<int> todo;
      for (int t = 0; t < tiles; ++t)
        if (plan_.tree.tiles[static_cast<std::size_t>(t)].colour == c && !fs::exists(paths_.doneD(t)))
          todo.push_back(t);
      const std::string name = "D (gaps, colour " + std::to_string(c + 1) + "/" + std::to_string(colours) + ")";
      runStage(name.c_str(), 4, todo, [&](int t) { gapTask(t); });
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
    geometryTask(t);
    break;
  case 'B':
    if (done(paths_.sumB(t)))
      return false;
    globalsAfterA();
    densityTask(t);
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
      coverTask(t);
    }
    else
      gapTask(t);
    break;
  default: failRun(std::string("no stage '") + stage + "' (A, B, C, D)");
  }
  stepDone();
  return true;
}

}  // namespace detail

using detail::Runner;

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

}  // namespace stream
}  // namespace pcl_ecs
