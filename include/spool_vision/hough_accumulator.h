// Stage 2: the hand-written circular Hough transform (gradient-directed, polarity-aware).
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "spool_vision/types.h"

namespace spool_vision
{
/// An edge pixel: sub-pixel position on the gradient maximum and the unit gradient direction
/// (pointing from dark to bright).
struct EdgePoint
{
  float x;
  float y;
  float dx;
  float dy;
};

/// A frame's pixels as light: the unfiltered gray frame read through a table of linear light per
/// gray level (Preprocessor::linearLight()).
struct LinearLight
{
  const cv::Mat* gray = nullptr;  ///< CV_8UC1, the frame the gradients were computed from, unfiltered
  const float* table = nullptr;   ///< 256 entries
  double reach = 4.0;             ///< px either side of an edge that its profile is read over
};

/// The linear light at (x, y) (px of `linear`'s gray frame): the four pixels' linear light,
/// interpolated bilinearly; positions clamped to the frame.
float linearLightAt(const LinearLight& linear, float x, float y);

/// Sobel gradients, non-maximum suppression along the gradient and sub-pixel edge positions.
class EdgeDetector
{
public:
  /// `threshold` is the minimum gradient magnitude as a fraction of full scale (0..1). At most
  /// `max_edges` are kept, the strongest: the work of every later stage grows with the edge
  /// count, and a frame of clutter or noise must not take many times a normal frame's time.
  void detect(const cv::Mat& gray8, double threshold, std::size_t max_edges, std::vector<EdgePoint>& edges);

  /// The two halves of detect(): gradients of the whole frame once, then edges of any region
  /// at any threshold (the faint hole rim is extracted at a lower threshold in its small window).
  void computeGradients(const cv::Mat& gray8);
  /// computeGradients() inside `region` (px of the raw frame) only, with `gray8` as detect()'s
  /// region overload needs it; extract() calls then see only `region`.
  void computeGradients(const cv::Mat& gray8, const cv::Rect& region);
  /// detect() for a search window: gradients and edges inside `region` (px of the raw frame)
  /// only, the same edges as detect() finds there while `max_edges` does not bind. `gray8` must
  /// hold the frame's pixels within 2 px of `region` (Preprocessor::process with a region 2 px
  /// wider). Later extract() calls see only `region`, until the next gradients.
  void detect(const cv::Mat& gray8, double threshold, std::size_t max_edges, std::vector<EdgePoint>& edges,
              const cv::Rect& region);
  /// The raw-frame rectangle (frame of `size`) whose edges can lie in the undistorted `roi`.
  cv::Rect rawRoi(const cv::Rect& roi, cv::Size size) const;
  /// With `linear`, each edge is then moved along its gradient to where the light crosses
  /// half-way between the levels `linear.reach` px before and after it (at most 2 px): a camera's
  /// gamma puts a blurred edge's gradient peak on its dark side (up to 1.5 px at 640x480 with a
  /// few px of defocus or motion blur), while any symmetric blur keeps the half-way point of the
  /// light on the edge.
  void extract(double threshold, const cv::Rect& roi, std::size_t max_edges, std::vector<EdgePoint>& edges,
               const LinearLight* linear = nullptr);

