#include "io_detail.h"

#include <pcl_ecs/io/las_io.h>
#include <pcl_ecs/io/pcd_stream.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

namespace pcl_ecs
{
namespace io
{

namespace fs = std::filesystem;

namespace
{
std::string lowerExtension(const std::string& path)
{
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}
}  // namespace

Format formatFromPath(const std::string& path)
{
  // One table for every tool: extension -> format.
  static const std::pair<const char*, Format> table[] = {
      {".pcd", Format::Pcd}, {".ply", Format::Ply}, {".xyz", Format::Xyz},
      {".txt", Format::Xyz}, {".pts", Format::Xyz}, {".asc", Format::Xyz},
      {".las", Format::Las}, {".laz", Format::Laz}};
  const std::string ext = lowerExtension(path);
  for (const auto& [e, f] : table)
    if (ext == e)
      return f;
  return Format::Unknown;
}

const char* formatName(Format format)
{
  switch (format)
  {
  case Format::Pcd: return "PCD";
  case Format::Ply: return "PLY";
  case Format::Xyz: return "XYZ";
  case Format::Las: return "LAS";
  case Format::Laz: return "LAZ";
  default: return "unknown";
  }
}

CloudProbe probeCloud(const std::string& path)
{
  std::error_code ec;
  const Format format = formatFromPath(path);
  if (!fs::is_regular_file(path, ec) || format == Format::Xyz || format == Format::Unknown)
    return {};
  const std::uint64_t size = fs::file_size(path, ec);
  if (ec)
    return {};
  try
  {
    if (format == Format::Pcd)
    {
      const PcdStreamReader reader(path);
      return {reader.header().points, reader.header().point_step};
    }
    std::ifstream in(path, std::ios::binary);
    if (!in)
      return {};
    if (format == Format::Las || format == Format::Laz)
    {
      std::string head(375, '\0');
      in.read(&head[0], static_cast<std::streamsize>(head.size()));
      head.resize(static_cast<std::size_t>(in.gcount()));
      CloudProbe p;
      probeLas(head, size, p.points, p.point_step);
      return p;
    }
    return probePly(in, size);
  }
  catch (const FormatError& e)
  {
    const std::string what = e.what();
    throw FormatError(what.rfind(path + ":", 0) == 0 ? what : path + ": " + what);
  }
}

void readCloud(const std::string& path, pcl::PCLPointCloud2& cloud)
{
  readCloud(path, cloud, nullptr);
}

bool readCloud(const std::string& path, pcl::PCLPointCloud2& cloud, LasInfo* las)
{
  const Format format = formatFromPath(path);
  if (format == Format::Unknown)
    throw FileError(path + ": unknown extension (expected .pcd, .ply, .las, .laz, .xyz, .txt, .pts or .asc)");
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (ec || !fs::exists(status))
    throw FileError(path + ": no such file");
  if (fs::is_directory(status))
    throw FileError(path + ": is a directory, not a point cloud file");
  if (format == Format::Ply || format == Format::Las || format == Format::Laz)
    probeCloud(path);  // a header that promises more than the file holds: refused unread
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw FileError(path + ": cannot be opened for reading (" + std::strerror(errno) + ")");
  std::string bytes;
  try
  {
    bytes.assign((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }
  catch (const std::exception& e)
  {
    throw FileError(path + ": cannot be read (" + e.what() + ")");
  }
  if (in.bad())
    throw FileError(path + ": cannot be read (I/O error)");
  if (bytes.empty())
    throw FileError(path + ": the file is empty");
  try
  {
    switch (format)
    {
    case Format::Pcd: parsePcd(bytes, cloud); break;
    case Format::Ply: parsePly(bytes, cloud); break;
    case Format::Las:
    case Format::Laz: parseLas(bytes, cloud, las); return true;
    default: parseXyz(bytes, cloud); break;
    }
  }
  catch (const FormatError& e)
  {
    throw FormatError(path + ": " + e.what());
  }
  return false;
}

void writePly(std::ostream& out, const pcl::PCLPointCloud2& cloud, bool binary)
{
  struct Column
  {
    std::string name;
    const pcl::PCLPointField* field;
    std::uint8_t out_type;
    int channel;  // -1: plain value; 0..3: byte of a packed colour (r, g, b, a)
    std::uint32_t at = 0;  // byte of the value within the field (fields of count > 1)
  };
  std::vector<Column> cols;
  auto plyTypeName = [](std::uint8_t t) {
    switch (t)
    {
    case pcl::PCLPointField::INT8: return "char";
    case pcl::PCLPointField::UINT8: return "uchar";
    case pcl::PCLPointField::INT16: return "short";
    case pcl::PCLPointField::UINT16: return "ushort";
    case pcl::PCLPointField::INT32: return "int";
    case pcl::PCLPointField::UINT32: return "uint";
    case pcl::PCLPointField::FLOAT64: return "double";
    default: return "float";
    }
  };
  for (const auto& f : cloud.fields)
  {
    if (f.count == 0 || f.name == "_" || detail::datatypeSize(f.datatype) == 0)
      continue;
    if (f.name == "rgb" || f.name == "rgba")
    {
      const char* names[] = {"red", "green", "blue", "alpha"};
      for (int c = 0; c < (f.name == "rgba" ? 4 : 3); ++c)
        cols.push_back({names[c], &f, pcl::PCLPointField::UINT8, c, 0});
      continue;
    }
    static const std::pair<const char*, const char*> standard[] = {
        {"x", "x"}, {"y", "y"}, {"z", "z"}, {"normal_x", "nx"}, {"normal_y", "ny"}, {"normal_z", "nz"},
        {"intensity", "intensity"}, {"label", "label"}, {"curvature", "curvature"}};
    std::string name;
    for (const auto& [from, to] : standard)
      if (f.name == from)
        name = to;
    if (name.empty())
      name = "scalar_" + f.name;
    // PLY has no 64-bit integers: they are written as double (exact up to 2^53).
    const bool wide = f.datatype == pcl::PCLPointField::INT64 || f.datatype == pcl::PCLPointField::UINT64;
    for (std::uint32_t c = 0; c < f.count; ++c)
      cols.push_back({f.count == 1 ? name : name + "_" + std::to_string(c), &f,
                      wide ? static_cast<std::uint8_t>(pcl::PCLPointField::FLOAT64) : f.datatype, -1,
                      static_cast<std::uint32_t>(c * detail::datatypeSize(f.datatype))});
  }
  const std::size_t n = static_cast<std::size_t>(cloud.width) * cloud.height;
  out << "ply\nformat " << (binary ? "binary_little_endian" : "ascii") << " 1.0\n"
      << "comment written by pcl_ecs\nelement vertex " << n << "\n";
  for (const auto& c : cols)
    out << "property " << plyTypeName(c.out_type) << " " << c.name << "\n";
  out << "end_header\n";
  out << std::setprecision(9);
  std::uint8_t buf[8];
  for (std::size_t i = 0; i < n; ++i)
  {
    const std::uint8_t* src = cloud.data.data() + i * cloud.point_step;
    for (std::size_t k = 0; k < cols.size(); ++k)
    {
      const Column& c = cols[k];
      double v = 0.0;
      if (c.channel >= 0)
      {
        std::uint32_t packed = 0;
        std::memcpy(&packed, src + c.field->offset, 4);
        const int shift[] = {16, 8, 0, 24};
        v = static_cast<double>((packed >> shift[c.channel]) & 0xFFu);
      }
      else
        v = detail::loadValue(c.field->datatype, src + c.field->offset + c.at);
      if (binary)
      {
        detail::storeValue(v, c.out_type, buf);  // little-endian hosts only (x86, arm64)
        out.write(reinterpret_cast<const char*>(buf), static_cast<std::streamsize>(detail::datatypeSize(c.out_type)));
      }
      else
      {
        if (c.out_type == pcl::PCLPointField::FLOAT64)
          out << std::setprecision(17) << v << std::setprecision(9);
        else
          out << v;
        out << (k + 1 == cols.size() ? '\n' : ' ');
      }
    }
  }
}

void writeCloud(const std::string& path, Format format, const pcl::PCLPointCloud2& cloud,
                Encoding encoding, const LasInfo* las)
{
  if (format == Format::Las || format == Format::Laz)
  {
    const std::string bytes = lasBytes(cloud, las, format == Format::Laz);
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    if (!out)
      throw FileError(path + ": cannot be created (" + std::strerror(errno) + ")");
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out)
      throw FileError(path + ": write error (" + std::strerror(errno) + ")");
    return;
  }
  if (format == Format::Ply)
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    if (!out)
      throw FileError(path + ": cannot be created (" + std::strerror(errno) + ")");
    writePly(out, cloud, encoding != Encoding::Ascii);
    out.close();
    if (!out)
      throw FileError(path + ": write error (" + std::strerror(errno) + ")");
    return;
  }
  if (format != Format::Pcd)
    throw FileError(path + ": can only write .pcd, .ply, .las or .laz");
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out)
    throw FileError(path + ": cannot be created (" + std::strerror(errno) + ")");
  try
  {
    writePcd(out, cloud, encoding);
  }
  catch (const FileError& e)
  {
    throw FileError(path + ": " + e.what());
  }
  out.close();
  if (!out)
    throw FileError(path + ": write error (" + std::strerror(errno) + ")");
}

namespace
{
std::atomic<unsigned> temp_counter{0};

// The temporary files alive in this process, for the signal handler: fixed storage, no allocation.
constexpr int kMaxTemporaries = 64;
char temporaries[kMaxTemporaries][4096];
std::atomic<bool> temporary_used[kMaxTemporaries];

int registerTemporary(const std::string& path)
{
  if (path.size() >= sizeof temporaries[0])
    return -1;
  for (int k = 0; k < kMaxTemporaries; ++k)
  {
    bool expected = false;
    if (temporary_used[k].load() || !temporary_used[k].compare_exchange_strong(expected, true))
      continue;
    std::memcpy(temporaries[k], path.c_str(), path.size() + 1);
    return k;
  }
  return -1;
}

void unregisterTemporary(int slot)
{
  if (slot >= 0)
    temporary_used[slot].store(false);
}

extern "C" void removeTemporariesAndDie(int sig)
{
  for (int k = 0; k < kMaxTemporaries; ++k)
    if (temporary_used[k].load())
      ::unlink(temporaries[k]);
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

/// fsync a file by name: its data is on disk (or the error is known) before it is renamed.
std::string syncFile(const std::string& path)
{
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0)
    return std::strerror(errno);
  std::string why;
  if (::fsync(fd) != 0)
    why = std::strerror(errno);
  if (::close(fd) != 0 && why.empty())
    why = std::strerror(errno);
  return why;
}
}  // namespace

void removeTemporariesOnSignal()
{
  struct sigaction sa = {};
  sa.sa_handler = removeTemporariesAndDie;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESETHAND;
  for (const int sig : {SIGINT, SIGTERM, SIGHUP, SIGPIPE})
    ::sigaction(sig, &sa, nullptr);
}

AtomicOutput::AtomicOutput(const std::string& target) : target_(target)
{
  const fs::path t(target);
  const fs::path dir = t.has_parent_path() ? t.parent_path() : fs::path(".");
  temp_ = (dir / ("." + t.filename().string() + ".tmp-" + std::to_string(::getpid()) + "-" +
                  std::to_string(temp_counter++)))
              .string();
  slot_ = registerTemporary(temp_);
}

AtomicOutput::~AtomicOutput()
{
  if (!committed_)
  {
    std::error_code ec;
    fs::remove(temp_, ec);
  }
  unregisterTemporary(slot_);
}

void AtomicOutput::commit()
{
  const std::string why = syncFile(temp_);
  if (!why.empty())
    throw FileError(target_ + ": cannot be written (" + why + ")");
  std::error_code ec;
  fs::rename(temp_, target_, ec);
  if (ec)
    throw FileError(target_ + ": cannot be put in place (" + ec.message() + ")");
  committed_ = true;
  unregisterTemporary(slot_);
  slot_ = -1;
}

std::string checkWritable(const std::string& path)
{
  const fs::path p(path);
  std::error_code ec;
  if (fs::is_directory(p, ec))
    return "is a directory";
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  if (!fs::is_directory(dir, ec))
    return "directory " + dir.string() + " does not exist";
  if (::access(dir.c_str(), W_OK) != 0)
    return "directory " + dir.string() + " is not writable";
  if (fs::exists(p, ec) && ::access(p.c_str(), W_OK) != 0)
    return "exists and is not writable";
  return {};
}

}  // namespace io
}  // namespace pcl_ecs
