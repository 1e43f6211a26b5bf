// record_stream.h — the points of a PCD, LAS or LAZ file as binary records, a chunk at a time, and
// records written to a PCD, LAS or LAZ file a chunk at a time: the input and output of the
// out-of-core run (`pcd_simplify --stream`), whatever the files' formats.
//
// Records are described by a PcdHeader (fields, point_step, count): a PCD file's own layout, or
// for LAS / LAZ the layout parseLas gives (x y z as double, one field per dimension).
#pragma once

#include <pcl_ecs/io/las_io.h>
#include <pcl_ecs/io/pcd_stream.h>

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace pcl_ecs
{
namespace io
{

/** \brief Reads a PCD (PcdStreamReader), LAS or LAZ file (LasStreamReader), chosen by its
 * extension; or several such files one after the other as one cloud (the tiles of a survey). */
class RecordSource
{
public:
  /** \brief Open `path` and read its header. Throws FileError (also for a format other than
   * PCD, LAS and LAZ) or FormatError, prefixed with the path. */
  explicit RecordSource(const std::string& path);
  /** \brief Several files read in the order given, as one: every header is read here, and every
   * file's records must have the first's layout (the same fields, types and record size: for
   * LAS, the same point format and extra bytes; scale and offset may differ). The LAS header of
   * the first is the cloud's. Throws as for one file, or FormatError naming the file whose
   * layout differs. */
  explicit RecordSource(const std::vector<std::string>& paths);
  ~RecordSource();
  RecordSource(const RecordSource&) = delete;
  RecordSource& operator=(const RecordSource&) = delete;

  const PcdHeader& header() const { return header_; }
  /** \brief Read up to `max_points` records into `records`; returns the count, 0 at the end. */
  std::size_t read(std::size_t max_points, std::vector<std::uint8_t>& records);
  /** \brief True when the file stores the records as read() gives them, record i at byte
   * `offset` + i × point_step (a binary PCD that is a regular file), so they can be read again
   * from the file itself. */
  bool recordsInFile(std::uint64_t& offset) const;
  /** \brief The LAS header of a LAS or LAZ input, else nullptr. */
  const LasInfo* las() const;

private:
  void open(std::size_t k);

  std::vector<std::string> paths_;
  std::vector<std::uint64_t> counts_;  // points of each file
  std::size_t current_ = 0;            // the file being read
  PcdHeader header_;
  std::unique_ptr<PcdStreamReader> pcd_;
  std::unique_ptr<LasStreamReader> las_;
  std::unique_ptr<LasInfo> las_info_;  // the first file's
};

/** \brief The files an input argument names: a file itself, or the .pcd, .las and .laz files of a
 * directory sorted by name (an archive's tiles). Throws FileError for a directory without any. */
std::vector<std::string> recordInputs(const std::vector<std::string>& args);

/** \brief Writes records to a binary PCD (PcdStreamWriter), LAS or LAZ file (LasStreamWriter),
 * chosen by the extension of `path`; nothing appears at `path` before commit(). */
class RecordSink
{
public:
  /** \param[in] layout the records' fields and point_step (and the PCD viewpoint)
   * \param[in] las for LAS / LAZ: the header of the file the records came from (its format,
   *   scale, offset and VLRs are kept); nullptr: defaultLasInfo(layout's fields, lo, hi)
   * \param[in] lo, hi a box that holds every point written (used without `las`)
   * Throws FileError for another extension or when the file cannot be created. */
  RecordSink(const std::string& path, const PcdHeader& layout, const LasInfo* las, const std::array<double, 3>& lo,
             const std::array<double, 3>& hi);
  ~RecordSink();
  RecordSink(const RecordSink&) = delete;
  RecordSink& operator=(const RecordSink&) = delete;

  void append(const std::uint8_t* records, std::size_t n);
  std::uint64_t written() const;
  void commit();

private:
  std::unique_ptr<PcdStreamWriter> pcd_;
  std::unique_ptr<LasStreamWriter> las_;
};

/** \brief True when `path`'s extension is one RecordSource reads and RecordSink writes. */
bool isRecordFormat(const std::string& path);

}  // namespace io
}  // namespace pcl_ecs
