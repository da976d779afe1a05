// sensor_msgs/CameraInfo -> CameraIntrinsics as image_geometry reads it: K and D for a raw image,
// P for a rectified one, binning and ROI, another image size scaled or refused.
#include <gtest/gtest.h>

#include "../../src/ros/camera_info_conversion.h"
#include "spool_vision/detector_params.h"

namespace spool_vision
{
namespace
{
// A C270-like calibration at 640x480 whose P differs from K, as camera_calibration writes it.
sensor_msgs::CameraInfo calibration(const std::string& model, const std::vector<double>& d)
{
  sensor_msgs::CameraInfo info;
  info.width = 640;
  info.height = 480;
  info.distortion_model = model;
  info.D = d;
  info.K = {810.0, 0.0, 322.0, 0.0, 812.0, 236.0, 0.0, 0.0, 1.0};
  info.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  info.P = {760.0, 0.0, 318.0, 0.0, 0.0, 770.0, 241.0, 0.0, 0.0, 0.0, 1.0, 0.0};
  return info;
}

const std::vector<double> kPlumbBob = {-0.2, 0.05, 0.001, -0.002, 0.0};

void expectIntrinsics(const CameraIntrinsics& c, double fx, double fy, double cx, double cy, int width, int height)
{
  EXPECT_DOUBLE_EQ(c.fx, fx);
  EXPECT_DOUBLE_EQ(c.fy, fy);
  EXPECT_DOUBLE_EQ(c.cx, cx);
  EXPECT_DOUBLE_EQ(c.cy, cy);
  EXPECT_EQ(c.width, width);
  EXPECT_EQ(c.height, height);
}

TEST(CameraInfoConversion, RawPlumbBobImageIsKWithD)
{
  const auto result = cameraFromInfo(calibration("plumb_bob", kPlumbBob), 640, 480);
  ASSERT_TRUE(result.camera) << result.problem;
  expectIntrinsics(*result.camera, 810.0, 812.0, 322.0, 236.0, 640, 480);
  EXPECT_EQ(result.camera->distortion, kPlumbBob);
  EXPECT_TRUE(result.camera->distorted());
  EXPECT_TRUE(result.camera->valid());
  EXPECT_TRUE(result.scaled.empty());
}

TEST(CameraInfoConversion, RectifiedImageWithZeroDIsP)
{
  const auto result = cameraFromInfo(calibration("plumb_bob", {0.0, 0.0, 0.0, 0.0, 0.0}), 640, 480);
  ASSERT_TRUE(result.camera) << result.problem;
  expectIntrinsics(*result.camera, 760.0, 770.0, 318.0, 241.0, 640, 480);
  EXPECT_FALSE(result.camera->distorted());
  EXPECT_TRUE(result.camera->distortion.empty());
}

TEST(CameraInfoConversion, ImageRectBesideTheRawCameraInfoIsPWhateverD)
{
  // image_proc publishes image_rect beside the raw camera_info: D is the lens's, P describes it.
  const auto result = cameraFromInfo(calibration("plumb_bob", kPlumbBob), 640, 480, /*rectified=*/true);
  ASSERT_TRUE(result.camera) << result.problem;
  expectIntrinsics(*result.camera, 760.0, 770.0, 318.0, 241.0, 640, 480);
  EXPECT_FALSE(result.camera->distorted());
  // Said, because a raw stream taken for rectified would be measured without its lens.
  EXPECT_NE(result.distortion_ignored.find("read with P (fx 760"), std::string::npos) << result.distortion_ignored;
  EXPECT_NE(result.distortion_ignored.find("rectified:=false"), std::string::npos) << result.distortion_ignored;
}

TEST(CameraInfoConversion, RectifiedWithDistortionAndUnsetPIsKAndSaysSo)
{
  sensor_msgs::CameraInfo info = calibration("plumb_bob", kPlumbBob);
  info.P.fill(0.0);
  const auto result = cameraFromInfo(info, 640, 480, /*rectified=*/true);
  ASSERT_TRUE(result.camera) << result.problem;
  expectIntrinsics(*result.camera, 810.0, 812.0, 322.0, 236.0, 640, 480);
  EXPECT_FALSE(result.camera->distorted());
  EXPECT_NE(result.distortion_ignored.find("read with K (P is unset)"), std::string::npos) << result.distortion_ignored;
}

TEST(CameraInfoConversion, NothingIgnoredWithoutDistortionOrOnARawImage)
{
  EXPECT_TRUE(
      cameraFromInfo(calibration("plumb_bob", {0.0, 0.0, 0.0, 0.0, 0.0}), 640, 480, true).distortion_ignored.empty());
  EXPECT_TRUE(cameraFromInfo(calibration("plumb_bob", kPlumbBob), 640, 480, false).distortion_ignored.empty());
}

TEST(CameraInfoConversion, RectifiedAutoGoesByTheImageTopicsName)
{
  EXPECT_TRUE(spool_vision::isRectifiedStream("auto", "/camera/image_rect"));
  EXPECT_TRUE(spool_vision::isRectifiedStream("auto", "/camera/image_rect_color"));
  EXPECT_FALSE(spool_vision::isRectifiedStream("auto", "/camera/image_raw"));
  EXPECT_FALSE(spool_vision::isRectifiedStream("auto", "/image_rect/image_raw"));
  EXPECT_TRUE(spool_vision::isRectifiedStream("true", "/camera/image_raw"));
  EXPECT_FALSE(spool_vision::isRectifiedStream("false", "/camera/image_rect"));
  EXPECT_THROW(spool_vision::isRectifiedStream("yes", "/camera/image_rect"), spool_vision::ParamError);
}

TEST(CameraInfoConversion, EmptyDAndUnsetPFallBackToK)
{
  auto info = calibration("", {});
  info.P = {};
  const auto result = cameraFromInfo(info, 640, 480);
  ASSERT_TRUE(result.camera) << result.problem;
  expectIntrinsics(*result.camera, 810.0, 812.0, 322.0, 236.0, 640, 480);
}

TEST(CameraInfoConversion, RationalPolynomialKeepsEightCoefficients)
{
  const std::vector<double> d = {-0.2, 0.05, 0.001, -0.002, 0.01, 0.1, 0.02, 0.003};
  const auto result = cameraFromInfo(calibration("rational_polynomial", d), 640, 480);
  ASSERT_TRUE(result.camera) << result.problem;
  EXPECT_EQ(result.camera->distortion, d);
  EXPECT_DOUBLE_EQ(result.camera->fx, 810.0);
  EXPECT_TRUE(result.camera->valid());
}

TEST(CameraInfoConversion, EquidistantIsRefused)
{
  const auto result = cameraFromInfo(calibration("equidistant", {0.1, 0.01, 0.0, 0.0}), 640, 480);
  EXPECT_FALSE(result.camera);
  EXPECT_TRUE(result.refused);
  EXPECT_NE(result.problem.find("'equidistant'"), std::string::npos) << result.problem;
  EXPECT_NE(result.problem.find("plumb_bob"), std::string::npos) << result.problem;
}

TEST(CameraInfoConversion, PlumbBobWithTheWrongCountIsRefused)
{
  const auto result = cameraFromInfo(calibration("plumb_bob", {-0.2, 0.05, 0.0}), 640, 480);
  EXPECT_FALSE(result.camera);
  EXPECT_TRUE(result.refused);
}

TEST(CameraInfoConversion, UncalibratedIsAWarningNotARefusal)
{
  sensor_msgs::CameraInfo info;  // camera_info_manager without a calibration: K all zero
  info.width = 640;
  info.height = 480;
  const auto result = cameraFromInfo(info, 640, 480);
  EXPECT_FALSE(result.camera);
  EXPECT_FALSE(result.refused);
  EXPECT_NE(result.problem.find("uncalibrated"), std::string::npos) << result.problem;
}

TEST(CameraInfoConversion, BinningTwoHalvesK)
{
  auto info = calibration("plumb_bob", kPlumbBob);
  info.binning_x = info.binning_y = 2;
  const auto result = cameraFromInfo(info, 320, 240);
  ASSERT_TRUE(result.camera) << result.problem;
  expectIntrinsics(*result.camera, 405.0, 406.0, 161.0, 118.0, 320, 240);
  EXPECT_EQ(result.camera->distortion, kPlumbBob);  // D acts on normalised coordinates
  EXPECT_TRUE(result.scaled.empty());
}

TEST(CameraInfoConversion, RoiOffsetShiftsThePrincipalPoint)
{
  auto info = calibration("plumb_bob", kPlumbBob);
  info.roi.x_offset = 100;
  info.roi.y_offset = 40;
  info.roi.width = 400;
  info.roi.height = 300;
  const auto result = cameraFromInfo(info, 400, 300);
  ASSERT_TRUE(result.camera) << result.problem;
  expectIntrinsics(*result.camera, 810.0, 812.0, 222.0, 196.0, 400, 300);
  EXPECT_TRUE(result.scaled.empty());
}

TEST(CameraInfoConversion, RoiOfARectifiedImageShiftsP)
{
  auto info = calibration("plumb_bob", {0.0, 0.0, 0.0, 0.0, 0.0});
  info.roi.x_offset = 100;
  info.roi.y_offset = 40;
  info.roi.width = 400;
  info.roi.height = 300;
  const auto result = cameraFromInfo(info, 400, 300);
  ASSERT_TRUE(result.camera) << result.problem;
  expectIntrinsics(*result.camera, 760.0, 770.0, 218.0, 201.0, 400, 300);
}

TEST(CameraInfoConversion, OtherSizeOfTheSameAspectIsScaled)
{
  const auto result = cameraFromInfo(calibration("plumb_bob", kPlumbBob), 320, 240);
  ASSERT_TRUE(result.camera) << result.problem;
  // Pixel centres of a resized image: c' = (c + 0.5) * s - 0.5.
  expectIntrinsics(*result.camera, 405.0, 406.0, 160.75, 117.75, 320, 240);
  EXPECT_EQ(result.camera->distortion, kPlumbBob);
  EXPECT_NE(result.scaled.find("640x480"), std::string::npos) << result.scaled;
  EXPECT_NE(result.scaled.find("320x240"), std::string::npos) << result.scaled;
}

TEST(CameraInfoConversion, OtherAspectIsRefusedNamingBothSizes)
{
  const auto result = cameraFromInfo(calibration("plumb_bob", kPlumbBob), 1280, 720);
  EXPECT_FALSE(result.camera);
  EXPECT_TRUE(result.refused);
  EXPECT_NE(result.problem.find("640x480"), std::string::npos) << result.problem;
  EXPECT_NE(result.problem.find("1280x720"), std::string::npos) << result.problem;
  EXPECT_NE(result.problem.find("calibrate the camera at 1280x720"), std::string::npos) << result.problem;
}

TEST(CameraInfoConversion, InfoFromCameraReadsBackAsTheSameCamera)
{
  for (const std::vector<double>& d :
       {kPlumbBob, std::vector<double>{-0.1, 0.02, 0.0, 0.001, 0.003, 0.01, -0.02, 0.004}, std::vector<double>{}})
  {
    CameraIntrinsics camera;
    camera.fx = 805.5;
    camera.fy = 803.25;
    camera.cx = 318.75;
    camera.cy = 241.5;
    camera.width = 640;
    camera.height = 480;
    camera.distortion = d;
    const sensor_msgs::CameraInfo info = infoFromCamera(camera);
    EXPECT_EQ(info.distortion_model, d.size() == 8 ? "rational_polynomial" : "plumb_bob");
    const auto result = cameraFromInfo(info, 640, 480);
    ASSERT_TRUE(result.camera) << result.problem;
    expectIntrinsics(*result.camera, camera.fx, camera.fy, camera.cx, camera.cy, 640, 480);
    EXPECT_EQ(result.camera->distorted(), !d.empty());
    if (!d.empty())
    {
      EXPECT_EQ(result.camera->distortion, d);
    }
    EXPECT_TRUE(result.distortion_ignored.empty());
  }
}

TEST(CameraInfoConversion, SameCalibrationIgnoresTheHeader)
{
  auto a = calibration("plumb_bob", kPlumbBob);
  auto b = a;
  b.header.stamp = ros::Time(5, 0);
  b.header.frame_id = "other";
  EXPECT_TRUE(sameCalibration(a, b));
  b.K[0] += 1.0;
  EXPECT_FALSE(sameCalibration(a, b));
  b = a;
  b.roi.x_offset = 2;
  EXPECT_FALSE(sameCalibration(a, b));
}

}  // namespace
}  // namespace spool_vision
