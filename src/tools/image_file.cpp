#include "image_file.h"

#include <filesystem>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

namespace spool_vision
{
ImageFile readImageFile(const std::string& path)
{
  // Checked first because imread would also print its own warning about a missing file.
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    throw std::runtime_error("no such file");
  ImageFile file;
  file.image = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (file.image.empty())
    throw std::runtime_error("cannot read image");
  // imread orders colour channels BGR, so these are the formats a file can come as.
  for (const PixelFormat format : {PixelFormat::kMono8, PixelFormat::kMono16, PixelFormat::kBgr8, PixelFormat::kBgra8})
    if (matTypeOf(format) == file.image.type())
    {
      file.format = format;
      return file;
    }
  throw std::runtime_error("unsupported pixel type " + cv::typeToString(file.image.type()));
}

}  // namespace spool_vision