  /// Frames of `camera`'s size with lens distortion give their edges in the undistorted image
  /// (the ideal pinhole image with the same K): each position through undistortionTable(), each
  /// gradient direction through that table's local Jacobian J (a gradient maps by J^-T), and
  /// extract()'s roi is read in undistorted pixels too. The frame itself is never resampled, which
  /// keeps undistortion to the few thousand edges kept. A camera without distortion switches it
  /// off. Throws std::invalid_argument on an invalid camera.
  void setUndistortion(const CameraIntrinsics& camera);

private:
  /// computeGradients() inside the raw frame's rectangle `inner` (within the frame) only.
  void computeGradientsIn(const cv::Mat& gray8, const cv::Rect& inner);
  /// extract() in the raw frame's rectangle `raw` (within computed_).
  void extractRaw(double threshold, const cv::Rect& raw, std::size_t max_edges, std::vector<EdgePoint>& edges,
                  const LinearLight* linear);
  /// Drops edges where the lens model has no inverse (no direction, or a position more than the
  /// frame's size off the frame).
  void undistort(std::vector<EdgePoint>& edges) const;
  /// extract()'s move of each edge to the half-way crossing of the light.
  static void placeInLinearLight(const LinearLight& linear, std::vector<EdgePoint>& edges);
  /// Keeps the strongest max_edges of `edges` (strengths_ alongside), in their order.
  void keepStrongest(std::size_t max_edges, std::vector<EdgePoint>& edges);
  /// The squared-magnitude threshold extract() applies in `area`: `t2`, or where more than
  /// kCandidatesPerEdge * max_edges pixels of it reach t2 (noise, dense clutter), the squared
  /// magnitude that about that many of them reach (a histogram of kMagnitudeBins). Each pixel
  /// past the threshold costs a square root and a suppression test, and the budget keeps only
  /// the strongest edges anyway; frames below the limit keep `t2` (their edges are unchanged).
  int boundedThreshold(const cv::Rect& area, int t2, std::size_t max_edges);
  static constexpr std::size_t kCandidatesPerEdge = 8;
  static constexpr int kMagnitudeBins = 1024;

  CameraIntrinsics lens_;
  cv::Mat undistorted_;  ///< undistortionTable(lens_); empty: edges stay where the frame has them
  cv::Mat gx_, gy_, mag_;
  cv::Rect computed_;  ///< where gx_, gy_ and mag_ hold this frame's gradients (all of it but the border)
  std::vector<short> column_sum_, column_diff_;   ///< one row's vertical Sobel taps, padded by 1
  std::vector<int> strengths_;                    ///< squared gradient magnitude of each extracted edge
  std::vector<std::uint8_t> at_threshold_;        ///< extractRaw()'s row: 1 where the threshold is reached
  std::vector<int> selection_;                    ///< scratch for the budget's nth_element
  std::vector<std::size_t> magnitude_histogram_;  ///< boundedThreshold()'s, kMagnitudeBins
};

/// Where a spool's back flange appears behind a front flange rim (x, y, r) seen through a
/// pinhole: hub_length L further away, so its disc is the front disc scaled by
/// k = Z / (Z + L) = 1 / (1 + growth * r) about the principal point (the spool axis taken along
/// the optical axis). Both flanges are black: no edge shows where the front rim lies over the
/// back disc, and an oblique rim fit follows the two discs' joint silhouette.
struct BackFlange
{
  cv::Point2d principal_point;
  double growth = 0.0;  ///< L / (f R), 1/px; 0 = no back flange

  /// Z / (Z + L) for a front rim of radius `r` px.
  double scale(double r) const
  {
    return 1.0 / (1.0 + growth * r);
  }
  /// True when (px, py) lies inside the back disc of the front rim (x, y, r).
  bool hides(double x, double y, double r, double px, double py) const
  {
    const double k = scale(r);
    const double bx = principal_point.x + k * (x - principal_point.x);
    const double by = principal_point.y + k * (y - principal_point.y);
    return growth > 0.0 && (px - bx) * (px - bx) + (py - by) * (py - by) < k * k * r * r;
  }
};

/// Sums of the rim points' moments for the two algebraic least-squares fits of a rim: a circle
/// (Kasa: u^2 + v^2 + a u + b v + c = 0) and an axis-aligned ellipse (a circle seen from a
/// yawed camera: A u^2 + B v^2 + C u + D v = 1). Points in any scaled frame; results in it.
struct RimMoments
{
  double su = 0, sv = 0, suu = 0, suv = 0, svv = 0;
  double suuu = 0, suuv = 0, suvv = 0, svvv = 0, suuuu = 0, suuvv = 0, svvvv = 0;
  unsigned octants = 0;  ///< bit i: some point in octant i
  int count = 0;

