// LAS / LAZ files a chunk at a time (las_io.h: LasStreamReader, LasStreamWriter), built from the
// same header, VLR and record code as the whole-file functions (las_detail.h).
#include "io_detail.h"
#include "las_detail.h"

#include <pcl_ecs/io/cloud_io.h>
#include <pcl_ecs/io/las_io.h>
#include <pcl_ecs/version.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>

namespace pcl_ecs
{
namespace io
{

namespace
{
namespace fs = std::filesystem;
using detail::fail;

/// The VLR and EVLR bytes a chunked reader keeps at most.
constexpr std::uint64_t kMaxStreamVlrBytes = 256ull << 20;

std::string errnoText() { return std::strerror(errno); }
}  // namespace

struct LasStreamReader::Impl
{
  std::string path;
  std::ifstream in;
  std::uint64_t file_size = 0;
  las::Layout layout;
  std::uint64_t read = 0;
  std::vector<std::uint8_t> raw;
#ifdef PCL_ECS_HAVE_LAZ
  std::unique_ptr<EcsLazReader, void (*)(EcsLazReader*)> laz{nullptr, ecs_laz_reader_close};
#endif

  std::string readAt(std::uint64_t offset, std::size_t n)
  {
    std::string s;
    if (offset >= file_size)
      return s;
    s.resize(static_cast<std::size_t>(std::min<std::uint64_t>(n, file_size - offset)));
    in.clear();
    in.seekg(static_cast<std::streamoff>(offset));
    in.read(&s[0], static_cast<std::streamsize>(s.size()));
    s.resize(static_cast<std::size_t>(std::max<std::streamsize>(0, in.gcount())));
    return s;
  }
};

LasStreamReader::LasStreamReader(const std::string& path) : impl_(std::make_unique<Impl>())
{
  Impl& m = *impl_;
  m.path = path;
  std::error_code ec;
  if (!fs::is_regular_file(path, ec))
    throw FileError(path + (fs::exists(path, ec) ? ": is not a regular file (a LAS file is read with seeks)"
                                                 : ": does not exist"));
  m.in.open(path, std::ios::binary);
  if (!m.in)
    throw FileError(path + ": cannot open it (" + errnoText() + ")");
  m.file_size = fs::file_size(path, ec);
  if (ec)
    throw FileError(path + ": cannot read its size (" + ec.message() + ")");
  try
  {
    const std::string head = m.readAt(0, 375);
    std::uint64_t asked = 0;
    m.layout = las::readLayout(head, m.file_size, [&](std::uint64_t offset, std::size_t n) {
      asked += n;
      if (asked > kMaxStreamVlrBytes)
        fail("its VLRs and EVLRs hold more than ", kMaxStreamVlrBytes >> 20, " MiB, more than this reader keeps");
      return m.readAt(offset, n);
    });
    fields_ = las::cloudFields(m.layout, step_);
    if (m.layout.compressed && m.layout.points > 0)  // no points: nothing to decompress
    {
#ifdef PCL_ECS_HAVE_LAZ
      char err[512] = {};
      EcsLazReader* reader = nullptr;
      if (ecs_laz_reader_open(path.c_str(), m.layout.point_offset, m.layout.laszip.data(), m.layout.laszip.size(),
                              m.layout.points, m.layout.record_length, &reader, err, sizeof err) != 0)
        fail(err);
      m.laz.reset(reader);
#else
      fail("LAZ is not supported by this build of pcl_ecs (built with -DPCL_ECS_WITH_LAZ=OFF: see docs/LAS.md)");
#endif
    }
  }
  catch (const FormatError& e)
  {
    throw FormatError(path + ": " + e.what());
  }
}

LasStreamReader::~LasStreamReader() = default;

std::uint64_t LasStreamReader::points() const { return impl_->layout.points; }
const LasInfo& LasStreamReader::info() const { return impl_->layout.info; }
std::uint64_t LasStreamReader::remaining() const { return impl_->layout.points - impl_->read; }

std::size_t LasStreamReader::read(std::size_t max_points, std::vector<std::uint8_t>& records)
{
  Impl& m = *impl_;
  const las::Layout& l = m.layout;
  const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(max_points, l.points - m.read));
  records.resize(n * step_);
  if (n == 0)
    return 0;
  m.raw.resize(n * l.record_length);
  if (l.compressed)
  {
#ifdef PCL_ECS_HAVE_LAZ
    char err[512] = {};
    if (ecs_laz_reader_read(m.laz.get(), m.raw.data(), n, err, sizeof err) != 0)
      throw FormatError(m.path + ": " + err);
#endif
  }
  else
  {
    m.in.clear();
    m.in.seekg(static_cast<std::streamoff>(l.point_offset + m.read * l.record_length));
    m.in.read(reinterpret_cast<char*>(m.raw.data()), static_cast<std::streamsize>(m.raw.size()));
    if (static_cast<std::size_t>(m.in.gcount()) != m.raw.size())
      throw FormatError(m.path + ": truncated: the data ends in point " +
                        std::to_string(m.read + static_cast<std::uint64_t>(m.in.gcount()) / l.record_length));
  }
  las::decodeRecords(l, m.raw.data(), n, fields_, step_, records.data());
  m.read += n;
  return n;
}

// ---------------------------------------------------------------------------------------------

struct LasStreamWriter::Impl
{
  AtomicOutput out;
  LasInfo info;
  bool compressed;
  las::Encoder enc;
  std::vector<std::uint8_t> laszip;
  std::fstream file;  // uncompressed: the records go here
  std::vector<std::uint8_t> buf;
#ifdef PCL_ECS_HAVE_LAZ
  std::unique_ptr<EcsLazWriter, void (*)(EcsLazWriter*)> laz{nullptr, ecs_laz_writer_free};
#endif

