// out_of_core.h — the paper's method on PCD scans larger than memory (docs/STREAMING.md).
//
//  scan   stream the input once (its only read): count, bounds, a deterministic ~1M-point
//         sample, and a binary copy of the finite points in the scratch directory;
//  plan   split the sample's 2D footprint (the two longest axes) into tiles of even point
//         counts, sized so that a tile with its halo fits the memory budget; estimate the halo
//         width (neighbourhoods + the largest ball) from the sample;
//  split  stream that copy: every point to its tile's core file, and to the halo file of every
//         other tile within the halo width (scratch directory); the copy is then deleted;
//  A      per tile: K-neighbourhoods, normals, eq. 1, eq. 3 and eq. 7-11 → per-tile sums;
//         δ = α × the mean measure over ALL points (eq. 4);
//  B      per tile: features, eq. 5 → the global means of eq. 6, eq. 12 and the radius unit;
//  C      per tile, colour by colour (tiles closer than two ball radii never share a colour):
//         the cover, centres taken from the tile's own points only; points claimed in other
//         tiles are recorded so that nothing is covered twice and nothing is missed;
//  write  the tiles' outputs in tile order (temporary file, renamed into place).
// Every step writes its results to the scratch directory under a temporary name and renames them
// when complete, so a killed run started again with the same command resumes where it stopped.
// The output depends on the input, the parameters and the memory limit (the tiling), never on the
// thread count.
#pragma once