  void add(double u, double v);
  /// False when the points fit no circle.
  bool fitCircle(double& x, double& y, double& r) const;
  /// False without points on both sides and in at least 5 octants, or when no ellipse fits.
  bool fitEllipse(double& x, double& y, double& semi_x, double& semi_y) const;
};

// Inline: it runs for every rim point of every fit pass.
inline void RimMoments::add(double u, double v)
{
  const double uu = u * u;
  const double vv = v * v;
  su += u;
  sv += v;
  suu += uu;
  suv += u * v;
  svv += vv;
  suuu += uu * u;
  suuv += uu * v;
  suvv += u * vv;
  svvv += vv * v;
  suuuu += uu * uu;
  suuvv += uu * vv;
  svvvv += vv * vv;
  // The octant from signs and the diagonal: the same eight sectors as atan2 (which cost 7% of a
  // frame here), numbered differently.
  octants |= 1u << ((v < 0.0 ? 4u : 0u) | (u < 0.0 ? 2u : 0u) | (std::abs(u) < std::abs(v) ? 1u : 0u));
  ++count;
}

/// One least-squares step of a rim model on `m`, moments taken in coordinates centred on `model`
/// and scaled by 1 / mean_r. The model is an axis-aligned ellipse (centre, r_horizontal,
/// r_vertical: a circle seen from a yawed camera is stretched horizontally) and r, the radius of
/// the circle fitted with it: the circle fit (Kasa), its centre and semi-axes replaced by the
/// ellipse fit's where that stays within 20% of the circle on both axes (a yawed rim; further off,
/// the ellipse has fitted clutter). False when no circle fits; `model` unchanged then.
bool fitRimModel(const RimMoments& m, double mean_r, Circle& model);

/// Search settings for one radius range.
struct HoughSearch
{
  double r_min = 0.0;  ///< px
  double r_max = 0.0;  ///< px
  Polarity polarity = Polarity::kDark;
  double min_score = 0.2;             ///< required supported fraction of the in-frame rim
  double min_visible_fraction = 0.3;  ///< required fraction of the rim inside the image
  int max_circles = 4;
  /// Centres are only accepted inside this rectangle (px); empty = anywhere, even off-frame
  /// within r_max of the image, which is how arcs cut by the border are found.
  cv::Rect2d center_window;
};

/// Two-stage CHT: every edge point votes for centres along its gradient over the radius range
/// into a 2-D accumulator; peaks (after non-maximum suppression) get a radius from a histogram
/// of supporting edge distances, and a least-squares fit of the supporting points refines the
/// centre, the radius and the vertical semi-axis to sub-pixel precision. Without a
/// center_window, a peak whose measured support is under kMinRefineSupport of min_score is
/// dropped unrefined.
class HoughAccumulator
{
public:
  /// Least share of min_score a whole-frame peak's rim support, measured about its coarse cell,
  /// needs to be refined. Weaker peaks seldom refine into a circle, and then mostly onto a
  /// stronger rim beside them (a duplicate), while refining them took a fifth of the time per
  /// frame at 160x120.
  static constexpr double kMinRefineSupport = 0.7;

  /// Detected circles, best first. `image_size` bounds the visible rim.
  void detect(const std::vector<EdgePoint>& edges, cv::Size image_size, const HoughSearch& search,
              std::vector<Circle>& circles);
  /// detect()'s circles again from the votes the last detect() of `search`'s radii, window and
  /// polarity cast on the same `edges`, asking `search.min_score` of a rim (a second look at
  /// weaker rims without voting again); only peaks centred in `centres` (px; empty = anywhere) are
  /// measured. Throws std::logic_error when the votes are of another search (or of either
  /// polarity since).
  void detectAgain(const std::vector<EdgePoint>& edges, cv::Size image_size, const HoughSearch& search,
                   const cv::Rect2d& centres, std::vector<Circle>& circles);
  /// detect()'s circles for `search` with polarity any, right after a detect() of `search` (dark
  /// or bright) on the same `edges`: only the other polarity's votes are cast, onto the
  /// accumulator that one left, which halves the voting of a second search. Only peaks centred
  /// in `centres` (px; empty = anywhere) are measured. Throws std::logic_error when `search`
  /// does not match the last detect()'s accumulator.
  void detectEitherPolarity(const std::vector<EdgePoint>& edges, cv::Size image_size, const HoughSearch& search,
                            const cv::Rect2d& centres, std::vector<Circle>& circles);

