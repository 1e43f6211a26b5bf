// PCD, LAS and LAZ files as records, a chunk at a time (record_stream.h).
#include <pcl_ecs/io/record_stream.h>

namespace pcl_ecs
{
namespace io
{

bool isRecordFormat(const std::string& path)
{
  const Format f = formatFromPath(path);
  return f == Format::Pcd || f == Format::Las || f == Format::Laz;
}

RecordSource::RecordSource(const std::string& path)
{
  const Format f = formatFromPath(path);
  if (f == Format::Pcd)
  {
    pcd_ = std::make_unique<PcdStreamReader>(path);
    header_ = pcd_->header();
  }
  else if (f == Format::Las || f == Format::Laz)
  {
    las_ = std::make_unique<LasStreamReader>(path);
    header_.fields = las_->fields();
    header_.point_step = las_->pointStep();
    header_.points = las_->points();
    header_.width = header_.points;
    header_.height = 1;
  }
  else
    throw FileError(path + ": chunked reading takes .pcd, .las and .laz files");
}

RecordSource::~RecordSource() = default;

std::size_t RecordSource::read(std::size_t max_points, std::vector<std::uint8_t>& records)
{
  return pcd_ ? pcd_->read(max_points, records) : las_->read(max_points, records);
}

bool RecordSource::recordsInFile(std::uint64_t& offset) const
{
  if (!pcd_ || header_.data != PcdData::Binary)
    return false;
  offset = pcd_->dataOffset();
  return pcd_->seekable();
}

const LasInfo* RecordSource::las() const { return las_ ? &las_->info() : nullptr; }

RecordSink::RecordSink(const std::string& path, const PcdHeader& layout, const LasInfo* las,
                       const std::array<double, 3>& lo, const std::array<double, 3>& hi)
{
  const Format f = formatFromPath(path);
  if (f == Format::Pcd)
    pcd_ = std::make_unique<PcdStreamWriter>(path, layout.fields, layout.point_step, layout.viewpoint);
  else if (f == Format::Las || f == Format::Laz)
    las_ = std::make_unique<LasStreamWriter>(path, layout.fields, layout.point_step,
                                             las ? *las : defaultLasInfo(layout.fields, lo, hi), f == Format::Laz);
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