#include <pcl_ecs/parameters.h>

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace pcl_ecs
{
namespace stream
{

/** \brief Settings of the out-of-core run (the method's own are in Parameters). */
struct StreamOptions
{
  /** \brief The memory budget in bytes (0: a quarter of the physical memory, at least 256 MiB). */
  std::uint64_t memory_limit = 0;
  /** \brief Scratch directory ("" : OUTPUT.ecs-scratch beside the output). A directory that
   * does not exist yet is made and is the scratch; an existing one that this tool did not make
   * (a user's directory, /tmp) holds the scratch as a directory of ours, NAME.ecs-scratch for an
   * output NAME. Only what the run made is removed (on success, unless keep_scratch). */
  std::string scratch_dir;
  /** \brief Keep the scratch directory and every intermediate file in it (by default a tile's
   * files are removed as soon as no later step reads them, and the directory on success). */
  bool keep_scratch = false;
  /** \brief Largest tile (own points + halo) in points; 0: derived from memory_limit. For tests and
   * experiments: part of the plan, so it changes the output like the memory limit does. */
  std::uint64_t max_tile_points = 0;
  /** \brief Progress lines (stage, tiles done, tiles, points per second, seconds left). */
  std::function<void(const std::string& line)> progress;
  /** \brief For tests: kill the process (SIGKILL) after this many tile steps (0: never). */
  std::uint64_t kill_after_steps = 0;
};

/** \brief One tile: its rectangle in the plane of the two longest axes (axis_u, axis_v). */
struct Tile
{
  std::array<double, 2> lo{{0, 0}};
  std::array<double, 2> hi{{0, 0}};
  std::uint64_t core_points = 0;
  std::uint64_t halo_points = 0;
  int colour = 0;
};

/** \brief What a run did. */
struct StreamSummary
{
  std::uint64_t input_points = 0;
  std::uint64_t finite_points = 0;
  std::uint64_t merged_points = 0;   ///< of those, points at exactly the place of another, merged into it
  std::uint64_t output_points = 0;
  std::uint64_t feature_points = 0;
  std::uint64_t balls = 0;           ///< ball representatives, gap points included
  std::uint64_t gap_points = 0;      ///< points added by the gap bound (phase D)
  int axis_u = 0, axis_v = 1;
  std::vector<Tile> tiles;
  double halo = 0.0;                  ///< halo width (input units)
  double bbox_diagonal = 0.0;         ///< L
  double feature_threshold = 0.0;     ///< δ
  double mean_spacing = 0.0;          ///< eq. 6
  double mean_abs_curvature = 0.0;    ///< eq. 12
  double neighborhood_radius = 0.0;   ///< radius cap unit
  double max_error = 0.0;
  std::uint64_t incomplete_neighbourhoods = 0;  ///< core points whose K neighbours reach past the halo
  std::uint64_t search_fallback_tiles = 0;  ///< tiles re-read in phase B (a point with only feature neighbours)
  int split_runs = 0;                 ///< runs of the input the split read at once (threads, open files)
  bool halo_too_narrow = false;       ///< 2 × the radius cap did not fit in the halo (warned)
  std::uint64_t tile_point_budget = 0;  ///< largest core + halo planned per tile
  std::uint64_t scratch_bytes = 0;    ///< largest scratch directory size seen
  bool resumed = false;               ///< finished steps of an earlier run were reused
  double seconds = 0.0;
  std::array<double, 6> stage_seconds{{0, 0, 0, 0, 0, 0}};  ///< scan, split, A, B, C, write
};

/** \brief A memory limit this run cannot keep; what() names the smallest one that works. */
struct LimitError : std::runtime_error
{
  using std::runtime_error::runtime_error;
};

/** \brief Run the method on `input` (a PCD file) into `output` (binary PCD with the input's fields,
 * records packed). Throws io::FileError / io::FormatError for unreadable or bad input, LimitError
 * before any work when the memory limit is below what the run needs, std::runtime_error for
 * anything else (message says what and where). Nothing appears at `output` unless it succeeds.
 * Parameters::target_size is not supported here (refused). */
StreamSummary simplifyOutOfCore(const std::string& input, const std::string& output,
                                const Parameters& params, const StreamOptions& options);
/** \brief simplifyOutOfCore on several files read one after the other as one cloud (the tiles of
 * a survey; io::RecordSource says what they must share). */
StreamSummary simplifyOutOfCore(const std::vector<std::string>& inputs, const std::string& output,
                                const Parameters& params, const StreamOptions& options);

/** \brief The out-of-core run as tasks, for a scheduler of the caller's (pcl_ecs.distributed
 * runs them on Dask): prepare() once (the scan, the plan and the split), then runTask() for every
 * tile's stage 'A' and 'B', colours(), then stage 'C' and (when Parameters::max_gap_factor > 0)
 * 'D', then finish(). A task reads its inputs from the scratch directory and writes its outputs
 * there atomically, so any process that reaches the scratch may run it (a TiledRun made with the
 * same arguments and prepare(false)), and a task run again returns at once. Dependencies:
 * B(t) needs A of every tile; C(t) needs B of every tile and C of every tile of a lower colour;
 * D(t) needs C of every tile and D of every tile of a lower colour; finish() needs them all. The
 * output is the bytes simplifyOutOfCore gives for the same input, parameters and options. */
class TiledRun
{
public:
  TiledRun(const std::string& input, const std::string& output, const Parameters& params,
           const StreamOptions& options);
  TiledRun(const std::vector<std::string>& inputs, const std::string& output, const Parameters& params,
           const StreamOptions& options);
  ~TiledRun();
  TiledRun(const TiledRun&) = delete;
  TiledRun& operator=(const TiledRun&) = delete;

  /** \brief Open the input's header and the plan; with `plan`, scan, plan and split first when
   * the scratch holds no plan for this run (without: that is an error). Returns the tiles. Throws
   * as simplifyOutOfCore does. */
  int prepare(bool plan = true);
  /** \brief Each tile's colour, once every tile's stage B is done. */
  std::vector<int> colours();
  /** \brief Run stage `stage` ('A', 'B', 'C' or 'D') of tile `tile`; false when it was done
   * already. */
  bool runTask(char stage, int tile);
  /** \brief Write the output from every tile's results and remove the scratch (unless
   * keep_scratch); the run's summary. */
  StreamSummary finish();

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/** \brief Parse a size like "512M", "2G", "1.5G", "800000K" or plain bytes; false when malformed. */
bool parseByteSize(const std::string& text, std::uint64_t& bytes);

/** \brief Physical memory of this machine in bytes (0 when unknown). */
std::uint64_t physicalMemory();

/** \brief Memory available to a new allocation now (MemAvailable of /proc/meminfo; the physical
 * memory when that cannot be read). */
std::uint64_t availableMemory();

/** \brief Split the 2D sample points into the fewest tiles of at most `max_per_tile` samples each,
 * counting with a tile's own samples those within `halo` of its rectangle, as even as possible, by
 * recursive splits of the longer side (a part that needs m tiles is split m/2 : m - m/2;
 * deterministic; ties by position in the list). The outer tiles reach to infinity; each tile's
 * core_points and halo_points are its sample counts. */
std::vector<Tile> planTiles(const std::vector<std::array<double, 2>>& sample, std::size_t max_per_tile,
                            double halo = 0.0);

/** \brief Distance between two tiles' rectangles (0 when they touch). */
double tileDistance(const Tile& a, const Tile& b);

/** \brief Greedy colouring in tile order: two tiles closer than `separation` get different colours.
 * Returns the number of colours. */
int colourTiles(std::vector<Tile>& tiles, double separation);

}  // namespace stream
}  // namespace pcl_ecs