  /// The rim circle of `search`'s radius range centred on `centre` (a known axis: a hole's
  /// centre), with no centre fit: a fit of a one-sided arc would follow whatever else lies on
  /// it. The radius is the support histogram's best-scoring one (with a `back` flange; without,
  /// detect()'s outer-ring rule: about a hole a larger ring is the back flange's crescent, not
  /// the rim outside a rib), then the mean distance of the supporting edges; the score is their
  /// fraction of the rim that can show (in the image, not over `back`'s disc). False without
  /// support.
  bool fitAt(const std::vector<EdgePoint>& edges, cv::Size image_size, const HoughSearch& search,
             const cv::Point2d& centre, const BackFlange& back, Circle& circle);

  /// The centre of a rim of known size and shape (an ellipse, px) within
  /// `max_shift` px of `start`, measured on the part of the rim that shows: the centre that puts
  /// the most edges of `search`'s polarity within a narrow band of the ellipse, each weighted by
  /// its closeness (half-pixel grid, then a tenth, then a fiftieth: the bore's axis is read off
  /// this centre). Only the half of the rim on the `side` of `start` counts (a direction; zero =
  /// all of it). `circle.r` is the mean semi-axis, r_vertical and r_horizontal the shape's half
  /// height and width; the score
  /// as refine()'s, over that half. False without support. For the bore's front rim, whose far
  /// side hides behind the bore wall catching light near the opening: a free fit follows the dark
  /// region inside and comes out small and off centre.
  bool fitCentreAtSize(const std::vector<EdgePoint>& edges, cv::Size image_size, const HoughSearch& search,
                       const cv::Point2d& start, const EllipseShape& shape, double max_shift, const cv::Point2d& side,
                       Circle& circle);
  /// fitCentreAtSize() at the scale of `shape` in [lo, hi] (steps of kScaleStep) whose
  /// rim has the most soft support per px of rim and of band: the rim's own size where only its
  /// shape is known.
  bool fitCentreAndScale(const std::vector<EdgePoint>& edges, cv::Size image_size, const HoughSearch& search,
                         const cv::Point2d& start, const EllipseShape& shape, double max_shift, const cv::Point2d& side,
                         double lo, double hi, Circle& circle);
  /// How well `edges` bear out a rim of `shape` (px) whose centre is within `max_shift` px of
  /// `start` (px): the soft support of ellipseSupport() (edges of `search.polarity` within a band
  /// of 4% of the mean radius, weighted by closeness) at the best such centre (to 0.3 px), per px
  /// of the ellipse's perimeter (Ramanujan's approximation), so that shapes of one rim compare (a
  /// bore seen at different angles off its axis). 0 where no edge supports it. Uses near_.
  double shapeDensity(const std::vector<EdgePoint>& edges, const HoughSearch& search, const cv::Point2d& start,
                      const EllipseShape& shape, double max_shift);
  /// fitCentreAndScale()'s step in scale (a fraction of the given size)
  static constexpr double kScaleStep = 0.02;