  Impl(const std::string& path, const std::vector<pcl::PCLPointField>& fields, std::uint32_t step,
       const LasInfo& like, bool z)
    : out(path), info(like), compressed(z), enc(fields, step, info)
  {
  }
  [[noreturn]] void writeFailed(const std::string& why) const
  {
    throw FileError(out.targetPath() + ": write error (" + why + ")");
  }
};

LasStreamWriter::LasStreamWriter(const std::string& path, const std::vector<pcl::PCLPointField>& fields,
                                 std::uint32_t point_step, const LasInfo& info, bool compressed)
{
#ifndef PCL_ECS_HAVE_LAZ
  if (compressed)
    throw FormatError(path + ": LAZ is not supported by this build of pcl_ecs (built with -DPCL_ECS_WITH_LAZ=OFF: "
                             "see docs/LAS.md)");
#endif
  LasInfo like = info;
  like.generating_software = std::string("pcl_ecs ") + PCL_ECS_VERSION_STRING;
  impl_ = std::make_unique<Impl>(path, fields, point_step, like, compressed);
  Impl& m = *impl_;
  if (compressed)
    m.laszip = las::laszipPayload(m.info);
  std::vector<LasVlr> evlrs;
  const std::string head = las::headerBytes(m.info, m.enc, m.laszip, evlrs);
  {
    std::ofstream f(m.out.tempPath(), std::ios::binary | std::ios::trunc);
    if (!f)
      throw FileError(path + ": cannot create it (" + errnoText() + ")");
    f.write(head.data(), static_cast<std::streamsize>(head.size()));
    f.flush();
    if (!f)
      m.writeFailed(errnoText());
  }
  if (compressed)
  {
#ifdef PCL_ECS_HAVE_LAZ
    char err[512] = {};
    EcsLazWriter* writer = nullptr;
    if (ecs_laz_writer_open(m.out.tempPath().c_str(), m.laszip.data(), m.laszip.size(), &writer, err, sizeof err) != 0)
      m.writeFailed(err);
    m.laz.reset(writer);
#endif
  }
  else
  {
    m.file.open(m.out.tempPath(), std::ios::binary | std::ios::in | std::ios::out);
    m.file.seekp(0, std::ios::end);
    if (!m.file)
      throw FileError(path + ": cannot open it (" + errnoText() + ")");
  }
}

LasStreamWriter::~LasStreamWriter() = default;

std::uint64_t LasStreamWriter::written() const { return impl_->enc.count(); }

void LasStreamWriter::append(const std::uint8_t* records, std::size_t n)
{
  Impl& m = *impl_;
  m.buf.clear();
  m.enc.encode(records, n, m.enc.count(), m.buf);
  if (m.compressed)
  {
#ifdef PCL_ECS_HAVE_LAZ
    char err[512] = {};
    if (ecs_laz_writer_write(m.laz.get(), m.buf.data(), n, m.info.record_length, err, sizeof err) != 0)
      m.writeFailed(err);
#endif
  }
  else
  {
    m.file.write(reinterpret_cast<const char*>(m.buf.data()), static_cast<std::streamsize>(m.buf.size()));
    if (!m.file)
      m.writeFailed(errnoText());
  }
}

void LasStreamWriter::commit()
{
  Impl& m = *impl_;
  if (m.compressed)
  {
#ifdef PCL_ECS_HAVE_LAZ
    char err[512] = {};
    // finish frees the writer, whatever it returns
    if (ecs_laz_writer_finish(m.laz.release(), err, sizeof err) != 0)
      m.writeFailed(err);
    m.file.open(m.out.tempPath(), std::ios::binary | std::ios::in | std::ios::out);
#endif
  }
  m.file.seekp(0, std::ios::end);
  const auto size = static_cast<std::uint64_t>(m.file.tellp());
  std::vector<LasVlr> evlrs;
  std::string head = las::headerBytes(m.info, m.enc, m.laszip, evlrs);
  const std::string tail = las::evlrBytes(evlrs, size, m.info, head);
  m.file.write(tail.data(), static_cast<std::streamsize>(tail.size()));
  m.file.seekp(0);
  m.file.write(head.data(), static_cast<std::streamsize>(head.size()));
  m.file.flush();
  if (!m.file)
    m.writeFailed(errnoText());
  m.file.close();
  m.out.commit();
}

}  // namespace io
}  // namespace pcl_ecs
