// PCD, LAS and LAZ files as records, a chunk at a time (record_stream.h).
#include <pcl_ecs/io/record_stream.h>

#include <algorithm>
#include <array>
#include <filesystem>

namespace pcl_ecs
{
namespace io
{

bool isRecordFormat(const std::string& path)
{
  const Format f = formatFromPath(path);
  return f == Format::Pcd || f == Format::Las || f == Format::Laz;
}

namespace
{
bool sameLayout(const PcdHeader& a, const PcdHeader& b)
{
  if (a.point_step != b.point_step || a.fields.size() != b.fields.size())
    return false;
  for (std::size_t k = 0; k < a.fields.size(); ++k)
  {
    const auto& f = a.fields[k];
    const auto& g = b.fields[k];
    if (f.name != g.name || f.datatype != g.datatype || f.count != g.count || f.offset != g.offset)
      return false;
  }
  return true;
}

std::string fieldList(const PcdHeader& h)
{
  std::string s;
  for (const auto& f : h.fields)
    s += (s.empty() ? "" : " ") + f.name;
  return s;
}
}  // namespace

RecordSource::RecordSource(const std::string& path) : RecordSource(std::vector<std::string>{path}) {}

RecordSource::RecordSource(const std::vector<std::string>& paths) : paths_(paths)
{
  if (paths_.empty())
    throw FileError("no input files");
  std::error_code ec;
  for (const std::string& p : paths_)
    if (paths_.size() > 1 && !std::filesystem::is_regular_file(p, ec))
      throw FileError(p + ": not a regular file (files read as one cloud are each opened twice)");
  PcdHeader first;
  // The coarsest scale of the LAS files (a finer one would claim a precision some points do not
  // have); RecordSink fits the offset to the whole box.
  std::array<double, 3> coarsest{{0.0, 0.0, 0.0}};
  for (std::size_t k = paths_.size(); k-- > 0;)  // the first file stays open, to be read first
  {
    open(k);
    if (las_)
      for (int a = 0; a < 3; ++a)
        coarsest[a] = std::max(coarsest[a], las_->info().scale[a]);
    if (k + 1 < paths_.size() && !sameLayout(header_, first))
      throw FormatError(paths_[k + 1] + ": its points have other fields than " + paths_[k] + "'s (" +
                        fieldList(first) + " against " + fieldList(header_) +
                        "): files read as one cloud must share their point format");
    first = header_;
    counts_.insert(counts_.begin(), header_.points);
  }
  if (las_)
  {
    las_info_ = std::make_unique<LasInfo>(las_->info());  // the first file's header
    las_info_->scale = coarsest;
  }
  std::uint64_t total = 0;
  for (const std::uint64_t c : counts_)
    total += c;
  header_.points = total;
  header_.width = total;
  header_.height = 1;
}

void RecordSource::open(std::size_t k)
{
  const std::string& path = paths_[k];
  pcd_.reset();
  las_.reset();
  const Format f = formatFromPath(path);
  if (f == Format::Pcd)
  {
    pcd_ = std::make_unique<PcdStreamReader>(path);
    header_ = pcd_->header();
  }
  else if (f == Format::Las || f == Format::Laz)
  {
    las_ = std::make_unique<LasStreamReader>(path);
    header_ = PcdHeader();
    header_.fields = las_->fields();
    header_.point_step = las_->pointStep();
    header_.points = las_->points();
    header_.width = header_.points;
    header_.height = 1;
  }
  else
    throw FileError(path + ": chunked reading takes .pcd, .las and .laz files");
  current_ = k;
}

RecordSource::~RecordSource() = default;

std::size_t RecordSource::read(std::size_t max_points, std::vector<std::uint8_t>& records)
{
  for (;;)
  {
    const std::size_t n = pcd_ ? pcd_->read(max_points, records) : las_->read(max_points, records);
    if (n > 0 || current_ + 1 >= paths_.size())
      return n;
    const PcdHeader whole = header_;
    open(current_ + 1);
    header_.points = whole.points;  // the cloud's, not this file's
    header_.width = whole.width;
  }
}

bool RecordSource::recordsInFile(std::uint64_t& offset) const
{
  if (!pcd_ || paths_.size() != 1 || header_.data != PcdData::Binary)
    return false;
  offset = pcd_->dataOffset();
  return pcd_->seekable();
}

const LasInfo* RecordSource::las() const { return las_info_.get(); }

std::vector<std::string> recordInputs(const std::vector<std::string>& args)
{
  namespace fs = std::filesystem;
  std::vector<std::string> out;
  for (const std::string& a : args)
  {
    std::error_code ec;
    if (!fs::is_directory(a, ec))
    {
      out.push_back(a);
      continue;
    }
    std::vector<std::string> files;
    for (const auto& e : fs::directory_iterator(a, ec))
      if (e.is_regular_file(ec) && isRecordFormat(e.path().string()))
        files.push_back(e.path().string());
    if (files.empty())
      throw FileError(a + ": a directory without .pcd, .las or .laz files");
    std::sort(files.begin(), files.end());
    out.insert(out.end(), files.begin(), files.end());
  }
  return out;
}

RecordSink::RecordSink(const std::string& path, const PcdHeader& layout, const LasInfo* las,
                       const std::array<double, 3>& lo, const std::array<double, 3>& hi)
{
  const Format f = formatFromPath(path);
  if (f == Format::Pcd)
    pcd_ = std::make_unique<PcdStreamWriter>(path, layout.fields, layout.point_step, layout.viewpoint);
  else if (f == Format::Las || f == Format::Laz)
  {
    LasInfo info = las ? *las : defaultLasInfo(layout.fields, lo, hi);
    fitLasFrame(info, lo, hi);
    las_ = std::make_unique<LasStreamWriter>(path, layout.fields, layout.point_step, info, f == Format::Laz);
  }
  else
    throw FileError(path + ": chunked writing makes .pcd, .las and .laz files");
}

RecordSink::~RecordSink() = default;

void RecordSink::append(const std::uint8_t* records, std::size_t n)
{
  if (pcd_)
    pcd_->append(records, n);
  else
    las_->append(records, n);
}

std::uint64_t RecordSink::written() const { return pcd_ ? pcd_->written() : las_->written(); }

void RecordSink::commit()
{
  if (pcd_)
    pcd_->commit();
  else
    las_->commit();
}

}  // namespace io
}  // namespace pcl_ecs
