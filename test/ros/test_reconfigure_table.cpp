// cfg/SpoolDetector.cfg must agree with the detector's parameter table: same names, types and
// ranges, and every enum word a valid choice. Otherwise dynamic_reconfigure would clamp or
// offer values the YAML loader rejects.
#include <string>

#include <gtest/gtest.h>

#include "spool_vision/SpoolDetectorConfig.h"
#include "spool_vision/detector_params.h"

namespace spool_vision
{
namespace
{
template <typename T>
T valueOf(const SpoolDetectorConfig::AbstractParamDescriptionConstPtr& description, const SpoolDetectorConfig& config)
{
  boost::any value;
  description->getValue(config, value);
  return boost::any_cast<T>(value);
}

TEST(ReconfigureTable, EveryCfgKeyMatchesTheParamSpec)
{
  const SpoolDetectorConfig min = SpoolDetectorConfig::__getMin__();
  const SpoolDetectorConfig max = SpoolDetectorConfig::__getMax__();
  const SpoolDetectorConfig defaults = SpoolDetectorConfig::__getDefault__();
  const DetectorParams params;
  ASSERT_FALSE(SpoolDetectorConfig::__getParamDescriptions__().empty());
  for (const auto& d : SpoolDetectorConfig::__getParamDescriptions__())
  {
    SCOPED_TRACE(d->name);
    const ParamSpec* spec = findParamSpec(d->name);
    ASSERT_NE(spec, nullptr);
    // The tooltip names the table's unit, as "[unit]" at its end.
    const std::string unit = spec->unit.empty() ? "" : " [" + spec->unit + "]";
    EXPECT_TRUE(d->description.size() >= unit.size() &&
                d->description.compare(d->description.size() - unit.size(), unit.size(), unit) == 0 &&
                (!unit.empty() || d->description.back() != ']'))
        << "'" << d->description << "' should end with '" << unit << "'";
    switch (spec->type)
    {
      case ParamType::kChoice:
      {
        ASSERT_EQ(d->type, "str");
        // The edit_method lists the enum words; each must be an allowed choice and vice versa.
        for (const auto& choice : spec->choices)
          EXPECT_NE(d->edit_method.find("'value': '" + choice + "'"), std::string::npos) << choice;
        EXPECT_EQ(valueOf<std::string>(d, defaults), std::get<std::string>(spec->get(params)));
        break;
      }
      case ParamType::kInt:
        ASSERT_EQ(d->type, "int");
        EXPECT_EQ(valueOf<int>(d, min), spec->min_value);
        EXPECT_EQ(valueOf<int>(d, max), spec->max_value);
        EXPECT_EQ(valueOf<int>(d, defaults), std::get<int>(spec->get(params)));
        break;
      case ParamType::kDouble:
        ASSERT_EQ(d->type, "double");
        EXPECT_DOUBLE_EQ(valueOf<double>(d, min), spec->min_value);
        EXPECT_DOUBLE_EQ(valueOf<double>(d, max), spec->max_value);
        EXPECT_DOUBLE_EQ(valueOf<double>(d, defaults), std::get<double>(spec->get(params)));
        break;
    }
  }
}

}  // namespace
}  // namespace spool_vision