  /// How far refitOnMostSupport() looks: the radius within this fraction of the start's, the
  /// centre within kRefitCentreReach of its radius.
  static constexpr double kRefitSizeReach = 0.1;
  static constexpr double kRefitCentreReach = 0.08;
  /// `circle` (a refined rim of `search`) fitted again from the circle near it that the most
  /// edges support (a local search of centre and radius on a narrow band), with refine()'s narrow
  /// passes only. A least-squares fit from a coarse Hough cell can slide off its rim onto arcs
  /// beside it (a neighbour's silhouette touching it, a highlight's edge) and keep part of the rim
  /// (heldout_v2 pos_002: radius +9%); the rim itself is the better supported circle. The caller
  /// decides which of the two to keep. False where no circle fits.
  bool refitOnMostSupport(const std::vector<EdgePoint>& edges, cv::Size image_size, const HoughSearch& search,
                          Circle& circle);

  /// The raw vote image of the last call (CV_32F, one cell per `cellSize()` px), for debugging.
  const cv::Mat& votes() const
  {
    return votes_;
  }
  double cellSize() const
  {
    return cell_;
  }

private:
  struct Peak
  {
    double x;
    double y;
    float votes;
  };
  void vote(const std::vector<EdgePoint>& edges, const HoughSearch& search);
  /// Throws std::logic_error naming `caller` unless the votes are the last detect()'s of `search`.
  void requireVotesOf(const HoughSearch& search, const char* caller) const;
  /// The circles at the accumulator's peaks centred in `centres` (empty = anywhere): radius,
  /// fit, score and duplicates (detect()).
  void circlesFromVotes(const std::vector<EdgePoint>& edges, cv::Size image_size, const HoughSearch& search,
                        const cv::Rect2d& centres, std::vector<Circle>& circles);
  /// Votes on the side `sign` (centreSign) of each edge.
  void vote(const std::vector<EdgePoint>& edges, const HoughSearch& search, float sign);
  /// Radii voted for per edge: r_min, r_min + cell_, ... up to r_max.
  int radiusSteps(const HoughSearch& search) const;
  /// peaks_: the strongest `max_peaks` separate maxima centred in `centres` (empty = anywhere).
  void findPeaks(const HoughSearch& search, int max_peaks, const cv::Rect2d& centres);
  bool measureRadius(const std::vector<EdgePoint>& edges, cv::Size image_size, const HoughSearch& search,
                     const Peak& peak, double slack, const BackFlange& back, Circle& circle);
  /// scores_[i]: the share of the visible rim (can show over `back`) of radius lo + i about
  /// `peak` that histogram_ supports, summed over the bins within slack / 2; 0 outside the search
  /// or with too little of the rim in view. Returns the best.
  double scoreRadii(cv::Size image_size, const HoughSearch& search, const Peak& peak, double lo, int bins, double slack,
                    const BackFlange& back);
  bool refine(const std::vector<EdgePoint>& edges, cv::Size image_size, const HoughSearch& search, Circle& circle);
  /// refine()'s least-squares passes on near_ from pass `first` (its bands narrow pass by pass),
  /// then the support count of the final `model`; false where too few edges are left to fit.
  bool fitPasses(cv::Size image_size, const HoughSearch& search, int first, Circle& model);
  /// The circle (x, y, r in px) about which the edges of near_ on the side `sign` (centreSign())
  /// put the most points, per px of radius, within the narrow fit band: centres within `reach`
  /// px of `start`'s (a grid of reach / 4, then of a pixel), radii within kRefitSizeReach of it.
  cv::Point3d mostSupportedNear(const Circle& start, double reach, float sign);
  /// taken_: the indices into near_ of the edges in the band `band` px wide about the axis-aligned
  /// ellipse of `model` (centre, r_horizontal, r_vertical) that support it for `sign`
  /// (centreSign); returns their count.
  std::size_t pickBand(const Circle& model, double band, float sign);
  /// An ellipse's normalised radius, set up once per fit (its tilt's sine and cosine): rho^2 =
  /// xx vx^2 + xy vx vy + yy vy^2 for an offset (vx, vy) px from its centre, 1 on the ellipse;
  /// mean_r its geometric mean semi-axis (px).
  struct EllipseForm
  {
    explicit EllipseForm(const EllipseShape& shape);
    double rho2(double vx, double vy) const
    {
      return vx * vx * xx + vx * vy * xy + vy * vy * yy;
    }
    double mean_r;
    double xx = 0.0;
    double xy = 0.0;
    double yy = 0.0;
  };
  /// The edges of near_ within `band` px of the ellipse `form` centred at
  /// `c` that support it for `sign` (centreSign), each weighted by how close it lies (1 on the
  /// ellipse, 0 at the band's edge): a soft count, so the best centre is found to a fraction of
  /// a grid step. `count`, if given, gets the plain count.
  double ellipseSupport(const cv::Point2d& c, const EllipseForm& form, double band, float sign, int* count) const;
  // fitCentreAtSize()'s centre search: coarse to fine grids of ellipseSupport() about `start` (the
  // first `grids` of 1, 0.3, 0.06 and 0.02 px).
  cv::Point2d bestCentre(const cv::Point2d& start, const EllipseShape& shape, double band, double max_shift, float sign,
                         double& best_soft, int grids = 4) const;
  // fitCentreAndScale()'s rating of a centre: the best soft support density over the scales lo +
  // k kScaleStep, k <= steps (that scale into `scale`).
  double bestScaleAt(const cv::Point2d& c, const EllipseForm& form, double lo, int steps, float sign, double& scale);
  // The rim model at `centre` with its score over near_ (refine()'s, over `side`'s half).
  bool supportAt(cv::Size image_size, const HoughSearch& search, const cv::Point2d& centre, const EllipseShape& shape,
                 const cv::Point2d& side, Circle& circle) const;
  /// Fills near_ (near_count_) with the edges `inner`..`outer` px from `centre` on its `side` (a direction;
  /// zero = all round).
  void gatherNear(const std::vector<EdgePoint>& edges, const cv::Point2d& centre, double inner, double outer,
                  const cv::Point2d& side);

