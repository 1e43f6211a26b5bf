// The pieces of LAS / LAZ reading and writing that the whole-file functions (las_io.cpp) and the
// chunked reader and writer (las_stream.cpp) share. Not installed.
#pragma once

#include <pcl_ecs/io/las_io.h>

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <pcl/PCLPointField.h>

#ifdef PCL_ECS_HAVE_LAZ
// The C ABI of rust/ecs_laz (src/lib.rs documents each function).
extern "C"
{
  struct EcsLazBytes
  {
    std::uint8_t* data;
    std::size_t len;
    std::size_t cap;
  };
  struct EcsLazReader;
  struct EcsLazWriter;
  std::uint64_t ecs_laz_max_extra_bytes();
  int ecs_laz_vlr(std::uint8_t format, std::uint16_t extra_bytes, EcsLazBytes* out, char* err, std::size_t err_cap);
  int ecs_laz_compress(const std::uint8_t* prefix, std::size_t prefix_len, const std::uint8_t* vlr, std::size_t vlr_len,
                       const std::uint8_t* records, std::uint64_t count, std::uint16_t record_len, EcsLazBytes* out,
                       char* err, std::size_t err_cap);
  int ecs_laz_decompress(const std::uint8_t* file, std::size_t file_len, std::uint64_t point_offset,
                         const std::uint8_t* vlr, std::size_t vlr_len, std::uint8_t* out, std::uint64_t count,
                         std::uint16_t record_len, char* err, std::size_t err_cap);
  void ecs_laz_free(EcsLazBytes* bytes);
  int ecs_laz_reader_open(const char* path, std::uint64_t point_offset, const std::uint8_t* vlr, std::size_t vlr_len,
                          std::uint64_t count, std::uint16_t record_len, EcsLazReader** reader, char* err,
                          std::size_t err_cap);
  int ecs_laz_reader_read(EcsLazReader* reader, std::uint8_t* out, std::uint64_t n, char* err, std::size_t err_cap);
  void ecs_laz_reader_close(EcsLazReader* reader);
  int ecs_laz_writer_open(const char* path, const std::uint8_t* vlr, std::size_t vlr_len, EcsLazWriter** writer,
                          char* err, std::size_t err_cap);
  int ecs_laz_writer_write(EcsLazWriter* writer, const std::uint8_t* records, std::uint64_t count,
                           std::uint16_t record_len, char* err, std::size_t err_cap);
  int ecs_laz_writer_finish(EcsLazWriter* writer, char* err, std::size_t err_cap);
  void ecs_laz_writer_free(EcsLazWriter* writer);
}
#endif

