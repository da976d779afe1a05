// Reading an image file the way the detector takes it, for the tools that run the detector.
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "spool_vision/types.h"

namespace spool_vision
{
struct ImageFile
{
  cv::Mat image;
  PixelFormat format = PixelFormat::kBgr8;
};

/// Reads `path` keeping its bit depth and channels (mono8, mono16, bgr8, bgra8). Throws
/// std::runtime_error "no such file", "cannot read image" or "unsupported pixel type ...".
ImageFile readImageFile(const std::string& path);

}  // namespace spool_vision
