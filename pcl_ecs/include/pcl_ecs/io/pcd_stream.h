// pcd_stream.h — PCD files larger than memory: a reader that hands out the points chunk by chunk
// (ascii, binary and binary_compressed, never the whole file) and a writer that appends chunks and
// fixes the header's counts at the end (temporary file, renamed into place on commit()).
//
// Points travel as binary records in the header's own layout (PCLPointField offsets, point_step
// bytes each, host byte order), whatever the file's encoding.
#pragma once

#include <pcl_ecs/io/cloud_io.h>

#include <array>
#include <cstdint>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <pcl/PCLPointField.h>

namespace pcl_ecs
{
namespace io
{

/** \brief How a PCD file stores its points. */
enum class PcdData
{
  Ascii,
  Binary,
  BinaryCompressed
};

/** \brief A parsed and checked PCD header. */
struct PcdHeader
{
  std::vector<pcl::PCLPointField> fields;  ///< names, datatypes, counts, offsets in a record
  std::uint32_t point_step = 0;            ///< bytes of one record
  std::uint64_t width = 0;
  std::uint64_t height = 1;
  std::uint64_t points = 0;
  PcdData data = PcdData::Binary;
  std::array<double, 7> viewpoint{{0, 0, 0, 1, 0, 0, 0}};  ///< tx ty tz qw qx qy qz

  /** \brief Index of the field called `name` in `fields`, or -1. */
  int fieldIndex(const std::string& name) const;
};

/** \brief Parse a PCD header from the lines that `next_line` hands out (without their '\n'),
 * up to and including the DATA line. Throws FormatError naming the line.
 * \param[in] max_points the largest POINTS accepted */
PcdHeader parsePcdHeader(const std::function<bool(std::string&)>& next_line, std::uint64_t max_points);

/** \brief Streams the points of a PCD file. Memory: one chunk, plus 64 KiB and an 8 KiB window per
 * field for binary_compressed (one LZF decoder per field, since that encoding stores each field for
 * all points in turn). */
class PcdStreamReader
{
public:
  /** \brief Open `path` and read its header. Throws FileError or FormatError (prefixed with the
   * path). A pipe or FIFO is read as it comes, once: ascii and binary data (a binary_compressed
   * one is refused: its fields are stored one after another), no rewind(). */
  explicit PcdStreamReader(const std::string& path);
  ~PcdStreamReader();
  PcdStreamReader(const PcdStreamReader&) = delete;
  PcdStreamReader& operator=(const PcdStreamReader&) = delete;

  const PcdHeader& header() const { return header_; }
  /** \brief Points not read yet. */
  std::uint64_t remaining() const { return header_.points - read_; }
  /** \brief Read up to `max_points` records into `records` (resized to count × point_step);
   * returns the count, 0 at the end. Throws FormatError naming the point for bad or truncated
   * data. */
  std::size_t read(std::size_t max_points, std::vector<std::uint8_t>& records);
  /** \brief Start again from the first point. */
  void rewind();
  /** \brief The byte where the data starts: for `DATA binary`, record i is the point_step bytes at
   * dataOffset() + i × point_step. */
  std::uint64_t dataOffset() const { return data_offset_; }
  /** \brief A regular file (not a pipe or FIFO, which are read once, as they come). */
  bool seekable() const { return seekable_; }

private:
  class Decoder;
  void openData();

  std::string path_;
  PcdHeader header_;
  std::uint64_t data_offset_ = 0;  ///< byte where the data starts
  std::uint64_t read_ = 0;
  std::uint64_t compressed_size_ = 0;
  bool seekable_ = true;  ///< a regular file (not a pipe or FIFO, which are read once, as they come)
  bool opened_ = false;   ///< openData() has run once
  std::ifstream in_;
  std::vector<std::unique_ptr<Decoder>> decoders_;  // binary_compressed: one per field
  // ascii: a buffered tokenizer
  std::vector<char> abuf_;
  std::size_t apos_ = 0, aend_ = 0;
  std::uint64_t aline_ = 0;
  bool nextToken(std::string& token);
};

/** \brief Writes a binary PCD chunk by chunk: a temporary file beside `path` whose header's
 * WIDTH and POINTS are fixed on commit(), then renamed into place. Without commit() (an exception,
 * a kill) nothing appears at `path`. Records come in the layout `fields` / `point_step` and are
 * written packed (no padding, no '_' fields), as writePcd writes them. */
class PcdStreamWriter
{
public:
  PcdStreamWriter(const std::string& path, const std::vector<pcl::PCLPointField>& fields,
                  std::uint32_t point_step, const std::array<double, 7>& viewpoint);
  ~PcdStreamWriter();
  PcdStreamWriter(const PcdStreamWriter&) = delete;
  PcdStreamWriter& operator=(const PcdStreamWriter&) = delete;

  /** \brief Append `n` records (point_step bytes each). Throws FileError. */
  void append(const std::uint8_t* records, std::size_t n);
  std::uint64_t written() const { return written_; }
  /** \brief Fix the counts, flush, rename into place. Throws FileError. */
  void commit();

private:
  std::string headerText(std::uint64_t points) const;

  AtomicOutput out_;
  std::ofstream file_;
  std::vector<pcl::PCLPointField> fields_;
  std::uint32_t point_step_;
  std::array<double, 7> viewpoint_;
  std::vector<pcl::PCLPointField> packed_fields_;
  std::uint32_t packed_step_ = 0;
  bool layout_packed_ = true;
  std::vector<std::uint8_t> pack_buffer_;
  std::uint64_t written_ = 0;
};

/** \brief x, y, z of a record as doubles (any numeric field type). */
struct XyzAccess
{
  std::uint32_t offset[3] = {0, 0, 0};
  std::uint8_t datatype[3] = {0, 0, 0};
  /** \brief Set up for `header`; throws FormatError when x, y or z is missing. */
  explicit XyzAccess(const PcdHeader& header);
  void get(const std::uint8_t* record, double& x, double& y, double& z) const;
  void set(std::uint8_t* record, double x, double y, double z) const;
};

/** \brief Store / load one value of a PCLPointField datatype (host byte order). */
void storeFieldValue(double value, std::uint8_t datatype, std::uint8_t* dst);
double loadFieldValue(std::uint8_t datatype, const std::uint8_t* src);

}  // namespace io
}  // namespace pcl_ecs
