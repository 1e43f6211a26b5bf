// Streaming PCD: see pcd_stream.h.
#include <pcl_ecs/io/pcd_stream.h>

#include "io_detail.h"

#include <pcl_ecs/io/cloud_convert.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <sstream>

namespace pcl_ecs
{
namespace io
{

using detail::fail;

namespace
{
constexpr std::uint64_t kMaxStreamPoints = 1ull << 40;

/// Fail with a FormatError prefixed by the path.
template <typename... Args>
[[noreturn]] void failAt(const std::string& path, Args&&... args)
{
  std::ostringstream os;
  os << path << ": ";
  (os << ... << args);
  throw FormatError(os.str());
}
}  // namespace

void storeFieldValue(double value, std::uint8_t datatype, std::uint8_t* dst)
{
  detail::storeValue(value, datatype, dst);
}

double loadFieldValue(std::uint8_t datatype, const std::uint8_t* src)
{
  return detail::loadValue(datatype, src);
}

// ---------------------------------------------------------------------------------------------
// LZF, decoded as a stream: a literal run (ctrl < 32: ctrl + 1 bytes follow) or a back reference
// (length ctrl >> 5, 7 meaning "add the next byte"; distance ((ctrl & 31) << 8) + next + 1, at most
// 8192). Keeping the last 8 KiB of output is all the state the format needs.
class PcdStreamReader::Decoder
{
public:
  Decoder(const std::string& path, std::uint64_t offset, std::uint64_t csize, std::uint64_t total)
    : path_(path), left_in_(csize), total_(total)
  {
    in_.open(path, std::ios::binary);
    in_.seekg(static_cast<std::streamoff>(offset));
    if (!in_)
      throw FileError(path + ": cannot read the compressed block");
    ibuf_.resize(1 << 16);
  }

  void skip(std::uint64_t n)
  {
    std::vector<std::uint8_t> sink(1 << 16);
    while (n > 0)
    {
      const std::size_t m = static_cast<std::size_t>(std::min<std::uint64_t>(n, sink.size()));
      read(sink.data(), m);
      n -= m;
    }
  }

  void read(std::uint8_t* dst, std::size_t n)
  {
    while (out_.size() - head_ < n)
    {
      if (head_ > (1u << 18))
      {
        // Keep the 8 KiB window before head_ and what is not handed out yet.
        const std::size_t keep_from = head_ - kWindow;
        out_.erase(out_.begin(), out_.begin() + static_cast<std::ptrdiff_t>(keep_from));
        head_ = kWindow;
      }
      decodeOne();
    }
    std::memcpy(dst, out_.data() + head_, n);
    head_ += n;
  }

private:
  static constexpr std::size_t kWindow = 8192;

  std::uint8_t nextIn()
  {
    if (ipos_ == iend_)
    {
      if (left_in_ == 0)
        failAt(path_, "corrupt compressed block: it ends after ", produced_, " of ", total_, " bytes");
      const std::size_t m = static_cast<std::size_t>(std::min<std::uint64_t>(left_in_, ibuf_.size()));
      in_.read(reinterpret_cast<char*>(ibuf_.data()), static_cast<std::streamsize>(m));
      if (static_cast<std::size_t>(in_.gcount()) != m)
        failAt(path_, "truncated: the compressed block is shorter than its stated size");
      left_in_ -= m;
      ipos_ = 0;
      iend_ = m;
    }
    return ibuf_[ipos_++];
  }

