// las_io.h — ASPRS LAS 1.0-1.4 (point formats 0-10) and LAZ in and out of a pcl::PCLPointCloud2.
//
// A LAS point becomes a record with x y z as double (the file's integers times its scale plus its
// offset) and one field per dimension of its point format, named as laspy names them and typed as
// the file stores them (bit fields as uint8):
//   formats 0-5:  intensity return_number number_of_returns scan_direction_flag edge_of_flight_line
//                 classification synthetic key_point withheld scan_angle_rank user_data point_source_id
//   formats 6-10: intensity return_number number_of_returns synthetic key_point withheld overlap
//                 scanner_channel scan_direction_flag edge_of_flight_line classification user_data
//                 scan_angle point_source_id
//   and, by format: gps_time (1, 3-10), red green blue (uint16; 2, 3, 5, 7, 8, 10), nir (8, 10),
//   wavepacket_index wavepacket_offset (uint64) wavepacket_size return_point_wave_location
//   x_t y_t z_t (4, 5, 9, 10); the extra bytes of a record as one field per extra dimension when
//   the Extra Bytes VLR names each as one plain number (its name and type), else as one uint8
//   field `extra_bytes` of that count.
// The header travels beside the cloud as LasInfo (version, point format, scale, offset, VLRs and
// EVLRs such as the CRS, file source id, GUID, creation date), so that writing a cloud read from a
// LAS file gives a file of the same kind: a point whose x y z did not change is written as the same
// integers, every other dimension as it was read.
// LAZ (LASzip) goes through the `laz` crate (laz-rs) when the library is built with it
// (lazSupported()).
#pragma once

#include <array>
#include <cstdint>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <pcl/PCLPointCloud2.h>

