// cloud_io.h — reading and writing point clouds for the tools: PCD (ascii, binary,
// binary_compressed; organised or not), PLY (ascii, binary little/big endian), plain-text XYZ,
// and LAS / LAZ (las_io.h).
// The parsers are our own so that every malformed input gets a precise message instead of a crash
// or a silent half-read (they are fuzzed: tests/fuzz). They produce a pcl::PCLPointCloud2 whose
// fields keep PCL's names (x y z, normal_x.., rgb/rgba, intensity, label, curvature) and the
// file's types; io::fromCloud (cloud_convert.h) turns it into any PCL point type, converting
// types that pcl::fromPCLPointCloud2 would leave at zero. The writers write packed records that
// PCL, Open3D and CloudCompare read.
#pragma once

#include <array>
#include <cstdint>
#include <istream>
#include <ostream>
#include <stdexcept>
#include <vector>
#include <string>

#include <pcl/PCLPointCloud2.h>

namespace pcl_ecs
{
namespace io
{

/** \brief Thrown for content that is not a valid cloud; what() says what is wrong and where. */
class FormatError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/** \brief Thrown for a file that cannot be read or written; what() starts with the path. */
class FileError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

enum class Format
{
  Pcd,
  Ply,
  Xyz,
  Las,
  Laz,
  Unknown
};

/** \brief The format for a path, by extension (case-insensitive): .pcd, .ply, .xyz / .txt / .pts /
 * .asc, .las, .laz. */
Format formatFromPath(const std::string& path);
/** \brief "PCD", "PLY", "XYZ", "LAS", "LAZ" or "unknown". */
const char* formatName(Format format);

/** \brief Encoding of a written PCD / PLY. */
enum class Encoding
{
  Binary,            ///< PCD binary, PLY binary_little_endian (default)
  Ascii,             ///< PCD ascii, PLY ascii
  BinaryCompressed   ///< PCD binary_compressed (PLY: written as binary)
};

/** \brief Parse a PCD file held in `bytes`. Throws FormatError. */
void parsePcd(const std::string& bytes, pcl::PCLPointCloud2& cloud);
/** \brief Parse a PLY file held in `bytes` (its vertex element). Throws FormatError. */
void parsePly(const std::string& bytes, pcl::PCLPointCloud2& cloud);
/** \brief Parse whitespace-separated columns, one point per line, '#' comments; x y z are double
 * when float would move a point by more than 1e-6 of the bounding-box diagonal, else float. By
 * column count:
 * 3: x y z; 4: x y z intensity; 6: x y z nx ny nz, or x y z r g b when the last three are all
 * integers in [0, 255] and one exceeds 1; 7: x y z r g b a (integers in [0, 255]);
 * 9: x y z nx ny nz r g b. Other counts, or lines of different counts, are refused.
 * Throws FormatError naming the line. */
void parseXyz(const std::string& bytes, pcl::PCLPointCloud2& cloud);

/** \brief Read `path`, by its extension, checking that the content matches it. Throws FileError
 * (missing, unreadable, a directory, empty) or FormatError (prefixed with the path). A PLY file
 * whose header declares more vertices than the file can hold is refused before its body is read.
 * A pipe or FIFO is read once, as it comes. */
void readCloud(const std::string& path, pcl::PCLPointCloud2& cloud);
struct LasInfo;
/** \brief readCloud that also gives, for a LAS or LAZ file, what its header says besides the
 * points (`las` is left as it was for other formats). Returns true for a LAS or LAZ file. */
bool readCloud(const std::string& path, pcl::PCLPointCloud2& cloud, LasInfo* las);

/** \brief What a file's header declares, read without its body. */
struct CloudProbe
{
  std::uint64_t points = 0;      ///< points declared
  std::uint64_t point_step = 0;  ///< bytes of a point's values (about a record in memory)
};
/** \brief The header of a regular PCD, PLY, LAS or LAZ file at `path` (XYZ files have none: zeros; so has
 * anything that is not a regular file, which is never read here). Throws FormatError (prefixed
 * with the path) for a bad header or, for binary data, one that declares more points than the
 * file holds. */
CloudProbe probeCloud(const std::string& path);
/** \brief probeCloud for a PLY header read from `in`; `file_size` bounds the body. */
CloudProbe probePly(std::istream& in, std::uint64_t file_size);

/** \brief Write `cloud` to `path` as `format` (Pcd, Ply, Las or Laz). Writes the path given
 * directly; use AtomicOutput for the write-then-rename. For LAS / LAZ, `las` is the header of the
 * file the cloud was read from (or null: see lasBytes in las_io.h); `encoding` is for PCD / PLY.
 * Throws FileError, or FormatError for a cloud LAS cannot hold. */
void writeCloud(const std::string& path, Format format, const pcl::PCLPointCloud2& cloud,
                Encoding encoding, const LasInfo* las = nullptr);

/** \brief Write a PLY file (vertex element only) to a stream; every field keeps its type. rgb / rgba
 * become uchar red green blue (alpha), normal_x.. become nx ny nz; x y z, intensity, label and
 * curvature keep the names PCL's PLY reader maps to its point types; every other field is named
 * `scalar_NAME`, which CloudCompare loads as a scalar field NAME without asking (parsePly reads
 * it back as NAME). Fields of count > 1 become NAME_0, NAME_1, ... */
void writePly(std::ostream& out, const pcl::PCLPointCloud2& cloud, bool binary);

/** \brief Write a PCD file to a stream, records packed (no padding, no '_' fields: every PCD
 * reader, PCL's included, reads it), fields in record order, types and names as in `cloud`.
 * Ascii writes floats with 9 and doubles with 17 significant digits (the same bits read back) and
 * a float `rgb` as its unsigned bits, as PCL does. Throws FileError. */
void writePcd(std::ostream& out, const pcl::PCLPointCloud2& cloud, Encoding encoding);

/** \brief The header of a PCD file whose records are laid out as `fields` (packed, see
 * packedFields in cloud_convert.h); `data` is "ascii", "binary" or "binary_compressed". With
 * `fixed_width_counts` WIDTH, HEIGHT and POINTS take 20 characters each, so that a writer can
 * rewrite them in place. */
std::string pcdHeader(const std::vector<pcl::PCLPointField>& fields, std::uint64_t width, std::uint64_t height,
                      const std::array<double, 7>& viewpoint, const char* data, bool fixed_width_counts);

/** \brief A temporary file beside `target` that becomes `target` only on commit(); removed by
 * the destructor otherwise, so a failed run leaves no partial output behind. commit() fsyncs the
 * file first (a full disk is an error then, never a truncated output) and renames it over the
 * target, which stays as it was until then. With removeTemporariesOnSignal() a SIGINT, SIGTERM,
 * SIGHUP or SIGPIPE removes the temporary files before the process dies. */
class AtomicOutput
{
public:
  explicit AtomicOutput(const std::string& target);
  ~AtomicOutput();
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;
  /** \brief Where to write. */
  const std::string& tempPath() const { return temp_; }
  const std::string& targetPath() const { return target_; }
  /** \brief Rename the temporary file into place. Throws FileError. */
  void commit();

private:
  std::string target_;
  std::string temp_;
  bool committed_ = false;
  int slot_ = -1;  // in the signal handler's list
};

/** \brief Install handlers for SIGINT, SIGTERM, SIGHUP and SIGPIPE that remove the temporary
 * files of every live AtomicOutput, then die of the signal as before. For tools, once at start. */
void removeTemporariesOnSignal();

/** \brief Check that a file can be created at `path` (its directory exists and is writable, the
 * path is not a directory). Returns an empty string or the reason. */
std::string checkWritable(const std::string& path);

}  // namespace io
}  // namespace pcl_ecs