  void decodeOne()
  {
    const unsigned ctrl = nextIn();
    std::size_t len;
    if (ctrl < 32)
    {
      len = ctrl + 1;
      if (produced_ + len > total_)
        failAt(path_, "corrupt compressed block: it unpacks to more than ", total_, " bytes");
      for (std::size_t i = 0; i < len; ++i)
        out_.push_back(nextIn());
    }
    else
    {
      len = ctrl >> 5;
      if (len == 7)
        len += nextIn();
      len += 2;
      const std::size_t back = ((ctrl & 0x1fu) << 8) + nextIn() + 1;
      if (back > out_.size() || back > produced_)
        failAt(path_, "corrupt compressed block: a reference before the start of the data");
      if (produced_ + len > total_)
        failAt(path_, "corrupt compressed block: it unpacks to more than ", total_, " bytes");
      std::size_t from = out_.size() - back;
      for (std::size_t i = 0; i < len; ++i)
        out_.push_back(out_[from++]);  // may overlap the bytes being written: byte by byte
    }
    produced_ += len;
  }

  std::string path_;
  std::ifstream in_;
  std::uint64_t left_in_;
  std::uint64_t total_;
  std::uint64_t produced_ = 0;
  std::vector<std::uint8_t> ibuf_;
  std::size_t ipos_ = 0, iend_ = 0;
  std::vector<std::uint8_t> out_;
  std::size_t head_ = 0;
};

PcdStreamReader::PcdStreamReader(const std::string& path) : path_(path)
{
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw FileError(path + ": no such file");
  if (std::filesystem::is_directory(path, ec))
    throw FileError(path + ": is a directory, not a file");
  {
    std::error_code ec;
    seekable_ = std::filesystem::is_regular_file(path, ec);
  }
  in_.open(path, std::ios::binary);
  if (!in_)
    throw FileError(path + ": cannot open it for reading (" + std::strerror(errno) + ")");
  std::uint64_t consumed = 0;
  bool any = false;
  try
  {
    header_ = parsePcdHeader(
        [&](std::string& line) {
          if (!detail::readHeaderLine(in_, line))
            return false;
          any = true;
          consumed += line.size() + 1;  // an over-long line is refused by the parser
          return true;
        },
        kMaxStreamPoints);
  }
  catch (const FormatError& e)
  {
    if (!any)
      throw FormatError(path + ": the file is empty");
    throw FormatError(path + ": " + e.what());
  }
  data_offset_ = consumed;
  openData();
}

PcdStreamReader::~PcdStreamReader() = default;

void PcdStreamReader::openData()
{
  read_ = 0;
  decoders_.clear();
  in_.clear();
  if (!seekable_)
  {
    // Read as it comes: right after the header, once. Truncation shows when the data ends.
    if (opened_)
      failAt(path_, "is a pipe or FIFO and cannot be read twice");
    if (header_.data == PcdData::BinaryCompressed)
      failAt(path_, "binary_compressed data cannot be streamed from a pipe or FIFO (its fields are stored one "
                    "after another): give a file, or read it in memory (without --stream)");
    opened_ = true;
    if (header_.data == PcdData::Ascii)
    {
      abuf_.resize(1 << 20);
      apos_ = aend_ = 0;
      aline_ = 0;
    }
    return;
  }
  opened_ = true;
  in_.seekg(static_cast<std::streamoff>(data_offset_));
  const std::uint64_t total = static_cast<std::uint64_t>(header_.point_step) * header_.points;
  std::error_code ec;
  const std::uint64_t file_size = std::filesystem::file_size(path_, ec);
  const std::uint64_t remaining = file_size > data_offset_ ? file_size - data_offset_ : 0;
  if (header_.data == PcdData::Binary)
  {
    if (total > remaining)
      failAt(path_, "truncated: the header promises ", header_.points, " points (", total,
             " bytes) but the file holds ", remaining, " data bytes");
  }
  else if (header_.data == PcdData::BinaryCompressed)
  {
    if (remaining < 8)
      failAt(path_, "truncated: binary_compressed data without its sizes");
    std::uint32_t sizes[2] = {0, 0};
    in_.read(reinterpret_cast<char*>(sizes), 8);
    const std::uint64_t csize = sizes[0], usize = sizes[1];
    if (csize > remaining - 8)
      failAt(path_, "truncated: the compressed block is ", csize, " bytes but the file holds ", remaining - 8);
    // A 32-bit size field: files of 4 GiB of data and more cannot be binary_compressed.
    if (usize != total)
      failAt(path_, "the header is inconsistent: ", header_.points, " points of ", header_.point_step,
             " bytes need ", total, " bytes but the compressed block says ", usize);
    compressed_size_ = csize;  // the decoders start on the first read()
  }
  else
  {
    abuf_.resize(1 << 20);
    apos_ = aend_ = 0;
    aline_ = 0;
  }
}

void PcdStreamReader::rewind()
{
  openData();
}

bool PcdStreamReader::nextToken(std::string& token)
{
  token.clear();
  for (;;)
  {
    if (apos_ == aend_)
    {
      in_.read(abuf_.data(), static_cast<std::streamsize>(abuf_.size()));
      aend_ = static_cast<std::size_t>(in_.gcount());
      apos_ = 0;
      if (aend_ == 0)
        return !token.empty();
    }
    const char c = abuf_[apos_];
    if (std::isspace(static_cast<unsigned char>(c)))
    {
      if (!token.empty())
        return true;
      if (c == '\n')
        ++aline_;
      ++apos_;
      continue;
    }
    token.push_back(c);
    ++apos_;
  }
}

std::size_t PcdStreamReader::read(std::size_t max_points, std::vector<std::uint8_t>& records)
{
  const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(max_points, remaining()));
  const std::size_t step = header_.point_step;
  records.resize(n * step);
  if (n == 0)
    return 0;
  if (header_.data == PcdData::Binary)
  {
    in_.read(reinterpret_cast<char*>(records.data()), static_cast<std::streamsize>(n * step));
    if (static_cast<std::size_t>(in_.gcount()) != n * step)
      failAt(path_, "truncated: the data ends in point ", read_ + static_cast<std::size_t>(in_.gcount()) / step);
  }
  else if (header_.data == PcdData::BinaryCompressed)
  {
    if (decoders_.empty())
    {
      const std::uint64_t total = static_cast<std::uint64_t>(header_.point_step) * header_.points;
      std::uint64_t field_start = 0;
      for (const auto& f : header_.fields)
      {
        auto d = std::make_unique<Decoder>(path_, data_offset_ + 8, compressed_size_, total);
        d->skip(field_start);
        field_start += detail::datatypeSize(f.datatype) * f.count * header_.points;
        decoders_.push_back(std::move(d));
      }
    }
    std::vector<std::uint8_t> column;
    for (std::size_t f = 0; f < header_.fields.size(); ++f)
    {
      const auto& field = header_.fields[f];
      const std::size_t fsize = detail::datatypeSize(field.datatype) * field.count;
      column.resize(n * fsize);
      decoders_[f]->read(column.data(), column.size());
      for (std::size_t i = 0; i < n; ++i)
        std::memcpy(records.data() + i * step + field.offset, column.data() + i * fsize, fsize);
    }
  }
  else
  {
    std::fill(records.begin(), records.end(), 0);
    std::string token;
    for (std::size_t i = 0; i < n; ++i)
    {
      std::uint8_t* dst = records.data() + i * step;
      for (const auto& f : header_.fields)
        for (std::uint32_t c = 0; c < f.count; ++c)
        {
          if (!nextToken(token))
            failAt(path_, "truncated: the header promises ", header_.points, " points but the data ends after ",
                   read_ + i);
          if (!detail::storeAsciiValue(token, f, dst + f.offset + c * detail::datatypeSize(f.datatype)))
            failAt(path_, "data line ", aline_ + 1, ": '", detail::quote(token), "' is not a number (field ",
                   detail::quote(f.name), ")");
        }
    }
  }
  read_ += n;
  return n;
}

// ---------------------------------------------------------------------------------------------

PcdStreamWriter::PcdStreamWriter(const std::string& path, const std::vector<pcl::PCLPointField>& fields,
                                 std::uint32_t point_step, const std::array<double, 7>& viewpoint)
  : out_(path), fields_(fields), point_step_(point_step), viewpoint_(viewpoint)
{
  packed_step_ = packedFields(fields_, packed_fields_);
  layout_packed_ = packed_fields_.size() == fields_.size();
  for (std::size_t k = 0; layout_packed_ && k < fields_.size(); ++k)
    layout_packed_ = fields_[k].offset == packed_fields_[k].offset && fields_[k].name == packed_fields_[k].name;
  file_.open(out_.tempPath(), std::ios::binary | std::ios::trunc);
  if (!file_)
    throw FileError(path + ": cannot create it (" + std::strerror(errno) + ")");
  const std::string h = headerText(0);
  file_.write(h.data(), static_cast<std::streamsize>(h.size()));
}

PcdStreamWriter::~PcdStreamWriter() = default;

std::string PcdStreamWriter::headerText(std::uint64_t points) const
{
  // The counts take a fixed width so that commit() can rewrite them in place.
  return pcdHeader(packed_fields_, points, 1, viewpoint_, "binary", true);
}

void PcdStreamWriter::append(const std::uint8_t* records, std::size_t n)
{
  if (packed_step_ != point_step_ || !layout_packed_)
  {
    // Records with padding or '_' fields: packed before they are written.
    std::vector<std::int64_t> all(n);
    for (std::size_t i = 0; i < n; ++i)
      all[i] = static_cast<std::int64_t>(i);
    pack_buffer_.assign(n * packed_step_, 0);
    copyRecords(records, point_step_, fields_, all, pack_buffer_.data(), packed_step_, packed_fields_);
    records = pack_buffer_.data();
  }
  file_.write(reinterpret_cast<const char*>(records), static_cast<std::streamsize>(n * packed_step_));
  if (!file_)
    throw FileError(out_.targetPath() + ": write failed (disk full?)");
  written_ += n;
}

void PcdStreamWriter::commit()
{
  const std::string h = headerText(written_);
  file_.seekp(0);
  file_.write(h.data(), static_cast<std::streamsize>(h.size()));
  file_.flush();
  if (!file_)
    throw FileError(out_.targetPath() + ": write failed (disk full?)");
  file_.close();
  out_.commit();
}

// ---------------------------------------------------------------------------------------------

XyzAccess::XyzAccess(const PcdHeader& header)
{
  const char* names[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a)
  {
    const int f = header.fieldIndex(names[a]);
    if (f < 0)
      throw FormatError(std::string("the cloud has no field '") + names[a] + "'");
    offset[a] = header.fields[static_cast<std::size_t>(f)].offset;
    datatype[a] = header.fields[static_cast<std::size_t>(f)].datatype;
  }
}

void XyzAccess::get(const std::uint8_t* record, double& x, double& y, double& z) const
{
  if (datatype[0] == pcl::PCLPointField::FLOAT32 && datatype[1] == pcl::PCLPointField::FLOAT32 &&
      datatype[2] == pcl::PCLPointField::FLOAT32)
  {
    float v[3];
    std::memcpy(&v[0], record + offset[0], 4);
    std::memcpy(&v[1], record + offset[1], 4);
    std::memcpy(&v[2], record + offset[2], 4);
    x = v[0];
    y = v[1];
    z = v[2];
    return;
  }
  x = detail::loadValue(datatype[0], record + offset[0]);
  y = detail::loadValue(datatype[1], record + offset[1]);
  z = detail::loadValue(datatype[2], record + offset[2]);
}

void XyzAccess::set(std::uint8_t* record, double x, double y, double z) const
{
  detail::storeValue(x, datatype[0], record + offset[0]);
  detail::storeValue(y, datatype[1], record + offset[1]);
  detail::storeValue(z, datatype[2], record + offset[2]);
}

}  // namespace io
}  // namespace pcl_ecs