namespace pcl_ecs
{
namespace io
{
namespace las
{

/// Bytes `n` at `offset` of a file (fewer at its end).
using ReadAt = std::function<std::string(std::uint64_t offset, std::size_t n)>;

/// What the fixed part of a LAS header says of the points.
struct Header
{
  std::uint8_t minor = 0;
  std::uint16_t header_size = 0;
  std::uint32_t point_offset = 0;
  std::uint32_t vlr_count = 0;
  int format = 0;
  bool compressed = false;
  std::uint16_t record_length = 0;
  std::uint64_t points = 0;
};

/// Everything before (and after) a file's points: the header, its VLRs and EVLRs.
struct Layout : Header
{
  std::uint64_t evlr_start = 0, evlr_count = 0;
  LasInfo info;                        ///< VLRs and EVLRs without the LASzip VLR
  std::vector<std::uint8_t> laszip;    ///< the LASzip VLR's payload
  bool has_laszip = false;
  std::size_t extra() const { return record_length - lasStandardRecordLength(format); }
};

/// Read a file's header (`head`: its first 375 bytes or all of a shorter file), VLRs and EVLRs
/// (through `read_at`). Throws FormatError; `max_vlr_bytes` bounds the VLR and EVLR payloads kept.
Layout readLayout(const std::string& head, std::uint64_t file_size, const ReadAt& read_at,
                  std::uint64_t max_vlr_bytes = ~std::uint64_t{0});

/// The fields of a cloud read from point format `format` with `extra` extra bytes: x y z, the
/// format's dimensions, the extra bytes as one field `extra_bytes`.
std::vector<pcl::PCLPointField> cloudFields(int format, std::size_t extra, std::uint32_t& step);

/// The fields of a cloud read from a file of `layout`: as above, but the extra bytes as one field
/// per extra dimension when the Extra Bytes VLR describes all of them (namedExtraDims). Either
/// way the extra bytes lie together at the end of the record, as in the file.
std::vector<pcl::PCLPointField> cloudFields(const Layout& layout, std::uint32_t& step);

/// `n` raw LAS records → records of `step` bytes in the layout of cloudFields.
void decodeRecords(const Layout& layout, const std::uint8_t* raw, std::size_t n,
                   const std::vector<pcl::PCLPointField>& fields, std::uint32_t step, std::uint8_t* dst);

/// One dimension the Extra Bytes VLR (user "LASF_Spec", record 4) describes: its name, where it
/// lies in a record's extra bytes, its size, and its PCL datatype when it is one plain number
/// (0 for undocumented bytes, a 2- or 3-vector, or a value with a scale or an offset).
struct ExtraDim
{
  std::string name;
  std::size_t offset = 0, size = 0;
  std::uint8_t las_type = 0;
  std::uint8_t datatype = 0;
};

/// The dimensions `info`'s Extra Bytes VLR describes, in record order (none without one). False,
/// saying why, when the VLR cannot be read: a size that is not a whole number of 192-byte
/// descriptors, or a data type LAS does not define.
bool extraDims(const LasInfo& info, std::vector<ExtraDim>& dims, std::string& why);

/// The extra dimensions a reader gives as fields of their own: every one the Extra Bytes VLR of
/// `info` describes, when each is one plain number (ExtraDim::datatype) named with letters, digits
/// and '_' only (a PCD or PLY field name), not as a LAS field, no name twice, and together they
/// are the records' `extra` bytes; else none (the extra bytes travel as one field `extra_bytes`).
std::vector<ExtraDim> namedExtraDims(const LasInfo& info, std::size_t extra);

/// Records in any layout with a LAS dimension's names → raw LAS records of `info`'s format, and the
/// bounds and counts by return that the header states.
class Encoder
{
public:
  Encoder(const std::vector<pcl::PCLPointField>& fields, std::uint32_t point_step, const LasInfo& info);
  /// Appends `n` records' LAS bytes to `out`; `first` numbers the first for messages.
  void encode(const std::uint8_t* records, std::size_t n, std::uint64_t first, std::vector<std::uint8_t>& out);
  std::uint64_t count() const { return count_; }
  /// The bounds (integers) and counts by return of everything encoded.
  std::array<std::int32_t, 3> imin, imax;
  std::array<std::uint64_t, 15> by_return{};

private:
  /// Where one LAS dimension's value comes from: `bits` bits from bit `shift` of the `size`-byte
  /// integer at `offset` of the LAS record (bits 0: the whole value, of PCL type `datatype`), taken
  /// from `field` or, without one, from the byte at `rgb_shift` of a packed PCL rgb (× 257).
  struct Source
  {
    std::uint8_t datatype;
    std::uint16_t offset;
    std::uint8_t size;
    std::uint8_t shift;
    std::uint8_t bits;
    const pcl::PCLPointField* field;
    int rgb_shift;
  };
  std::vector<pcl::PCLPointField> fields_;
  std::uint32_t step_;
  const LasInfo& info_;
  std::vector<Source> sources_;
  const pcl::PCLPointField* xyz_[3] = {nullptr, nullptr, nullptr};
  const pcl::PCLPointField* packed_rgb_ = nullptr;
  const pcl::PCLPointField* extra_field_ = nullptr;
  /// Extra dimensions the header describes and the cloud has a field of that name for.
  std::vector<std::pair<ExtraDim, const pcl::PCLPointField*>> named_;
  std::uint64_t count_ = 0;
};

/// The LASzip VLR payload for `info`'s format (throws without LAZ support).
std::vector<std::uint8_t> laszipPayload(const LasInfo& info);

/// The header and VLRs of a file of `info` holding what `enc` encoded, with the LASzip VLR
/// `laszip` when not empty; `evlrs` gets the EVLRs to write after the points.
std::string headerBytes(const LasInfo& info, const Encoder& enc, const std::vector<std::uint8_t>& laszip,
                        std::vector<LasVlr>& evlrs);

/// The bytes of `evlrs` to write at byte `at` of the file (after its points), and their place set in
/// the file's header `head` (which the caller writes again).
std::string evlrBytes(const std::vector<LasVlr>& evlrs, std::uint64_t at, const LasInfo& info,
                      std::string& head);

}  // namespace las
}  // namespace io
}  // namespace pcl_ecs
