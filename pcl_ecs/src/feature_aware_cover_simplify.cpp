// Explicit instantiations of FeatureAwareCoverSimplify for the point types we ship. Users with
// their own point types define PCL_ECS_NO_PRECOMPILE (or PCL_NO_PRECOMPILE) before including the
// header, which then brings in the template definitions.
#include <pcl_ecs/feature_aware_cover_simplify.h>
#include <pcl_ecs/impl/feature_aware_cover_simplify.hpp>

template class pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZ>;
template class pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZI>;
template class pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZL>;
template class pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZRGB>;
template class pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZRGBA>;
template class pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZRGBL>;
template class pcl_ecs::FeatureAwareCoverSimplify<pcl::PointNormal>;
template class pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZRGBNormal>;
template class pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZINormal>;
