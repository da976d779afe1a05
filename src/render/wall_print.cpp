#include "spool_vision/render/wall_print.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

namespace spool_vision
{
namespace
{
// Texels per centimetre of the finest level.
constexpr double kPerCm = 0.01 / PrintTexture::kTexel;

int cm(double centimetres)
{
  return std::max(1, static_cast<int>(std::lround(centimetres * kPerCm)));
}

bool chance(cv::RNG& rng, double p)
{
  return rng.uniform(0.0, 1.0) < p;
}

cv::Point randomPoint(cv::RNG& rng, const cv::Size& size)
{
  return {rng.uniform(0, size.width), rng.uniform(0, size.height)};
}

// Words of random lower-case letters, as handwriting or print reads to an edge detector.
std::string randomWords(cv::RNG& rng, int words)
{
  std::string text;
  for (int w = 0; w < words; ++w)
  {
    if (w > 0)
      text += ' ';
    const int letters = rng.uniform(2, 9);
    for (int i = 0; i < letters; ++i)
      text += static_cast<char>('a' + rng.uniform(0, 26));
  }
  return text;
}

// Lines of text from `origin` down, `height_cm` tall letters, until `bottom`.
void drawTextLines(cv::Mat& img, cv::RNG& rng, cv::Point origin, int right, int bottom, double height_cm, int font,
                   const cv::Scalar& colour, int thickness)
{
  // Hershey fonts are about 22 px tall at scale 1.
  const double scale = cm(height_cm) / 22.0;
  const int step = static_cast<int>(cm(height_cm) * rng.uniform(1.4, 2.0));
  for (int y = origin.y + cm(height_cm); y < bottom; y += step)
  {
    const int x = origin.x + rng.uniform(0, cm(2.0));
    const int words = std::max(1, static_cast<int>((right - x) / (cm(height_cm) * 3.5)));
    cv::putText(img, randomWords(rng, rng.uniform(1, words + 1)), {x, y}, font, scale, colour, thickness, cv::LINE_AA);
  }
}

cv::Scalar marker(cv::RNG& rng)
{
  static const cv::Scalar kMarkers[] = {{40, 35, 30}, {150, 60, 25}, {40, 40, 170}, {60, 120, 40}};
  return kMarkers[rng.uniform(0, 4)];
}

// A whiteboard: aluminium frame, faint ghosts of wiped writing, marker handwriting, and the
// circles, boxes and arrows people draw (a hand-drawn circle is a circle to a Hough transform).
void whiteboard(cv::Mat& img, cv::RNG& rng)
{
  img.setTo(cv::Scalar(232, 236, 236));
  const cv::Size size = img.size();
  for (int i = rng.uniform(2, 6); i > 0; --i)  // wiped writing
    cv::line(img, randomPoint(rng, size), randomPoint(rng, size), cv::Scalar(210, 214, 214), cm(rng.uniform(2.0, 6.0)),
             cv::LINE_AA);
  cv::GaussianBlur(img, img, cv::Size(), cm(1.0));
  const int margin = cm(3.0);
  drawTextLines(img, rng, {margin, margin}, size.width - margin, size.height - margin, rng.uniform(2.5, 6.0),
                chance(rng, 0.6) ? cv::FONT_HERSHEY_SCRIPT_SIMPLEX : cv::FONT_HERSHEY_SIMPLEX, marker(rng),
                rng.uniform(1, 4));
  for (int i = rng.uniform(1, 6); i > 0; --i)
  {
    const cv::Point c = randomPoint(rng, size);
    const int r = cm(rng.uniform(2.0, 15.0));
    switch (rng.uniform(0, 3))
    {
      case 0:
        cv::ellipse(img, c, {r, static_cast<int>(r * rng.uniform(0.7, 1.0))}, rng.uniform(0.0, 180.0), 0.0,
                    rng.uniform(250.0, 370.0), marker(rng), rng.uniform(2, 5), cv::LINE_AA);
        break;
      case 1:
        cv::rectangle(img, c, c + cv::Point(2 * r, r), marker(rng), rng.uniform(2, 5), cv::LINE_AA);
        break;
      default:
        cv::arrowedLine(img, c, randomPoint(rng, size), marker(rng), rng.uniform(2, 5), cv::LINE_AA, 0, 0.05);
    }
  }
  cv::rectangle(img, {0, 0}, {size.width - 1, size.height - 1}, cv::Scalar(150, 150, 155), cm(1.5));
}

// A colour photograph: a smooth background, shapes at every scale and contrast, some out of
// focus, and a caption.
void photograph(cv::Mat& img, cv::RNG& rng)
{
  const cv::Size size = img.size();
  cv::Mat coarse(3, 4, CV_8UC3);
  rng.fill(coarse, cv::RNG::UNIFORM, 20, 235);
  cv::resize(coarse, img, size, 0.0, 0.0, cv::INTER_CUBIC);
  // As many shapes per square metre as a poster's 8-30 on a quarter of one.
  const double area = static_cast<double>(size.area()) / (kPerCm * kPerCm * 2500.0);
  for (int layer = 0; layer < 3; ++layer)
  {
    cv::Mat shapes = img.clone();
    for (int i = static_cast<int>(rng.uniform(8, 30) * std::max(1.0, area)); i > 0; --i)
    {
      const cv::Scalar colour(rng.uniform(0, 256), rng.uniform(0, 256), rng.uniform(0, 256));
      const cv::Point c = randomPoint(rng, size);
      const int r = cm(rng.uniform(0.5, 12.0) / (layer + 1));
      if (chance(rng, 0.5))
        cv::circle(shapes, c, r, colour, cv::FILLED, cv::LINE_AA);
      else
        cv::rectangle(shapes, c, c + cv::Point(rng.uniform(1, 3 * r), rng.uniform(1, 3 * r)), colour, cv::FILLED);
    }
    // The far layers out of focus.
    if (layer == 0)
      cv::GaussianBlur(shapes, shapes, cv::Size(), cm(rng.uniform(0.3, 1.5)));
    img = shapes;
  }
  const int band = cm(rng.uniform(4.0, 8.0));
  cv::rectangle(img, {0, size.height - band}, {size.width, size.height}, cv::Scalar(245, 245, 245), cv::FILLED);
  drawTextLines(img, rng, {cm(2.0), size.height - band}, size.width, size.height - cm(0.5), band / kPerCm * 0.3,
                cv::FONT_HERSHEY_DUPLEX, cv::Scalar(20, 20, 20), 2);
  cv::rectangle(img, {0, 0}, {size.width - 1, size.height - 1}, cv::Scalar(240, 240, 240), cm(1.0));
}

// One carton face: print, a logo, a barcode.
void cartonFace(cv::Mat& img, cv::RNG& rng, const cv::Rect& face)
{
  const cv::Scalar ink = chance(rng, 0.7) ? cv::Scalar(30, 30, 30) : cv::Scalar(40, 40, 150);
  const cv::Point c(face.x + rng.uniform(face.width / 4, 3 * face.width / 4 + 1),
                    face.y + rng.uniform(face.height / 4, face.height / 2 + 1));
  const int logo = std::max(2, std::min(face.width, face.height) / rng.uniform(6, 12));
  if (chance(rng, 0.5))
    cv::circle(img, c, logo, ink, chance(rng, 0.5) ? cv::FILLED : rng.uniform(2, 5), cv::LINE_AA);
  else
    cv::rectangle(img, c - cv::Point(logo, logo / 2), c + cv::Point(logo, logo / 2), ink, cv::FILLED);
  drawTextLines(img, rng, {face.x + cm(1.0), face.y + cm(1.0)}, face.x + face.width, c.y - logo, rng.uniform(1.0, 3.0),
                cv::FONT_HERSHEY_SIMPLEX, ink, rng.uniform(1, 3));
  if (chance(rng, 0.6))
  {
    int x = face.x + rng.uniform(cm(1.0), std::max(cm(1.0) + 1, face.width / 2));
    const int y = face.y + face.height - cm(rng.uniform(5.0, 8.0));
    const int end = std::min(face.x + face.width - cm(1.0), x + cm(rng.uniform(4.0, 8.0)));
    for (; x < end; x += rng.uniform(2, 5))
      cv::rectangle(img, {x, y}, {x + rng.uniform(0, 2), y + cm(2.5)}, cv::Scalar(20, 20, 20), cv::FILLED);
  }
}

// Stacked cartons: brown faces, dark seams, a tape strip across each.
void cartons(cv::Mat& img, cv::RNG& rng)
{
  const cv::Size size = img.size();
  img.setTo(cv::Scalar(60, 60, 65));
  for (int y = 0; y < size.height;)
  {
    const int h = cm(rng.uniform(20.0, 40.0));
    for (int x = -rng.uniform(0, cm(20.0)); x < size.width;)
    {
      const int w = cm(rng.uniform(25.0, 50.0));
      const cv::Rect face(x + 2, y + 2, w - 4, h - 4);
      const double shade = rng.uniform(0.8, 1.15);
      cv::rectangle(img, face, cv::Scalar(95, 140, 180) * shade, cv::FILLED);
      cv::rectangle(img, {face.x, face.y + face.height / 2 - cm(2.5)},
                    {face.x + face.width, face.y + face.height / 2 + cm(2.5)}, cv::Scalar(120, 165, 200) * shade,
                    cv::FILLED);
      cartonFace(img, rng, face);
      x += w;
    }
    y += h;
  }
}

// A pallet rack: blue uprights punched with slots every 5 cm, orange beams, stock between.
void rack(cv::Mat& img, cv::RNG& rng)
{
  const cv::Size size = img.size();
  img.setTo(cv::Scalar(45, 45, 48));
  const int bay = cm(rng.uniform(30.0, 60.0));
  const int level = cm(rng.uniform(25.0, 40.0));
  for (int y = level; y < size.height + level; y += level)
    for (int x = 0; x < size.width; x += bay)
    {
      // Stock standing on the beam below.
      const int w = rng.uniform(bay / 4, bay / 2 + 1);
      const int h = rng.uniform(level / 3, 3 * level / 4);
      const cv::Rect box(x + cm(8.0) + rng.uniform(0, bay / 3), y - h, w, h);
      cv::rectangle(img, box, cv::Scalar(rng.uniform(40, 220), rng.uniform(40, 220), rng.uniform(40, 220)), cv::FILLED);
      drawTextLines(img, rng, box.tl(), box.x + box.width, box.y + box.height, rng.uniform(1.0, 2.0),
                    cv::FONT_HERSHEY_SIMPLEX, cv::Scalar(20, 20, 20), 1);
    }
  for (int y = level; y < size.height; y += level)
    cv::rectangle(img, {0, y}, {size.width, y + cm(8.0)}, cv::Scalar(30, 110, 220), cv::FILLED);
  for (int x = 0; x < size.width; x += bay)
  {
    cv::rectangle(img, {x, 0}, {x + cm(7.0), size.height}, cv::Scalar(140, 80, 30), cv::FILLED);
    for (int y = cm(2.0); y < size.height; y += cm(5.0))
      cv::rectangle(img, {x + cm(3.0), y}, {x + cm(4.0), y + cm(2.0)}, cv::Scalar(20, 20, 20), cv::FILLED);
  }
}

// Cartons under stretch film: long bright streaks where the film catches the lamps, and glints.
void shrinkWrap(cv::Mat& img, cv::RNG& rng)
{
  cartons(img, rng);
  const cv::Size size = img.size();
  cv::Mat film = cv::Mat::zeros(size, CV_8UC3);
  for (int i = rng.uniform(3, 9); i > 0; --i)
  {
    std::vector<cv::Point> streak;
    const double y0 = rng.uniform(0, size.height);
    const double slope = rng.uniform(-0.3, 0.3);
    const double wave = rng.uniform(0.0, 5.0 * kPerCm);
    const double period = cm(rng.uniform(20.0, 60.0));
    for (int x = 0; x <= size.width; x += cm(2.0))
      streak.emplace_back(x, static_cast<int>(y0 + slope * x + wave * std::sin(x / period * 2.0 * M_PI)));
    const int value = rng.uniform(80, 200);
    cv::polylines(film, streak, false, cv::Scalar::all(value), cm(rng.uniform(0.5, 4.0)), cv::LINE_AA);
  }
  for (int i = rng.uniform(5, 20); i > 0; --i)
    cv::circle(film, randomPoint(rng, size), cm(rng.uniform(0.3, 1.5)), cv::Scalar::all(255), cv::FILLED, cv::LINE_AA);
  cv::GaussianBlur(film, film, cv::Size(), cm(0.4));
  cv::add(img, film, img);  // saturates: film highlights burn out as they do on a webcam
}

// 8-bit sRGB-like print to linear reflectance: white paper 0.85, black ink 0.03.
cv::Mat linearReflectance(const cv::Mat& srgb)
{
  cv::Mat f;
  srgb.convertTo(f, CV_32FC3, 1.0 / 255.0);
  cv::pow(f, 2.2, f);
  return f * 0.82 + cv::Scalar::all(0.03);
}
}  // namespace

PrintTexture::PrintTexture(const WallPrint& print) : print_(print)
{
  const cv::Size size(std::max(2, static_cast<int>(std::lround(print.width / kTexel))),
                      std::max(2, static_cast<int>(std::lround(print.height / kTexel))));
  cv::Mat img(size, CV_8UC3);
  cv::RNG rng(print.seed);
  // In PrintKind's order.
  using Draw = void (*)(cv::Mat&, cv::RNG&);
  constexpr std::array<Draw, 5> kDraw = {whiteboard, photograph, cartons, rack, shrinkWrap};
  kDraw.at(static_cast<std::size_t>(print.kind))(img, rng);
  levels_.push_back(linearReflectance(img));
  while (levels_.back().cols > 2 && levels_.back().rows > 2)
  {
    cv::Mat next;
    cv::pyrDown(levels_.back(), next);
    levels_.push_back(next);
  }
}

bool PrintTexture::contains(double x, double y) const
{
  return std::abs(x - print_.x) <= 0.5 * print_.width && std::abs(y - print_.y) <= 0.5 * print_.height;
}

cv::Vec3d PrintTexture::reflectance(double x, double y, double footprint) const
{
  const double ratio = std::max(footprint, kTexel) / kTexel;
  const int level = std::min(static_cast<int>(levels_.size()) - 1, static_cast<int>(std::floor(std::log2(ratio))));
  const cv::Mat& tex = levels_[static_cast<std::size_t>(level)];
  // Texel centres; the image's row 0 is the print's top edge.
  const double u = (x - (print_.x - 0.5 * print_.width)) / print_.width * tex.cols - 0.5;
  const double v = ((print_.y + 0.5 * print_.height) - y) / print_.height * tex.rows - 0.5;
  const int u0 = std::clamp(static_cast<int>(std::floor(u)), 0, tex.cols - 2);
  const int v0 = std::clamp(static_cast<int>(std::floor(v)), 0, tex.rows - 2);
  const float a = static_cast<float>(std::clamp(u - u0, 0.0, 1.0));
  const float b = static_cast<float>(std::clamp(v - v0, 0.0, 1.0));
  const cv::Vec3f top = (1.0f - a) * tex.at<cv::Vec3f>(v0, u0) + a * tex.at<cv::Vec3f>(v0, u0 + 1);
  const cv::Vec3f bottom = (1.0f - a) * tex.at<cv::Vec3f>(v0 + 1, u0) + a * tex.at<cv::Vec3f>(v0 + 1, u0 + 1);
  const cv::Vec3f mix = (1.0f - b) * top + b * bottom;
  return {mix[0], mix[1], mix[2]};
}

}  // namespace spool_vision
