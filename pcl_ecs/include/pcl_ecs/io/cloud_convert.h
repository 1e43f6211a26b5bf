// cloud_convert.h — between a pcl::PCLPointCloud2 of any field types and the clouds the method
// runs on. PCL's own fromPCLPointCloud2 matches a field only when its type is the point type's
// (a double `x`, an int16 intensity or a U8 label is left at zero); these convert every numeric
// type, keep coordinates precise by subtracting a shift in double before they become float, and
// lay records out without padding, as every PCD and PLY reader expects.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <pcl/PCLPointCloud2.h>
#include <pcl/point_cloud.h>
#include <pcl/common/io.h>

namespace pcl_ecs
{
namespace io
{

/** \brief Index of the field called `name` in `fields`, or -1. */
int fieldIndex(const std::vector<pcl::PCLPointField>& fields, const std::string& name);

/** \brief The fields worth keeping of a layout, packed one after another in offset order: no
 * padding bytes, no '_' fields, none of unknown type or of count 0. Returns the packed record
 * size; `packed[k]` keeps its name, type and count, with its new offset. */
std::uint32_t packedFields(const std::vector<pcl::PCLPointField>& fields, std::vector<pcl::PCLPointField>& packed);

/** \brief `cloud` with packed records (packedFields); a cloud already packed is copied as is. */
pcl::PCLPointCloud2 packedCloud(const pcl::PCLPointCloud2& cloud);

/** \brief Append a field of `count` values of `datatype` at the end of `cloud`'s records (the
 * point step grows by its size; the data is not touched). Returns the field's offset. */
std::uint32_t appendField(pcl::PCLPointCloud2& cloud, const std::string& name, std::uint8_t datatype,
                          std::uint32_t count = 1);

/** \brief Copy the record of each point `from[i]` of `src` (a layout `src_fields`) into record i of
 * `dst` (a layout `dst_fields`, `dst_step` bytes each), field by field by name. */
void copyRecords(const std::uint8_t* src, std::uint32_t src_step, const std::vector<pcl::PCLPointField>& src_fields,
                 const std::vector<std::int64_t>& from, std::uint8_t* dst, std::uint32_t dst_step,
                 const std::vector<pcl::PCLPointField>& dst_fields);

/** \brief The bounding box of the finite x, y, z of `cloud`, in double whatever their type;
 * returns the number of finite points (0 when none or a coordinate field is missing: `lo`, `hi`
 * are then left as they were). */
std::size_t boundingBox(const pcl::PCLPointCloud2& cloud, Eigen::Vector3d& lo, Eigen::Vector3d& hi);

/** \brief The centre of boundingBox() (zero when there is none): subtracted before coordinates
 * become float, it keeps them as precise as the cloud's extent allows, whatever their magnitude
 * (UTM). */
Eigen::Vector3d boundingBoxCentre(const pcl::PCLPointCloud2& cloud);

/** \brief Write the values of `cloud`'s fields into `n` records of another layout (`dst_fields`,
 * `dst_step` bytes each, at `dst`), converting between numeric types. Fields are matched by name;
 * `rgb` and `rgba` stand for each other and their four bytes are copied as they are; x, y and z
 * have `shift` subtracted (in double) first. Destination fields the cloud lacks keep their bytes. */
void convertRecords(const pcl::PCLPointCloud2& cloud, const std::vector<pcl::PCLPointField>& dst_fields,
                    std::size_t dst_step, std::uint8_t* dst, const Eigen::Vector3d& shift);

/** \brief `cloud` as a pcl::PointCloud<PointT>, every numeric field type converted (see
 * convertRecords); coordinates are `cloud`'s minus `shift`. Fields PointT has and `cloud` lacks
 * keep PointT's defaults. */
template <typename PointT>
void fromCloud(const pcl::PCLPointCloud2& cloud, pcl::PointCloud<PointT>& out,
               const Eigen::Vector3d& shift = Eigen::Vector3d::Zero())
{
  const std::vector<pcl::PCLPointField> fields = pcl::getFields<PointT>();
  out.clear();
  out.resize(static_cast<std::size_t>(cloud.width) * cloud.height);
  out.width = cloud.width;
  out.height = cloud.height;
  out.is_dense = cloud.is_dense;
  convertRecords(cloud, fields, sizeof(PointT), reinterpret_cast<std::uint8_t*>(out.data()), shift);
}

}  // namespace io
}  // namespace pcl_ecs