  cv::Mat votes_;     ///< a view of votes_data_
  cv::Mat smoothed_;  ///< a view of smoothed_data_
  /// The hole window's size changes with every candidate, and cv::Mat::create reallocates on any
  /// change of shape: the cells live in buffers that only grow.
  std::vector<float> votes_data_;
  std::vector<float> smoothed_data_;
  std::vector<std::uint8_t> peak_flags_;  ///< findPeaks()'s row: 1 at a cell that is a peak
  cv::Point2d origin_;                    ///< image position of cell (0,0)
  HoughSearch voted_;                     ///< the last detect()'s search (detectEitherPolarity())
  bool has_votes_ = false;                ///< whether votes_ holds its votes
  double cell_ = 1.0;
  std::vector<Peak> peaks_;
  std::vector<float> histogram_;
  std::vector<std::uint32_t> support_bins_;  ///< measureRadius(): the supporting edges' bins
  std::vector<float> vote_weights_;          ///< vote(): cell / r per radius step
  std::vector<int> vote_cells_;              ///< vote(): one edge's cells, one per radius step
  std::vector<double> scores_;
  std::vector<double> scale_soft_;  ///< bestScaleAt(): soft support per scale
  /// refine(), fitCentreAtSize(): the edges near the circle are the first near_count_ (the
  /// buffer only grows: gatherNear() writes every edge it reads).
  std::vector<EdgePoint> near_;
  std::size_t near_count_ = 0;
  /// ellipseSupport(): each of near_'s edges' weight (a scratch buffer gatherNear() sizes).
  mutable std::vector<double> ellipse_weights_;
  std::vector<std::uint32_t> taken_;  ///< refine(): indices into near_ of one pass's points
  std::vector<std::uint8_t> keep_;    ///< gatherNear(), refine(): 1 per edge kept
};

/// Fraction of a circle's circumference that can show: inside an image of the given size and,
/// for a spool's front rim, not over its `back` flange.
double visibleRimFraction(double x, double y, double r, cv::Size image_size, const BackFlange& back = {});

}  // namespace spool_vision