namespace pcl_ecs
{
namespace io
{

/** \brief A variable-length record of a LAS header (or an extended one, after the points). */
struct LasVlr
{
  std::uint16_t reserved = 0;
  std::string user_id;       ///< up to 16 characters
  std::uint16_t record_id = 0;
  std::string description;   ///< up to 32 characters
  std::vector<std::uint8_t> data;
  bool extended = false;     ///< an EVLR (LAS 1.3 and later), written after the points
};

/** \brief What a LAS header says besides the points. */
struct LasInfo
{
  std::uint8_t version_minor = 2;  ///< LAS 1.x
  std::uint8_t point_format = 0;   ///< 0-10
  std::uint16_t record_length = 20;
  std::uint16_t file_source_id = 0;
  std::uint16_t global_encoding = 0;
  std::array<std::uint8_t, 16> guid{};
  std::string system_identifier;
  std::string generating_software;
  std::uint16_t creation_day = 0;
  std::uint16_t creation_year = 0;
  std::array<double, 3> scale{{0.001, 0.001, 0.001}};
  std::array<double, 3> offset{{0.0, 0.0, 0.0}};
  std::vector<LasVlr> vlrs;  ///< VLRs and EVLRs in file order, without the LASzip VLR
  bool compressed = false;   ///< read from a LAZ file
};

/** \brief Bytes of the standard fields of LAS point format `format` (0-10); 0 for another. */
std::size_t lasStandardRecordLength(int format);

/** \brief Parse a whole LAS or LAZ file held in `bytes`. Throws FormatError saying what is wrong
 * and where (a header that declares more points than the file holds, a record length too short
 * for its format, VLRs past the point data, corrupt compressed points). */
void parseLas(const std::string& bytes, pcl::PCLPointCloud2& cloud, LasInfo* info = nullptr);

/** \brief Points declared and the size of one in memory, read from the header in `bytes` (its
 * first 375 bytes suffice); refuses as parseLas would a header that is not one, or an uncompressed
 * file (of `file_size` bytes) too short for the points it declares. */
void probeLas(const std::string& header_bytes, std::uint64_t file_size, std::uint64_t& points,
              std::uint64_t& point_step);

/** \brief A whole LAS (or, `compressed`, LAZ) file for `cloud`.
 *
 * With `like` (the LasInfo of the file the cloud was read from) the file keeps its version, point
 * format, record length, scale, offset, VLRs and EVLRs and the header's identifiers and date; the
 * bounds and the counts by return are those of the points written. Without it, the point format
 * is 0-3 by the fields the cloud has (gps_time, colour), version 1.2, offset the box centre
 * rounded down to an integer and the scale the finest power of ten that holds the box in
 * 31-bit integers; fields with a LAS dimension's name are written to it (a PCL rgb/rgba as
 * 16-bit colour, value × 257), other fields have no place in these formats and are not written.
 * x y z are rounded to the scale. Throws FormatError for a coordinate that does not fit the
 * scale and offset, or for LAZ when the library is built without it. */
std::string lasBytes(const pcl::PCLPointCloud2& cloud, const LasInfo* like, bool compressed);

/** \brief The header lasBytes(cloud, like, ...) writes the cloud with: `like`, or without it the
 * header of defaultLasInfo for the cloud's fields and the box of its finite points. */
LasInfo lasInfoFor(const pcl::PCLPointCloud2& cloud, const LasInfo* like);

/** \brief Whether `name` is a field parseLas gives for some point format (x, y, z, a dimension such
 * as intensity or gps_time, extra_bytes) or a PCL colour field (rgb, rgba): not a name for an
 * extra dimension. */
bool isLasFieldName(const std::string& name);

/** \brief A cloud field to write as an extra dimension of LAS records (addLasExtraDimensions). */
struct ExtraDimension
{
  std::string name;         ///< the field's name, 1 to 31 characters, also the dimension's
  std::string description;  ///< up to 31 characters
};

/** \brief Makes the records of `info` hold the cloud fields `add` (each one number of any PCL
 * type; `fields` are the cloud's) as extra dimensions after the extra bytes they have: the record
 * length grows by their sizes and the Extra Bytes VLR (user "LASF_Spec", record 4; laspy, PDAL,
 * CloudCompare and LAStools read it in any LAS version) describes them, with the name and type of
 * the field. Extra bytes no descriptor covered are first described as undocumented. A dimension the
 * records already have with that name and type (a file written so, simplified again) is written
 * over instead. lasBytes and LasStreamWriter then write those fields' values there. Throws
 * FormatError when a field is missing or not one number, a dimension of that name has another
 * type, the Extra Bytes VLR cannot be read or describes more bytes than the records hold, or a
 * record would pass 65,535 bytes. */
void addLasExtraDimensions(LasInfo& info, const std::vector<pcl::PCLPointField>& fields,
                           const std::vector<ExtraDimension>& add);

/** \brief True when LAZ can be read and written (the library was built with the laz crate). */
bool lazSupported();

/** \brief The most extra bytes per record (after the point format's fields) that LAZ is read and
 * written with: the codec keeps models for every extra byte before the first point (up to 45 kB
 * each), so more is refused as a FormatError. 0 when built without LAZ. */
std::size_t lazMaxExtraBytes();

/** \brief Why records with the header `info` cannot be written as LAZ (more extra bytes than
 * lazMaxExtraBytes(), or no LAZ in this build), or empty when they can. */
std::string lazCannotWrite(const LasInfo& info);

/** \brief The header lasBytes gives a cloud without a LAS origin whose fields are `fields` and
 * whose finite points lie in the box [lo, hi]: point format 0-3, version 1.2, offset the box
 * centre rounded down to an integer, scale the finest power of ten that holds the box in 31-bit
 * integers. */
LasInfo defaultLasInfo(const std::vector<pcl::PCLPointField>& fields, const std::array<double, 3>& lo,
                       const std::array<double, 3>& hi);

/** \brief Make `info`'s scale and offset hold the box [lo, hi] in 32-bit integers: unchanged when
 * they do; else the offset becomes the box centre rounded down to an integer and, if that is not
 * enough, the scale grows by powers of ten until it is (the tiles of a survey, each with its own
 * offset, written as one file). */
void fitLasFrame(LasInfo& info, const std::array<double, 3>& lo, const std::array<double, 3>& hi);

/** \brief The points of a LAS or LAZ file a chunk at a time, in the layout parseLas gives them
 * (for files larger than memory: `pcd_simplify --stream`). Memory: one chunk and the header's
 * VLRs and EVLRs (at most 256 MiB of them). */
class LasStreamReader
{
public:
  /** \brief Open `path` and read its header, VLRs and EVLRs. Throws FileError or FormatError
   * (prefixed with the path), as readCloud does for the same file. */
  explicit LasStreamReader(const std::string& path);
  ~LasStreamReader();
  LasStreamReader(const LasStreamReader&) = delete;
  LasStreamReader& operator=(const LasStreamReader&) = delete;

  const std::vector<pcl::PCLPointField>& fields() const { return fields_; }
  std::uint32_t pointStep() const { return step_; }
  std::uint64_t points() const;
  const LasInfo& info() const;
  /** \brief Points not read yet. */
  std::uint64_t remaining() const;
  /** \brief Read up to `max_points` records into `records` (resized to count × pointStep());
   * returns the count, 0 at the end. Throws FormatError for corrupt or truncated data. */
  std::size_t read(std::size_t max_points, std::vector<std::uint8_t>& records);

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<pcl::PCLPointField> fields_;
  std::uint32_t step_ = 0;
};

/** \brief Writes a LAS or LAZ file chunk by chunk: a temporary file beside `path` whose header
 * (counts, bounds) is completed on commit(), then renamed into place. Without commit() nothing
 * appears at `path`. The file is the one lasBytes(cloud of all the records, &info, compressed)
 * gives. */
class LasStreamWriter
{
public:
  LasStreamWriter(const std::string& path, const std::vector<pcl::PCLPointField>& fields,
                  std::uint32_t point_step, const LasInfo& info, bool compressed);
  ~LasStreamWriter();
  LasStreamWriter(const LasStreamWriter&) = delete;
  LasStreamWriter& operator=(const LasStreamWriter&) = delete;

  /** \brief Append `n` records (point_step bytes each, in the layout `fields`). Throws FileError
   * or FormatError (a coordinate that does not fit the scale and offset). */
  void append(const std::uint8_t* records, std::size_t n);
  std::uint64_t written() const;
  /** \brief Complete the header, flush, rename into place. Throws FileError. */
  void commit();

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace io
}  // namespace pcl_ecs
