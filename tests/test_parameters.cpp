#include <pcl_ecs/parameters.h>

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

using pcl_ecs::Parameters;

TEST(Parameters, DefaultsAreValidAndDocumented)
{
  const Parameters p;
  EXPECT_EQ(pcl_ecs::validate(p), "");
  EXPECT_DOUBLE_EQ(p.error_threshold, 1e-3);
  EXPECT_DOUBLE_EQ(p.feature_factor, 6.0);
  EXPECT_EQ(p.k_neighbors, 16);
  EXPECT_EQ(p.error_form, pcl_ecs::ErrorForm::Normalized);
  EXPECT_TRUE(p.adaptive);
  EXPECT_DOUBLE_EQ(p.adaptive_factor, 2.0);
  EXPECT_DOUBLE_EQ(p.radius_cap_factor, 5.0);
  EXPECT_EQ(p.seed, 42u);
  EXPECT_FALSE(p.use_input_normals);
  EXPECT_EQ(p.threads, 0);
  EXPECT_EQ(p.target_size, 0u);
  EXPECT_DOUBLE_EQ(p.max_gap_factor, 1.0);
  EXPECT_DOUBLE_EQ(p.target_gap_factor, 0.6);
  EXPECT_DOUBLE_EQ(p.max_representative_offset, 0.5);
  EXPECT_DOUBLE_EQ(p.representative_cutoff, 0.05);
  EXPECT_DOUBLE_EQ(p.max_roughness, 0.2);
  Parameters off = p;
  off.max_gap_factor = 0.0;  // off is valid
  off.target_gap_factor = 0.0;
  EXPECT_EQ(pcl_ecs::validate(off), "");
}

TEST(Parameters, EachBadValueIsRefusedByName)
{
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case
  {
    void (*set)(Parameters&);
    const char* name;
  };
  const Case cases[] = {
      {[](Parameters& p) { p.error_threshold = 0.0; }, "error_threshold"},
      {[](Parameters& p) { p.error_threshold = -1e-3; }, "error_threshold"},
      {[](Parameters& p) { p.error_threshold = 1.0; }, "error_threshold"},
      {[](Parameters& p) { p.error_threshold = std::numeric_limits<double>::quiet_NaN(); }, "error_threshold"},
      {[](Parameters& p) { p.feature_factor = 0.0; }, "feature_factor"},
      {[](Parameters& p) { p.feature_factor = -2.0; }, "feature_factor"},
      {[](Parameters& p) { p.feature_factor = std::numeric_limits<double>::infinity(); }, "feature_factor"},
      {[](Parameters& p) { p.k_neighbors = 4; }, "k_neighbors"},
      {[](Parameters& p) { p.k_neighbors = 201; }, "k_neighbors"},
      {[](Parameters& p) { p.adaptive_factor = 0.5; }, "adaptive_factor"},
      {[](Parameters& p) { p.adaptive_factor = std::numeric_limits<double>::quiet_NaN(); }, "adaptive_factor"},
      {[](Parameters& p) { p.radius_cap_factor = 0.0; }, "radius_cap_factor"},
      {[](Parameters& p) { p.radius_cap_factor = 1e6; }, "radius_cap_factor"},
      {[](Parameters& p) { p.max_gap_factor = -0.1; }, "max_gap_factor"},
      {[](Parameters& p) { p.max_gap_factor = 101.0; }, "max_gap_factor"},
      {[](Parameters& p) { p.max_gap_factor = std::numeric_limits<double>::quiet_NaN(); }, "max_gap_factor"},
      {[](Parameters& p) { p.target_gap_factor = -1.0; }, "target_gap_factor"},
      {[](Parameters& p) { p.representative_cutoff = 0.0; }, "representative_cutoff"},
      {[](Parameters& p) { p.representative_cutoff = 1.5; }, "representative_cutoff"},
      {[](Parameters& p) { p.representative_cutoff = std::numeric_limits<double>::quiet_NaN(); }, "representative_cutoff"},
      {[](Parameters& p) { p.max_roughness = 0.0; }, "max_roughness"},
      {[](Parameters& p) { p.max_roughness = 11.0; }, "max_roughness"},
      {[](Parameters& p) { p.max_roughness = std::numeric_limits<double>::infinity(); }, "max_roughness"},
      {[](Parameters& p) { p.target_gap_factor = 1e9; }, "target_gap_factor"},
      {[](Parameters& p) { p.threads = -1; }, "threads"},
  };
  (void)nan;
  (void)inf;
  for (const Case& c : cases)
  {
    Parameters p;
    c.set(p);
    const std::string why = pcl_ecs::validate(p);
    EXPECT_NE(why.find(c.name), std::string::npos) << why;
  }
}

TEST(Parameters, ErrorFormRoundTrips)
{
  pcl_ecs::ErrorForm f = pcl_ecs::ErrorForm::Normalized;
  EXPECT_TRUE(pcl_ecs::parseErrorForm("paper", f));
  EXPECT_EQ(f, pcl_ecs::ErrorForm::Paper);
  EXPECT_STREQ(pcl_ecs::toString(f), "paper");
  EXPECT_TRUE(pcl_ecs::parseErrorForm("normalized", f));
  EXPECT_EQ(f, pcl_ecs::ErrorForm::Normalized);
  EXPECT_FALSE(pcl_ecs::parseErrorForm("Paper ", f));
}

TEST(Parameters, ResolveThreads)
{
  EXPECT_EQ(pcl_ecs::resolveThreads(3), 3);
  EXPECT_GE(pcl_ecs::resolveThreads(0), 1);
}
