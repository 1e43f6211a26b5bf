#include <pcl_ecs/parameter_table.h>
#include <pcl_ecs/parameters.h>

#include <cmath>
#include <limits>
#include <set>
#include <string>

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
  EXPECT_TRUE(p.representative_fit);
  EXPECT_TRUE(p.relax_representatives);
  EXPECT_EQ(p.feature_spacing, 0.0);
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

// The parameter table (parameter_table.h): one row per Parameters member, one spelling each.
TEST(ParameterTable, EveryRowRoundTripsItsTextAndNamesItsFieldWhenOutOfRange)
{
  const auto& table = pcl_ecs::parameterTable();
  EXPECT_EQ(table.size(), 23u);
  std::set<std::string> names, fields;
  const Parameters defaults;
  for (const pcl_ecs::ParameterInfo& info : table)
  {
    SCOPED_TRACE(info.name);
    EXPECT_TRUE(names.insert(info.name).second) << "spelled twice";
    EXPECT_TRUE(fields.insert(info.field).second) << "described twice";
    EXPECT_EQ(pcl_ecs::findParameter(info.name), &info);
    // A flag's spelling: lower case words joined by '-'.
    for (const char c : std::string(info.name))
      EXPECT_TRUE((c >= 'a' && c <= 'z') || c == '-') << c;
    // The default's text, set into other parameters, gives the same text back.
    Parameters p;
    p.error_threshold = 0.5;
    p.k_neighbors = 9;
    p.seed = 7;
    const std::string text = pcl_ecs::parameterText(info, defaults);
    if (*info.metavar)
    {
      EXPECT_EQ(pcl_ecs::setParameter(info, text, p), "");
      EXPECT_EQ(pcl_ecs::parameterText(info, p), text);
    }
    EXPECT_TRUE(pcl_ecs::inRange(info, defaults));
  }
  // Out of range: validate() names the field (and the paper's symbol where there is one).
  struct Bad
  {
    const char* name;
    const char* text;
    const char* message;
  };
  for (const Bad& b : {Bad{"terr", "1", "error_threshold (T_err) = 1 is invalid: must be in (0, 1)"},
                       Bad{"alpha", "0", "feature_factor (alpha) = 0 is invalid"},
                       Bad{"k", "4", "k_neighbors (K) = 4 is invalid: must be an integer in [5, 200]"},
                       Bad{"adapt-factor", "0.5", "adaptive_factor = 0.5 is invalid"},
                       Bad{"radius-cap", "1001", "radius_cap_factor = 1001 is invalid"},
                       Bad{"rep-offset", "1.5", "max_representative_offset = 1.5 is invalid"},
                       Bad{"rep-cutoff", "0", "representative_cutoff = 0 is invalid"},
                       Bad{"max-roughness", "11", "max_roughness = 11 is invalid"},
                       Bad{"max-gap", "-1", "max_gap_factor = -1 is invalid: must be 0 (off) or in (0, 100]"},
                       Bad{"target-gap", "101", "target_gap_factor = 101 is invalid"},
                       Bad{"threads", "1025", "threads = 1025 is invalid"},
                       Bad{"target-cap", "-2", "target_radius_cap = -2 is invalid"},
                       Bad{"max-deviation", "-0.1", "max_deviation = -0.1 is invalid"},
                       Bad{"terr-abs", "-2", "error_threshold_abs = -2 is invalid"},
                       Bad{"max-deviation", "101%", "max_deviation_of_L = 1.01, a fraction of L in (0, 1]"}})
  {
    Parameters p;
    ASSERT_EQ(pcl_ecs::setParameter(*pcl_ecs::findParameter(b.name), b.text, p), "") << b.name;
    EXPECT_NE(pcl_ecs::validate(p).find(b.message), std::string::npos) << b.name << ": " << pcl_ecs::validate(p);
  }
  // Text that is no value of the row is refused before any range.
  Parameters p;
  EXPECT_NE(pcl_ecs::setParameter(*pcl_ecs::findParameter("terr"), "abc", p).find("not a number"), std::string::npos);
  EXPECT_NE(pcl_ecs::setParameter(*pcl_ecs::findParameter("seed"), "-1", p).find("must not be negative"), std::string::npos);
  EXPECT_NE(pcl_ecs::setParameter(*pcl_ecs::findParameter("k"), "1e9", p).find("not an integer"), std::string::npos);
  EXPECT_NE(pcl_ecs::setParameter(*pcl_ecs::findParameter("error-form"), "x", p).find("normalized"), std::string::npos);
  // Switches: "true" sets the member to the switch's value, "false" leaves it.
  const pcl_ecs::ParameterInfo& no_adapt = *pcl_ecs::findParameter("no-adapt");
  EXPECT_EQ(pcl_ecs::setParameter(no_adapt, "false", p), "");
  EXPECT_TRUE(p.adaptive);
  EXPECT_EQ(pcl_ecs::setParameter(no_adapt, "true", p), "");
  EXPECT_FALSE(p.adaptive);
  EXPECT_EQ(pcl_ecs::parameterText(no_adapt, p), "true");
  EXPECT_EQ(pcl_ecs::findParameter("error_threshold"), nullptr);  // the field is not a spelling
}

TEST(ParameterTable, MaxDeviationTakesUnitsOrAPercentageOfL)
{
  const pcl_ecs::ParameterInfo& row = *pcl_ecs::findParameter("max-deviation");
  Parameters p;
  EXPECT_EQ(pcl_ecs::setParameter(row, "0.25%", p), "");
  EXPECT_DOUBLE_EQ(p.max_deviation_of_L, 0.0025);
  EXPECT_EQ(p.max_deviation, 0.0);
  EXPECT_EQ(pcl_ecs::parameterText(row, p), "0.25%");
  EXPECT_EQ(pcl_ecs::validate(p), "");
  EXPECT_EQ(pcl_ecs::setParameter(row, "0.02", p), "");  // the other form replaces it
  EXPECT_EQ(p.max_deviation, 0.02);
  EXPECT_EQ(p.max_deviation_of_L, 0.0);
  EXPECT_EQ(pcl_ecs::parameterText(row, p), "0.02");
  EXPECT_NE(pcl_ecs::setParameter(row, "%", p).find("not a number or a percentage"), std::string::npos);
  // Both set (only possible in code), or with a target size: refused, saying why.
  p.max_deviation_of_L = 0.001;
  EXPECT_NE(pcl_ecs::validate(p).find("not with max_deviation as well"), std::string::npos);
  p.max_deviation_of_L = 0.0;
  p.target_size = 100;
  EXPECT_NE(pcl_ecs::validate(p).find("cannot be combined with target_size"), std::string::npos);
}
