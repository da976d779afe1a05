#include <gtest/gtest.h>

#include <set>

#include "spool_vision/detector_params.h"

using spool_vision::DetectorParams;
using spool_vision::ParamError;
using spool_vision::paramSpecs;
using spool_vision::setParam;
using spool_vision::validateParams;

namespace
{
// The message of the ParamError `fn` throws, or "" if it throws nothing.
template <typename Fn>
std::string errorOf(Fn fn)
{
  try
  {
    fn();
  }
  catch (const ParamError& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(DetectorParams, DefaultsAreValidAndKeysUnique)
{
  EXPECT_NO_THROW(validateParams(DetectorParams()));
  std::set<std::string> keys;
  for (const auto& spec : paramSpecs())
  {
    EXPECT_TRUE(keys.insert(spec.key).second) << spec.key;
    EXPECT_FALSE(spec.doc.empty()) << spec.key;
  }
  EXPECT_GE(keys.size(), 35u);
}

TEST(DetectorParams, SetsEveryKind)
{
  DetectorParams p;
  setParam(p, "filter_sigma", 0.0025);
  setParam(p, "filter_kernel", 5);
  setParam(p, "morphology_radius", 3.0);  // an integral double is fine for an int key
  setParam(p, "binarize", std::string("otsu"));
  setParam(p, "hole_polarity", std::string("dark"));
  EXPECT_DOUBLE_EQ(p.preprocess.filter_sigma, 0.0025);
  EXPECT_EQ(p.preprocess.filter_kernel, 5);
  EXPECT_EQ(p.preprocess.morphology_radius, 3);
  EXPECT_EQ(p.preprocess.binarize, spool_vision::BinarizeType::kOtsu);
  EXPECT_EQ(p.hough.hole_polarity, spool_vision::Polarity::kDark);
  EXPECT_EQ(std::get<std::string>(spool_vision::findParamSpec("binarize")->get(p)), "otsu");
}

TEST(DetectorParams, ErrorsNameTheKeyAndTheRange)
{
  DetectorParams p;
  const std::string range = errorOf([&] { setParam(p, "binarize_threshold", 1.5); });
  EXPECT_NE(range.find("binarize_threshold"), std::string::npos) << range;
  EXPECT_NE(range.find("[0, 1]"), std::string::npos) << range;

  const std::string word = errorOf([&] { setParam(p, "filter", std::string("bilateral")); });
  EXPECT_NE(word.find("filter"), std::string::npos);
  EXPECT_NE(word.find("gaussian|median|average|unsharp|none"), std::string::npos) << word;

  EXPECT_NE(errorOf([&] { setParam(p, "no_such_key", 1.0); }).find("no_such_key"), std::string::npos);
  EXPECT_NE(errorOf([&] { setParam(p, "filter_kernel", 2.5); }).find("not an integer"), std::string::npos);
  EXPECT_NE(errorOf([&] { setParam(p, "sensitivity", std::string("high")); }).find("sensitivity"), std::string::npos);
  EXPECT_NE(errorOf([&] { setParam(p, "mode", 1.0); }).find("mode"), std::string::npos);
  EXPECT_FALSE(errorOf([&] { setParam(p, "edge_threshold", std::nan("")); }).empty());
  EXPECT_DOUBLE_EQ(p.preprocess.binarize_threshold, 0.35);  // failed sets leave values alone
}

TEST(DetectorParams, RelationsBetweenKeysAreChecked)
{
  DetectorParams p;
  p.hough.flange_radius_min = 60;
  p.hough.flange_radius_max = 40;
  EXPECT_NE(errorOf([&] { validateParams(p); }).find("flange_radius_max"), std::string::npos);

  p = DetectorParams();
  p.geometry.distance_min = 1.5;
  EXPECT_NE(errorOf([&] { validateParams(p); }).find("distance_max"), std::string::npos);

  p = DetectorParams();
  p.preprocess.filter_kernel = 4;
  EXPECT_NE(errorOf([&] { validateParams(p); }).find("filter_kernel"), std::string::npos);

  p = DetectorParams();
  p.geometry.puller_diameter = 0.04;
  EXPECT_NE(errorOf([&] { validateParams(p); }).find("puller_diameter"), std::string::npos);

  p = DetectorParams();
  p.hough.sensitivity = 1.5;  // a struct filled in code meets the same table
  EXPECT_NE(errorOf([&] { validateParams(p); }).find("sensitivity"), std::string::npos);
}
