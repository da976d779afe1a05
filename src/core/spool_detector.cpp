#include "spool_vision/spool_detector.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>

#include "spool_vision/bore_parallax.h"
#include "spool_vision/camera_model.h"

namespace spool_vision
{
namespace
{
/// selectTarget()'s cost when no candidate has a concentric hole rim.
constexpr double kNoMatch = std::numeric_limits<double>::infinity();

/// A search of `polarity` needing (1 - `sensitivity`) of the rim, its radii the configured ones
/// where set (> 0), else the ones derived from the distance range (px).
HoughSearch houghSearch(const HoughParams& hp, Polarity polarity, double sensitivity, double r_min_set,
                        double r_min_derived, double r_max_set, double r_max_derived)
{
  HoughSearch search;
  search.r_min = r_min_set > 0.0 ? r_min_set : r_min_derived;
  search.r_max = r_max_set > 0.0 ? r_max_set : r_max_derived;
  search.polarity = polarity;
  search.min_score = 1.0 - sensitivity;
  search.min_visible_fraction = hp.min_visible_fraction;
  search.max_circles = hp.max_candidates;
  return search;
}
}  // namespace

SpoolDetector::SpoolDetector(const DetectorParams& params)
  : params_(params)
  // Both are set up again for the camera of the first frame (geometryFor()).
  , preprocessor_(params.preprocess, CameraIntrinsics::thesisDefault(640, 480).fy)
  , matcher_(params.matcher, params.geometry, CameraIntrinsics::thesisDefault(640, 480))
{
  validateParams(params);
}

void SpoolDetector::setParams(const DetectorParams& params)
{
  validateParams(params);
  params_ = params;
  geometry_.reset();
}

void SpoolDetector::setCamera(const CameraIntrinsics& camera)
{
  if (!camera.valid())
    throw std::invalid_argument("camera intrinsics need fx, fy > 0 and a positive image size");
  camera_ = camera;
  geometry_.reset();
  // The lens table and the geometry for this camera now, not in its first frame's time.
  geometryFor(cv::Size(camera.width, camera.height));
}

void SpoolDetector::clearCamera()
{
  camera_.reset();
  geometry_.reset();
}

const SpoolGeometry& SpoolDetector::geometryFor(cv::Size size)
{
  if (geometry_ && geometry_->camera().width == size.width && geometry_->camera().height == size.height)
    return *geometry_;
  using_fallback_ = !(camera_ && camera_->width == size.width && camera_->height == size.height);
  const CameraIntrinsics camera = cameraFor(size);
  geometry_.emplace(params_.geometry, camera);
  matcher_ = ConcentricMatcher(params_.matcher, params_.geometry, camera);
  preprocessor_.setParams(params_.preprocess, camera.fy);
  edge_detector_.setUndistortion(camera);
  moving_edges_.setCamera(camera);
  rim_pose_search_.setCamera(camera);
  return *geometry_;
}

CameraIntrinsics SpoolDetector::cameraFor(cv::Size size) const
{
  return camera_ && camera_->width == size.width && camera_->height == size.height
             ? *camera_
             : CameraIntrinsics::thesisDefault(size.width, size.height, params_.geometry.fallback_focal_length);
}

CameraIntrinsics SpoolDetector::camera() const
{
  return geometry_ ? geometry_->camera() : CameraIntrinsics::thesisDefault(640, 480);
}

SpoolDetection SpoolDetector::detect(const cv::Mat& image, PixelFormat format)
{
  return detect(image, format, std::nullopt);
}

SpoolDetection SpoolDetector::detect(const cv::Mat& image, PixelFormat format,
                                     const std::optional<FlangeWindow>& window)
{
  if (image.empty())
    throw std::invalid_argument("empty image");
  if (image.cols < kMinImageSide || image.rows < kMinImageSide)
    throw std::invalid_argument("image " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                                " is smaller than the minimum " + std::to_string(kMinImageSide) + "x" +
                                std::to_string(kMinImageSide));
  const auto start = std::chrono::steady_clock::now();
  const SpoolGeometry& geometry = geometryFor(image.size());
  const HoughParams& hp = params_.hough;

  double flange_min = 0.0;
  double flange_max = 0.0;
  double hole_min = 0.0;
  double hole_max = 0.0;
  geometry.radiusRanges(flange_min, flange_max, hole_min, hole_max);
  HoughSearch flange_search = houghSearch(hp, hp.flange_polarity, hp.sensitivity, hp.flange_radius_min, flange_min,
                                          hp.flange_radius_max, flange_max);
  if (window)
  {
    // The window's prior (the centre within a few px, the radius within a few %) stands in for
    // part of the rim's evidence: a flange cut by the border with a label or the puller rod over
    // what is left shows a quarter of its rim.
    flange_search.min_score = std::min(flange_search.min_score, 1.0 - kWindowSensitivity);
    flange_search.r_min = std::max(1.0, window->radius - window->radius_margin);
    flange_search.r_max = std::max(flange_search.r_min + 1.0, window->radius + window->radius_margin);
    flange_search.center_window =
        cv::Rect2d(window->centre.x - window->centre_margin, window->centre.y - window->centre_margin,
                   2.0 * window->centre_margin, 2.0 * window->centre_margin);
  }
  const HoughSearch hole_search = houghSearch(hp, hp.hole_polarity, hp.hole_sensitivity, hp.hole_radius_min, hole_min,
                                              hp.hole_radius_max, hole_max);
  const cv::Point2d reference = geometry.reference(geometry.nominalDistance());
  // The whole frame's checks of the chosen spool run in a window that stands for the whole frame.
  const bool whole_frame = !window || window->whole_frame;
  // The steps below read this search's settings; the searches nested in it (an outer rim's, the
  // second search) set their own, and the caller's are back when this one returns.
  const SearchSettings outer = search_;
  struct Restore
  {
    SearchSettings& settings;
    SearchSettings value;
    ~Restore()
    {
      settings = value;
    }
  } restore{search_, outer};
  search_.whole_frame = whole_frame;
  // The moving edges keep the frame's gray levels over this search and those nested in it.
  struct HeldFrame
  {
    MovingEdges& edges;
    RimPoseSearch& poses;
    bool outermost;
    ~HeldFrame()
    {
      if (outermost)
      {
        edges.endFrame();
        poses.endFrame();
      }
    }
  } held{moving_edges_, rim_pose_search_, !outer.nested};
  if (held.outermost)
  {
    moving_edges_.beginFrame();
    rim_pose_search_.beginFrame();
  }
  search_.nested = true;

  SpoolDetection result;
  if (whole_frame)
  {
    bore_agrees_at_own_size_ = false;
    weak_match_rim_taken_ = false;
    small_bore_spool_taken_ = false;
    searched_pose_.reset();
    bore_ring_.reset();
  }
  bool along_rim = window && window->rim.radius > 0.0;
  bool budget_bound = false;
  // A tracked rim's bore is first measured at its known size where the track puts it; the hole
  // search runs where that finds no bore rim.
  bool at_prediction = false;
  if (along_rim)
  {
    // The tracked rim by moving edges; only the hole's surroundings are preprocessed.
    flanges_.clear();
    edges_.clear();
    Circle flange;
    along_rim = measureAlongRim(image, format, *window, flange_search, !outer.nested, flange);
    if (along_rim)
    {
      flanges_.push_back(flange);
      at_prediction = boreAtPrediction(image, format, *window, result);
      HoughSearch holes = hole_search;
      if (!at_prediction && matcher_.narrowHoleSearch(flange, image.size(), holes))
        prepareAround(image, format, holes.center_window, kDiscReach * holes.r_max, false);
    }
  }
  if (!along_rim)
  {
    // No rim along the prediction (or none predicted): the window's Hough search, or the frame's.
    if (window)
    {
      // Only the pixels the window's flanges can reach are preprocessed and searched for edges:
      // the centre window plus the largest radius, an oblique rim's wider semi-axis and the
      // rim fit's band (kWindowSlack), in raw frame px.
      const double reach = window->centre_margin + kWindowSlack * (window->radius + window->radius_margin) + kWindowPad;
      prepareAround(image, format, cv::Rect2d(window->centre.x, window->centre.y, 0.0, 0.0), reach, true);
    }
    else
    {
      preprocessor_.process(image, format, preprocessed_);
      edge_detector_.detect(preprocessed_, hp.edge_threshold, edgeBudget(image.size()), edges_);
      // Fewer edges than the budget: a larger one keeps the same edges.
      budget_bound = edges_.size() >= edgeBudget(image.size());
    }
    flange_hough_.detect(edges_, image.size(), flange_search, flanges_);
  }
  const double cost = at_prediction ? 0.0
                                    : selectTarget(reference, flange_search, hole_search,
                                                   params_.matcher.spool_evidence, kNoMatch, result);
  // The cost a sharp bore lowers (bearingSupport()) does not stand for the rim: whether a better
  // supported rim of the same spool can cost less is judged on the rim's own support.
  const double rim_cost =
      result.hole_detected && std::isfinite(cost)
          ? ConcentricMatcher::targetCost({result.hole.x, result.hole.y}, result.flange.score, reference)
          : cost;
  // The second search runs only where it can change the answer: no spool with a hole rim, or
  // one costing more than its flange radius. Within it, no other spool (whose disc cannot
  // overlap this one's) is nearer the reference.
  const bool retry = !along_rim && hp.flange_retry == FlangeRetry::kAnyPolarity &&
                     params_.matcher.mode == MatchMode::kMcht && flange_search.polarity != Polarity::kAny &&
                     !(rim_cost <= result.flange.r);
  // A spool taken, when one costing less could be beside it: first sought with less rim support
  // asked, then with either polarity, also after a nearer spool was found (its weak circle may be
  // the joint silhouette of its two flanges, its front rim the other polarity's: oblique seed 13
  // #191).
  double taken = cost;
  nearer_flanges_.clear();
  const bool nearer =
      retry && whole_frame && std::isfinite(cost) && searchNearer(reference, flange_search, hole_search, taken, result);
  const bool either = retry && (nearer || !(rim_cost <= result.flange.r)) &&
                      searchEitherPolarity(reference, flange_search, hole_search, taken, result);
  // The bores lead to a spool only in the frame's last search (a budget-bound first one is
  // searched again): the bore alone may lead to a rib ring where the second search's flange
  // circle leads to the rim outside it (oblique seed 7 #42, #107).
  const bool last_search = search_.second || !budget_bound;
  // The weak circles searchNearer() found nearer the reference lead to bores too: a Hough circle
  // too large and off its bore (a grey face under a shelf board, its bore's lit lens splitting
  // the bore's rim) has no bore in its concentric window, but one within a third of its size
  // (hard seed 7 #160 at 1280x720).
  const bool oblique = !either && !nearer && !along_rim && whole_frame &&
                       (obliqueSpool(image, format, reference, flanges_, hole_search,
                                     result.hole_detected ? cost : kNoMatch, last_search, result) ||
                        (result.hole_detected && !nearer_flanges_.empty() &&
                         obliqueSpool(image, format, reference, nearer_flanges_, hole_search, cost, false, result)));
  // No spool, but a circle about a sharp bore too large for it: a rib ring, whose flange is searched
  // outside it below (and without which it is no spool). In either search: this leads outwards.
  const bool ring_about_bore =
      !result.detected && !along_rim && whole_frame && ringAboutLargeBore(reference, hole_search, result);
  // Nor any rib ring a Hough circle gave, but a rim searched about a bore that the bore at its own
  // size calls one: it too leads outwards.
  const bool ring_searched_about_bore =
      !result.detected && !along_rim && whole_frame && !ring_about_bore && takeBoreRing(result);
  const bool bare_ring = ring_about_bore || ring_searched_about_bore;
  if (along_rim)
  {
    // The moving edges on the rim are its edges, while the flange is theirs.
    const std::vector<cv::Point2f>& on_rim = moving_edges_.rimEdges();
    rim_.clear();
    if (result.hole_detected && !flanges_.empty() && result.flange.r == flanges_.front().r)
      rim_.assign(on_rim.begin(), on_rim.end());
  }
  else
  {
    gatherRim(result, either ? Polarity::kAny : flange_search.polarity);
    if (oblique)
      takeObliqueRim();
  }
  geometry.measure(result, rim_);
  const bool rim_measured = whole_frame && !along_rim && result.hole_detected &&
                            measureObliqueRim(image, format, geometry, hole_search, result);
  if (whole_frame && !along_rim && !oblique && result.hole_detected &&
      result.flange.score < ConcentricMatcher::kSolidRimScore)
    weak_match_rim_taken_ = rimAboutWeakMatch(image, format, geometry, rim_measured, result);
  if (whole_frame && !along_rim && result.hole_detected &&
      nearerTurnedSpool(image, format, reference, hole_search, result))
  {
    gatherRim(result, hp.flange_polarity);
    takeObliqueRim();
    geometry.measure(result, rim_);
  }
  else if (whole_frame && !along_rim && result.hole_detected &&
           nearerTurnedFlange(image, format, reference, flange_search, result))
    geometry.measure(result, rim_);
  const bool outline_refused =
      whole_frame && !along_rim && result.hole_detected && !frontRimAboutOwnBore(image, format, geometry, result);
  // A rib ring taken as the flange says so by its bore, measured at the bore's own size (seen far
  // off its axis, with the lit wall on the side the axis gives).
  Circle bore;
  bool inner_ring = whole_frame && result.hole_detected && ownBore(result, hole_search, bore);
  // (Not where the ring was refused as an outline just above: nothing is left to lead outwards.)
  if (ring_searched_about_bore && result.hole_detected)
  {
    inner_ring = true;
    bore = bore_ring_->bore;
  }
  // Seen far off its axis, the bore is measured with the lit wall on the side the axis gives: the
  // whole frame's pose's, or the one an inner ring of the same spool gave the window.
  const bool axis_given = window && std::isfinite(window->spool_axis[2]);
  const cv::Vec3d axis = axis_given ? window->spool_axis : result.axis;
  bool oblique_inner_ring = false;
  bool off_axis_bore = false;
  if (((whole_frame && !along_rim) || axis_given) && result.hole_detected && !inner_ring && offAxis(axis))
  {
    oblique_inner_ring = whole_frame && obliqueInnerRing(result, bore);
    inner_ring = oblique_inner_ring;
    off_axis_bore = whole_frame && !inner_ring;
    if (!inner_ring)
      remeasureBore(geometry, axis, false, result);
  }
  else if (whole_frame && !along_rim && result.hole_detected && !inner_ring && roundBoreInOvalFlange(result))
    remeasureBore(geometry, std::nullopt, false, result);
  measureBoreParallax(geometry, result);
  // The second search's spool, however it was found (a circle of either polarity about a bore
  // whose free circle scored 0.74: oblique seed 131 #3 at 640x480), is as good as one found about
  // a bore that agrees with its rim (takesSecondSearch()); a rim cut by the border asks the hole
  // rim it asks in spoolAboutHoles() (a neighbour cut to a third, 13% deep: packed seed 103 #47 at
  // 160x120).
  if (search_.second && whole_frame && result.hole_detected && !inner_ring && !outline_refused &&
      !bore_agrees_at_own_size_)
    bore_agrees_at_own_size_ =
        boreAgreesAtOwnSize(result, result.axis) &&
        (!cutByBorder(result.flange) || result.hole.score >= params_.matcher.cut_flange_hole_score);
  // What is reported is measured again, now that nothing is judged on it: the pose the rim search
  // found an oblique flange at, where its moving edges support it more than the pose fitted on the
  // flange's edges since (searchedPoseSupportsMore()); a pose its ellipse could not give fitted on
  // its rim from the axes the ellipse's aspect allows; and, wherever the pose has an axis, its bore
  // at the size and shape that pose projects it to, as well as at its flange's (seen 14 deg off
  // its axis, within offAxis()'s 10 deg by a pose 6 deg short, a bore was measured round on a round
  // flange circle, 1.1 px off: oblique seed 131 #70; near the axis, 1.2 px off on a lit lens or at
  // the frame's edge: hard seed 7 #1, #56, at 640x480). The checks above keep the size its flange's
  // ellipse gives, which they were set on.
  const bool reported = whole_frame && !along_rim && !inner_ring;
  bool silhouette_beyond_view = false;
  const bool searched_pose_taken =
      reported && searchedPoseSupportsMore(image, format, geometry, result, false, nullptr, &silhouette_beyond_view);
  // The bore measured at its own size on the pose taken: a pose searched about the bore can be a
  // rib ring's, found about a round circle too small for the bore whose circle fit (21.5 px for a
  // 23.9 px high bore seen 32 deg off) agreed with it (packed_oblique seed 43 #37 at 640x480: the
  // ring's pose right in axis, 20% deep; the bore 1.2 times what the ring allows, 1.06 at most on
  // the 200 other searched poses of 19 rendered sets). That pose is carried out to the flange's.
  std::optional<SearchedPose> ring_pose;
  if (ring_searched_about_bore)
    ring_pose = bore_ring_->ring;
  if (searched_pose_taken && offAxis(result.axis) && obliqueInnerRing(result, bore))
  {
    inner_ring = true;
    oblique_inner_ring = true;
    ring_pose = SearchedPose{result.flange, result.position, result.axis};
  }
  if (off_axis_bore ||
      ((searched_pose_taken || (reported && geometry.measureFromAspect(result, rim_))) && offAxis(result.axis)))
    remeasureBore(geometry, result.axis, true, result);
  else if (reported && std::isfinite(result.axis[2]))
    remeasureBore(geometry, result.axis, true, result, kReportedBoreShift);
  toFramePixels(geometry.camera(), result);
  bool outer_taken = false;
  // Whatever is reported now is no longer the spool about that bore.
  if (inner_ring || outline_refused)
  {
    bore_agrees_at_own_size_ = false;
    weak_match_rim_taken_ = false;
    small_bore_spool_taken_ = false;
  }
  if (inner_ring)
  {
    // The flange is then the outermost concentric rim that agrees with the bore's size (a face may
    // carry several rib rings): rims are searched outwards, each above the one before, as the
    // tracker's window searches (the rim may be cut by the frame), after this result is complete
    // (the search reuses the frame's buffers).
    const double outer = result.flange.r_vertical * bore.r_vertical / matcher_.holeRadius(result.flange);
    // Taken only where the two agree: the outer rim's own hole is the bore that was measured, its
    // centre within concentric_tolerance (each is measured to about a pixel) and its size within
    // the margin the rim was searched in (in frame px, as detect() leaves its centres).
    const cv::Point2d seen = distortPixel(geometry.camera(), {bore.x, bore.y});
    const double centre_agreement = std::max(matcher_.tolerancePx(), kOwnBoreAgreementPx);
    // The largest concentric rim found so far, taken or not: a rib ring between the flange and
    // the inner ring taken (faces carry them at 0.86 of the rim: hard set seed 7 #10) is no
    // flange, but the next rim is searched above it.
    double below = result.flange.r_vertical;
    const cv::Point2d hole_seen(result.hole.x, result.hole.y);
    const bool near_axis = !oval(result.flange);
    for (int ring = 0; ring < kMaxRibRings; ++ring)
    {
      const double inner = result.flange.r_vertical;
      const double smallest = std::max((1.0 - kOuterRimMargin) * outer, kInnerRingRatio * below);
      const double largest = (1.0 + kOuterRimMargin) * outer;
      if (smallest >= largest)
        break;
      // About the bore measured at its own size, or, for a rim the frame's search would take, about
      // the hole the inner ring was found with: seen 30-40 deg off the axis, the first is an ellipse
      // about the pose's axis and the rim's window fits a circle, their centres up to half the
      // bore's radius apart (10.7 px on packed oblique seed 43 #24 at 640x480, 2.8 px on oblique 97
      // #80 at 320x240). That hole may be mismeasured, and a weaker circle about it a back flange's
      // outline (0.36 on oblique seed 185 #48 of 300 at 640x480, 15% short). Both may be off the
      // bore where the rim's own hole is not: a sharp hole within half a bore radius of either is
      // that bore (packed_oblique seed 185 #109 of 200 at 640x480: the two 4.6 and 5.0 px off the
      // truth, the flange's hole 1.8 px off, 6.3 and 5.9 px from them).
      auto concentric = [&](const SpoolDetection& rim)
      {
        const double off_seen = std::hypot(rim.hole.x - seen.x, rim.hole.y - seen.y);
        const double off_hole_seen = std::hypot(rim.hole.x - hole_seen.x, rim.hole.y - hole_seen.y);
        const bool takeable = rim.flange.score >= flange_search.min_score;
        return rim.hole_detected && (off_seen <= centre_agreement || (takeable && off_hole_seen <= centre_agreement) ||
                                     (takeable && rim.hole.score >= kSharpHoleScore &&
                                      std::min(off_seen, off_hole_seen) <= kSharpBoreAgreement * bore.r));
      };
      // Near the axis, a rim whole in the frame needs the support the frame's search asks: the
      // window's lower bar stands for a rim the border cuts, and a faint circle just outside a
      // sharp whole rim (0.27-0.37 about a lit lens whose bore measured 4-5% large: hard seed 19
      // #48, #147 at 320x240) is no flange. Far off the axis a circle follows the rim's ellipse in
      // part only (0.3 on oblique seed 13 #42, the flange outside a rib ring).
      auto agrees = [&](const SpoolDetection& rim)
      {
        // The window's sub-pixel refinement may put the rim just under its lower bound (267.3 px for
        // 267.4: oblique seed 97 #80 at 640x480); each is measured to about a pixel.
        return concentric(rim) && rim.flange.r_vertical >= smallest - kOwnBoreAgreementPx &&
               std::abs(rim.hole.r - bore.r) <= std::max(kOuterRimMargin * bore.r, kOwnBoreAgreementPx) &&
               (!near_axis || rim.flange.visible_fraction < ConcentricMatcher::kMinHoleVisibleFraction ||
                rim.flange.score >= flange_search.min_score);
      };
      FlangeWindow around;
      if (oblique_inner_ring)
        around.spool_axis = result.axis;
      around.centre = {bore.x, bore.y};
      around.centre_margin = 0.25 * kOuterRimMargin * outer;
      around.radius = 0.5 * (smallest + largest);
      around.radius_margin = 0.5 * (largest - smallest);
      SpoolDetection rim = detect(image, format, around);
      if (!agrees(rim) && std::isfinite(result.position.z))
      {
        // A rim too faint for the Hough search (a grey face on a grey wall, cut by the frame, the
        // ribs' edges taking the edge budget) is still the strongest edge along its own circle:
        // it is measured by moving edges where the bore puts it (this rim's centre scaled to the
        // bore's depth), no farther in than halfway to the rim below. Facing the camera: an inner
        // ring's own axis is no guide (a rib's relief tilts its fit by up to 17 deg on a level
        // spool), and near the axis, where a face overfills the frame, the two differ by little.
        around.rim = RimPrediction{result.position * (inner / outer), cv::Vec3d(0.0, 0.0, 1.0),
                                   0.5 * params_.geometry.flange_diameter};
        around.rim_reach = std::min(kOuterRimMargin, 0.5 * (1.0 - below / outer)) * outer;
        around.bore_reach = centre_agreement;
        rim = detect(image, format, around);
      }
      // A rim that does not agree is searched above only about a bore large enough to have been
      // measured (at 160x120 a 4 px bore's size is noise: oblique seed 7 #146).
      const bool taken = agrees(rim);
      if (!taken && !(bore.r >= kMinKnownSizeRadius && concentric(rim) && rim.flange.r_vertical > below))
        break;
      below = rim.flange.r_vertical;
      if (taken)
      {
        result = rim;
        outer_taken = true;
      }
    }
  }
  // The flange outside an inner ring came from the window's search, which checks no reported pose:
  // its pose is checked now as a whole frame's is (a round circle about an oblique rim, 7-45 deg
  // off the axis from the start a circle gives: oblique seed 7 #11, #84 and 47 #20 at 640x480),
  // in undistorted px.
  if (outer_taken)
  {
    const CameraIntrinsics& camera = geometry.camera();
    toUndistortedPixels(camera, result);
    if (searchedPoseSupportsMore(image, format, geometry, result, true, ring_pose ? &*ring_pose : nullptr) &&
        offAxis(result.axis))
      remeasureBore(geometry, result.axis, true, result);
    toFramePixels(camera, result);
  }
  // Seen far off its axis, a rib ring (its bore at its own size too large for it, its ellipse oval)
  // with no rim outside it that agrees with the bore is no flange either: its depth is the ring's,
  // 13-18% off on the oblique sets (seed 7 #10, 131 #83 at 640x480; 131 #68 at 320x240). A round
  // one is judged on its own pose's axis alone, which can be 10 deg off (the right flange, seen 6
  // deg off its axis: seed.yaml, main seed 163 #57 of 60 at 160x120). Nor is a joint silhouette
  // of a spool seen beyond the range (searchedPoseSupportsMore()'s `beyond_view`).
  if (((bare_ring || (oblique_inner_ring && oval(result.flange))) && !outer_taken) || silhouette_beyond_view)
  {
    noSpool(geometry, result);
    toFramePixels(geometry.camera(), result);
  }
  result.time_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!window && !result.detected && budget_bound && !search_.second && !outline_refused)
  {
    // Nothing in the whole frame, whose edges filled the budget: texture elsewhere may have taken
    // the target rim's share (a clear target missed at edge_budget 6, found at 8). Searched again with
    // kRetryBudgetScale times the budget; what that finds is taken only on strong evidence
    // (takesSecondSearch()), since more edges let clutter vote for more false circles too.
    search_.second = true;
    const SpoolDetection second = detect(image, format, window);
    const double first_ms = result.time_ms;
    if (takesSecondSearch(second))
      result = second;
    result.time_ms = first_ms + second.time_ms;
  }
  return result;
}

void SpoolDetector::prepareAround(const cv::Mat& image, PixelFormat format, const cv::Rect2d& centres, double reach,
                                  bool flange_edges)
{
  const cv::Rect undistorted(cvFloor(centres.x - reach), cvFloor(centres.y - reach),
                             cvCeil(centres.width + 2.0 * reach) + 1, cvCeil(centres.height + 2.0 * reach) + 1);
  const cv::Rect region = edge_detector_.rawRoi(undistorted, image.size());
  preprocessor_.process(image, format, preprocessed_,
                        cv::Rect(region.x - 2, region.y - 2, region.width + 4, region.height + 4));
  if (flange_edges)
    edge_detector_.detect(preprocessed_, params_.hough.edge_threshold, edgeBudget(image.size()), edges_, region);
  else
    edge_detector_.computeGradients(preprocessed_, region);
}

bool SpoolDetector::measureAlongRim(const cv::Mat& image, PixelFormat format, const FlangeWindow& window,
                                    const HoughSearch& flange_search, bool tracked, Circle& flange)
{
  RimSearch search = rimSearch(window.rim_reach);
  search.max_band_share = tracked ? kTrackedRimBandShare : 0.0;
  if (!moving_edges_.measure(image, format, window.rim, search, flange))
    return false;
  // The window's tests: enough of the rim, and a fit that stayed where the track allows.
  return flange.score >= flange_search.min_score && flange.r_vertical >= flange_search.r_min &&
         flange.r_vertical <= flange_search.r_max && flange_search.center_window.contains({flange.x, flange.y});
}

RimSearch SpoolDetector::rimSearch(double reach) const
{
  const PreprocessParams& pre = params_.preprocess;
  RimSearch search;
  search.reach = reach;
  // Either way: within a few px of a predicted rim its own edge is the strongest, whichever side
  // is darker (a grey face against a dark shelf board shows it bright inside, where the dark
  // search would take the back flange's silhouette around it).
  search.polarity = Polarity::kAny;
  search.threshold = kAlongRimThreshold * params_.hough.edge_threshold;
  search.sigma = pre.filter == FilterType::kGaussian ? pre.filter_sigma * geometry_->camera().fy : 0.0;
  return search;
}

bool SpoolDetector::measureObliqueRim(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                                      const HoughSearch& hole_search, SpoolDetection& result)
{
  if (!(result.position.z > 0.0) || result.flange.r_vertical < kObliqueRimMinRadius)
    return false;
  RimSearch own_search = obliqueRimSearch(result.flange.r_vertical);
  own_search.samples_in_view = offAxis(result.axis);
  const cv::Point2d bore(result.hole.x, result.hole.y);
  const double own =
      rim_pose_search_.measure(image, format, geometry, bore, result.position, result.axis, own_search, own_rim_)
          ? own_rim_.support
          : 0.0;
  // A rim mostly out of the frame has too few samples for any pose's fit: nothing to compare.
  if (rim_pose_search_.samplesInFrame() < kObliqueRimMinSamples)
    return false;
  if (own >= kObliqueRimSupport)
    return true;
  const double least = std::max(own + kObliqueRimMargin, kObliqueRimMinSupport);
  Circle hole = result.hole;
  if (!(rim_pose_search_.search(image, format, geometry, bore, kObliqueNearest * result.position.z,
                                kObliqueFarthest * result.position.z, obliqueRimSearch(result.flange.r_vertical),
                                oblique_rim_) &&
        oblique_rim_.support >= least && boreAgreesWith(hole, oblique_rim_)) &&
      !smallerBoreRim(image, format, geometry, hole_search, result, least, hole))
    return true;
  takeSpoolAboutBore(geometry, hole, result);
  return true;
}

bool SpoolDetector::rimAboutWeakMatch(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                                      bool rim_measured, SpoolDetection& result)
{
  // The second search's spool that would be dropped (takesSecondSearch()) has nothing to lose;
  // any other result is replaced by a rim seen off its axis that its own pose's rim, where
  // measured, supports less by kObliqueRimMargin (a frontal circle is as well measured).
  const bool dropped = search_.second && !takesSecondSearch(result);
  const Circle hole = result.hole;
  const bool own_measured =
      !dropped && rim_pose_search_.measure(image, format, geometry, {hole.x, hole.y}, result.position, result.axis,
                                           obliqueRimSearch(result.flange.r_vertical), own_rim_);
  // A rim measureObliqueRim() judged is searched again only where its own pose supports it and a
  // pose turned off the line of sight supports it more (probes: a whole search costs ~2 ms at
  // 640x480), and a rim off the axis about the same bore replaces it on a smaller margin: the
  // circle lies within the reach of the ellipse's samples. (Where it searched a rim its own pose did
  // not support and took none, a rib ring inside the rim can keep more: packed_oblique seed 43 #86
  // at 640x480.)
  if (rim_measured && !dropped &&
      !(own_measured && own_rim_.support >= kObliqueRimSupport &&
        turnedPoseSupportsMore(image, format, geometry, hole, result.position, result.flange.r_vertical,
                               own_rim_.support)))
    return false;
  const double least =
      own_measured
          ? std::max(kWeakMatchRimSupport, own_rim_.support + (rim_measured ? kMeasuredRimMargin : kObliqueRimMargin))
          : kWeakMatchRimSupport;
  // No rim has more than all of its samples.
  if (least > 1.0)
    return false;
  if (!searchRimAbout(image, format, geometry, hole, kBoreRimFallbackPoses) || oblique_rim_.support < least ||
      !boreAgreesWith(hole, oblique_rim_) || !geometry.atPullerLevel(oblique_rim_.rim, hole.y) ||
      !(dropped || offAxis(oblique_rim_.axis)))
    return false;
  takeSpoolAboutBore(geometry, hole, result);
  return true;
}

bool SpoolDetector::turnedPoseSupportsMore(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                                           const Circle& hole, const cv::Point3d& position, double flange_px,
                                           double support)
{
  const double line_of_sight = std::atan2(position.x, position.z);
  for (const double turn : kWeakCircleProbeTurns)
    for (const double side : {-1.0, 1.0})
    {
      const double yaw = line_of_sight + side * turn;
      if (rim_pose_search_.measure(image, format, geometry, {hole.x, hole.y}, position,
                                   cv::Vec3d(std::sin(yaw), 0.0, std::cos(yaw)), obliqueRimSearch(flange_px),
                                   probe_rim_) &&
          probe_rim_.support > support)
        return true;
    }
  return false;
}

bool SpoolDetector::smallerBoreRim(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                                   const HoughSearch& hole_search, const SpoolDetection& result, double least,
                                   Circle& hole)
{
  // A circle around an oblique rim and its back flange's silhouette is too large, and the hole
  // measured at the size it gives is too: the bore's own rim is sought at smaller sizes about it.
  const double expected = matcher_.holeRadius(result.flange);
  const Circle* best =
      bestBoreAbout(result.hole, expected, hole_search, std::max(hole_search.r_min, kSmallerBoreRatio * expected),
                    std::min(hole_search.r_max, kInnerRingRatio * expected));
  if (!best || !wholeBoreRim(*best) ||
      signedBoreContrast({best->x, best->y}, best->r) < params_.matcher.bore_contrast ||
      !searchRimAbout(image, format, geometry, *best, 0) || oblique_rim_.support < least ||
      !boreAgreesWith(*best, oblique_rim_))
    return false;
  hole = *best;
  return true;
}

const Circle* SpoolDetector::bestBoreAbout(const Circle& hole, double expected, const HoughSearch& hole_search,
                                           double r_min, double r_max)
{
  // The bore's centre may lie up to the size the flange gives it away from the hole's.
  const double margin = std::max(2.0, expected);
  HoughSearch own = hole_search;
  own.center_window = cv::Rect2d(hole.x - margin, hole.y - margin, 2.0 * margin, 2.0 * margin);
  own.r_min = r_min;
  own.r_max = r_max;
  if (own.r_min >= own.r_max)
    return nullptr;
  extractHoleEdges(cv::Rect2d(hole.x, hole.y, 0.0, 0.0), margin + own.r_max + 2.0);
  hole_hough_.detect(hole_edges_, preprocessed_.size(), own, own_bores_);
  const auto best = std::max_element(own_bores_.begin(), own_bores_.end(),
                                     [](const Circle& a, const Circle& b) { return a.score < b.score; });
  return best == own_bores_.end() ? nullptr : &*best;
}

bool SpoolDetector::wholeBoreRim(const Circle& hole, double min_radius)
{
  return hole.r >= min_radius && hole.visible_fraction >= ConcentricMatcher::kMinHoleVisibleFraction;
}

bool SpoolDetector::searchRimAbout(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                                   const Circle& bore, std::size_t fallback, std::optional<double> axis_yaw,
                                   bool in_view_retry)
{
  // The depth its size gives, and the flange's size there.
  const GeometryParams& gp = params_.geometry;
  const double flange_px = bore.r * gp.flange_diameter / gp.hole_diameter;
  const double depth = geometry.depthFromDiameter(2.0 * flange_px);
  const double nearest = std::max(gp.distance_min, kObliqueBoreNearest * depth);
  const double farthest = std::min(gp.distance_max, kObliqueBoreFarthest * depth);
  if (!axis_yaw)
    return rim_pose_search_.search(image, format, geometry, {bore.x, bore.y}, nearest, farthest,
                                   obliqueRimSearch(flange_px), oblique_rim_, fallback, in_view_retry);
  // Its rim's extent in the image from the pose: seen beyond 37 deg off its axis the moving
  // edges' ellipse fit falls back to a circle (fitRimModel()).
  if (!rim_pose_search_.searchAbout(image, format, geometry, {bore.x, bore.y}, nearest, farthest,
                                    obliqueRimSearch(flange_px), *axis_yaw, kNeighbourAxisSpread, oblique_rim_,
                                    fallback))
    return false;
  oblique_rim_.rim = rimSeenAt(oblique_rim_);
  return true;
}

RimSearch SpoolDetector::obliqueRimSearch(double flange_px) const
{
  // The poses tried are a few % apart in size and 10 deg in axis: the reach covers half of that.
  return rimSearch(std::max(kObliqueRimReachPx, kObliqueRimReach * flange_px));
}

bool SpoolDetector::boreAgreesWith(const Circle& hole, const RimPoseFit& fit) const
{
  const double seen = (hole.r_vertical > 0.0 ? hole.r_vertical : hole.r) / matcher_.holeRadius(fit.rim);
  // Seen far off its axis, a dark bore's opening narrows by the cosine of the angle, and its
  // circle comes out between the two semi-axes.
  const cv::Vec3d sight = cv::normalize(cv::Vec3d(fit.position.x, fit.position.y, fit.position.z));
  const double narrowing = std::isfinite(fit.axis[0]) ? std::abs(sight.dot(fit.axis)) : 1.0;
  return seen <= 1.0 + kObliqueBoreAgreement && seen >= (1.0 - kObliqueBoreAgreement) * narrowing;
}

void SpoolDetector::takeObliqueRim()
{
  // The frame's edges on the search's rim are placed where the light crosses half-way and are
  // many; the moving edges, one per sample, only where too few of those are on it.
  if (rim_.size() < kMinGatheredRim)
    rim_.assign(oblique_rim_.edges.begin(), oblique_rim_.edges.end());
}

void SpoolDetector::takeSpoolAboutBore(const SpoolGeometry& geometry, const Circle& hole, SpoolDetection& result)
{
  result.flange = oblique_rim_.rim;
  result.hole = hole;
  keepSearchedPose();
  gatherRim(result, params_.hough.flange_polarity);
  takeObliqueRim();
  geometry.measure(result, rim_);
}

void SpoolDetector::keepSearchedPose()
{
  searched_pose_ = SearchedPose{oblique_rim_.rim, oblique_rim_.position, oblique_rim_.axis};
}

bool SpoolDetector::sameCircle(const Circle& a, const Circle& b)
{
  return a.x == b.x && a.y == b.y && a.r == b.r && a.r_vertical == b.r_vertical;
}

bool SpoolDetector::searchedPoseSupportsMore(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                                             SpoolDetection& result, bool outermost_rim, const SearchedPose* ring_pose,
                                             bool* beyond_view)
{
  if (!result.hole_detected)
    return false;
  const bool has_axis = std::isfinite(result.axis[2]);
  const bool searched = has_axis && searched_pose_ && sameCircle(searched_pose_->flange, result.flange);
  // Both poses' rims measured alike: by moving edges from the pose, the support of its 3-D fit
  // about the hole. A flange no rim search found may be half cut by the frame near the camera:
  // its rims are sampled as densely in view as a whole rim, and the search below retried so
  // (without, oblique seed 89 #54 and 131 #39 at 640x480 kept poses 21 and 43 deg off; for a
  // searched flange, 7 of the 12 poses it changed on the oblique sets at 640x480 came out worse).
  RimSearch search = obliqueRimSearch(result.flange.r_vertical);
  search.samples_in_view = !searched;
  const cv::Point2d bore(result.hole.x, result.hole.y);
  const double own = has_axis && rim_pose_search_.measure(image, format, geometry, bore, result.position, result.axis,
                                                          search, own_rim_)
                         ? own_rim_.support
                         : 0.0;
  // The bore's own shape is a second witness of the axis (oblique seed 89 #42 at 640x480: a round
  // circle's pose 13 deg off the line of sight keeps 0.53 of its rim, its depth 10% short; the
  // bore's rim bears out 40 deg, the truth's 39). Not where the lit lens shows through the bore
  // and agrees with it (measureBoreParallax()): the line of sight is then within atan(36/200) = 10
  // deg of the axis, and the lens's own rim narrows the bore's edges (15-30 deg read on the main
  // set's frames 3-6 deg off). A pose without an axis is fitted from the ellipse's aspect
  // (SpoolGeometry::measureFromAspect), which puts the depth nearer than the searched pose does
  // (1.7% and 0.6% off on oblique seed 131 #42 at 1280x720): it is searched again only on the
  // bore's word.
  const cv::Vec3d sight = cv::normalize(cv::Vec3d(result.position.x, result.position.y, result.position.z));
  auto view_angle = [&](const cv::Vec3d& axis) { return std::acos(std::min(1.0, std::abs(sight.dot(axis)))); };
  const double pose_angle = has_axis              ? view_angle(result.axis)
                            : oval(result.flange) ? std::acos(result.flange.r_horizontal / result.flange.r_vertical)
                                                  : 0.0;
  const double bore_angle = searched || result.parallax_measured ? std::numeric_limits<double>::quiet_NaN()
                                                                 : boreViewBeyond(result.hole, pose_angle);
  const bool bore_oblique = std::isfinite(bore_angle);
  if (!has_axis && !bore_oblique)
    return false;
  // A flange found otherwise (a circle of either polarity about the bore) had its pose fitted
  // from a start its circle gave (frontal for a round one) on the edges gathered about it: where
  // that pose's rim keeps under kObliqueRimSupport, the rim is searched about the bore, as
  // measureObliqueRim() does before the spool is judged (oblique seed 19 #13 at 640x480: a round
  // circle, its pose 21 deg off the axis; the search's 1.7 deg).
  // An inner ring's pose taken before, where given, stands for the search about the bore.
  if (ring_pose)
  {
    oblique_rim_.position = ring_pose->position;
    oblique_rim_.axis = ring_pose->axis;
  }
  else if (!searched &&
           ((own >= kObliqueRimSupport && !bore_oblique) ||
            !searchRimAbout(image, format, geometry, result.hole, kBoreRimFallbackPoses, std::nullopt, true) ||
            !boreAgreesWith(result.hole, oblique_rim_)))
    return false;
  const cv::Point3d& position = searched ? searched_pose_->position : oblique_rim_.position;
  const cv::Vec3d& axis = searched ? searched_pose_->axis : oblique_rim_.axis;
  // The search fitted the rim's centre within kBoreOffCentre of the bore it searched about, which
  // may have been measured again since: where the searched pose's rim keeps no fit about the hole,
  // it is measured about the centre it projects to (oblique seed 19 #94 at 640x480: 8 px apart;
  // reported now, 1.5 deg off the axis against 25). Not in every case: the searched poses
  // reported then came out 1-2 deg worse (FailureKinds.AnObliqueSpoolIsReportedAtThePoseItsRimWasFoundAt).
  if (!(rim_pose_search_.measure(image, format, geometry, bore, position, axis, search, probe_rim_) ||
        rim_pose_search_.measure(image, format, geometry, geometry.project(position), position, axis, search,
                                 probe_rim_)))
    return false;
  const double eq32_depth = geometry.depthFromDiameter(2.0 * result.flange.r_vertical);
  const bool supported =
      bore_oblique ? probe_rim_.support >= own - kBoreViewMargin &&
                         std::abs(view_angle(probe_rim_.axis) - bore_angle) < std::abs(pose_angle - bore_angle)
                   : probe_rim_.support >= own + kMeasuredRimMargin;
  if (outermost_rim && !searched)
    scaleToOutermostRim(image, format, geometry, bore, search, result.flange);
  const Circle seen = rimSeenAt(probe_rim_);
  const bool depth_agrees = has_axis || std::abs(probe_rim_.position.z / eq32_depth - 1.0) <= kBoreViewDepthAgreement;
  // A searched rim higher than the outermost one found is the flange outside it, missed by the
  // window's search where the frame or the puller rod cuts it (packed_oblique seed 189 #103 at
  // 640x480: a rib ring 0.85 of the flange was reported 18% too far, the searched rim 1.6% off).
  const bool height_agrees =
      !outermost_rim || searched || seen.r_vertical / result.flange.r_vertical >= 1.0 - kOutermostRimHeight;
  // A spool seen 42-56 deg off its axis shows its front and back flanges and the hub between as
  // one outline; a circle about the bore through its far side is 1.2-1.6 times the front rim's
  // height, round, and 20-35% short in depth. The rim searched about that bore finds the spool
  // where it is (packed_oblique seed 185 #83 at 640x480: 48.7 deg off, 0.878 m for the truth's
  // 0.869; the circle's Eq. 3.2 0.596 m). On 24 rendered sets, every other rim found about a
  // reported flange's bore beyond 40 deg was within 8% of Eq. 3.2's depth on that flange.
  if (beyond_view)
    *beyond_view =
        supported && !searched && !outermost_rim && !ring_pose &&
        SpoolGeometry::viewAngle(probe_rim_.position, probe_rim_.axis) > SpoolGeometry::kMaxMeasuredViewAngle &&
        std::abs(probe_rim_.position.z / eq32_depth - 1.0) > SpoolGeometry::kMaxDepthDisagreement;
  // The flange is the outermost rim: a searched rim higher than the flange circle is the rim outside
  // that circle, and its own height gives Eq. 3.2's depth (oblique seed 131 #80 at 320x240: a round
  // rib ring 0.81 of the flange reported 19% too far; the rim searched about its bore 1.22 times
  // as high, 1.1% off, beyond 15% of the ring's depth).
  const double outer_eq32_depth = geometry.depthFromDiameter(2.0 * std::max(result.flange.r_vertical, seen.r_vertical));
  if (!supported || !depth_agrees || !height_agrees ||
      !SpoolGeometry::plausiblePose(probe_rim_.position, probe_rim_.axis, outer_eq32_depth))
    return false;
  result.position = probe_rim_.position;
  result.axis = probe_rim_.axis;
  // The flange is reported where that pose puts its rim: the round circle it was found as lay a
  // quarter of its size off the rim's centre and 17% too large (oblique seed 89 #42 at 640x480).
  // Its score stays the evidence the spool was taken on.
  if (!searched)
  {
    result.flange.x = seen.x;
    result.flange.y = seen.y;
    result.flange.r = seen.r;
    result.flange.r_horizontal = seen.r_horizontal;
    result.flange.r_vertical = seen.r_vertical;
  }
  geometry.moveBoreCentre(result);
  return true;
}

void SpoolDetector::scaleToOutermostRim(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                                        const cv::Point2d& bore, const RimSearch& search, const Circle& outermost)
{
  const double ratio = rimSeenAt(probe_rim_).r_vertical / outermost.r_vertical;
  if (ratio >= 1.0 - kOutermostRimHeight)
    return;
  // A concentric ring of the same face, seen at the same axis: the scene scaled about the camera
  // by `ratio` gives the outer rim the ring's image scaled by 1 / ratio.
  if (rim_pose_search_.measure(image, format, geometry, bore, probe_rim_.position * ratio, probe_rim_.axis, search,
                               scaled_rim_))
    std::swap(probe_rim_, scaled_rim_);
}

double SpoolDetector::boreViewBeyond(const Circle& hole, double pose_angle)
{
  constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  const double height = hole.r_vertical > 0.0 ? hole.r_vertical : hole.r;
  if (height < kMinKnownSizeRadius)
    return kNone;
  const double shift = std::max(1.0, kBoreViewShift * height);
  extractBoreEdges(hole, height + shift + std::max(0.75, 0.04 * height) + 2.0);
  HoughSearch search;
  search.polarity = params_.hough.hole_polarity;
  auto density = [&](double angle)
  {
    return hole_hough_.shapeDensity(hole_edges_, search, {hole.x, hole.y}, {std::cos(angle) * height, height, 0.0},
                                    shift);
  };
  const double at_pose = density(pose_angle);
  double best = -1.0;
  double best_angle = 0.0;
  const int steps = static_cast<int>(std::floor((kBoreViewMax - pose_angle - kBoreViewGap) / kBoreViewStep + 1e-9));
  for (int k = 0; k <= steps; ++k)
  {
    const double angle = pose_angle + kBoreViewGap + k * kBoreViewStep;
    const double d = density(angle);
    if (best < 0.0 && d < kBoreViewEarly * at_pose)
      return kNone;
    if (d > best)
    {
      best = d;
      best_angle = angle;
    }
  }
  return best > 0.0 && best >= kBoreViewRatio * at_pose ? best_angle : kNone;
}

bool SpoolDetector::searchEitherPolarity(const cv::Point2d& reference, const HoughSearch& flange_search,
                                         const HoughSearch& hole_search, double cost, SpoolDetection& result)
{
  // Either polarity admits ghosts (shelf boards and neighbours' arcs closing a circle around a
  // real rim, weak rings in clutter): those enclosing a solid rim go, and a spool needs a hole
  // rim with kRetryHoleScore of its support.
  HoughSearch either = flange_search;
  either.polarity = Polarity::kAny;
  HoughSearch strict = hole_search;
  strict.min_score = std::max(hole_search.min_score, kRetryHoleScore);
  const cv::Rect2d centres =
      std::isfinite(cost) ? centresCostingLess(reference, flange_search, hole_search, cost) : cv::Rect2d();
  // Copies, not swaps: each buffer keeps its role and so its grown capacity (no allocation in
  // the steady state whichever search wins).
  first_holes_ = holes_;
  first_flanges_ = flanges_;
  flange_hough_.detectEitherPolarity(edges_, preprocessed_.size(), flange_search, centres, flanges_);
  ConcentricMatcher::dropEnclosingGhosts(flanges_, first_flanges_);
  SpoolDetection second;
  if (selectTarget(reference, either, strict, SpoolEvidence::kHole, cost, second) < cost)
  {
    result = second;
    return true;
  }
  holes_ = first_holes_;
  return false;
}

cv::Rect2d SpoolDetector::centresCostingLess(const cv::Point2d& reference, const HoughSearch& flange_search,
                                             const HoughSearch& hole_search, double cost) const
{
  // A flange's hole lies within its hole window, whose reach is widest for the largest flange.
  Circle largest;
  largest.x = reference.x;
  largest.y = reference.y;
  largest.r = largest.r_vertical = flange_search.r_max;
  HoughSearch window = hole_search;
  matcher_.narrowHoleSearch(largest, preprocessed_.size(), window);
  const double reach = cost + std::max(window.center_window.width, window.center_window.height);
  return {reference.x - reach, reference.y - reach, 2.0 * reach, 2.0 * reach};
}

bool SpoolDetector::searchNearer(const cv::Point2d& reference, const HoughSearch& flange_search,
                                 const HoughSearch& hole_search, double& cost, SpoolDetection& result)
{
  // Where a rim borders other dark flanges all round (touching neighbours, a back row behind the
  // gaps) only its arcs against the wall and the boards have edges: it scores under the least
  // support, and a spool farther off is taken. Sought again where a spool could cost less, with
  // less rim support asked; such a weak rim is a spool only with a hole rim of kNearerHoleScore
  // and (nearly) all of it in the frame (arcs of the boards and of a neighbour cut by the border
  // closed a ghost of 0.31 about a wall mark: packed seed 13 #19). The first search's votes are
  // measured again where such a spool's centre can lie.
  HoughSearch relaxed = flange_search;
  relaxed.min_score = std::min(relaxed.min_score, 1.0 - kNearerSensitivity);
  HoughSearch strict = hole_search;
  strict.min_score = std::max(hole_search.min_score, kNearerHoleScore);
  first_holes_ = holes_;
  first_flanges_ = flanges_;
  flange_hough_.detectAgain(edges_, preprocessed_.size(), relaxed,
                            centresCostingLess(reference, flange_search, hole_search, cost), flanges_);
  SpoolDetection second;
  const double second_cost = selectTarget(reference, flange_search, strict, SpoolEvidence::kHole, cost, second);
  if (second_cost < cost && second.flange.visible_fraction >= ConcentricMatcher::kMinHoleVisibleFraction)
  {
    result = second;
    cost = second_cost;
    return true;
  }
  holes_ = first_holes_;
  nearer_flanges_.swap(flanges_);
  flanges_ = first_flanges_;
  return false;
}

void SpoolDetector::gatherRim(const SpoolDetection& result, Polarity polarity)
{
  rim_.clear();
  if (!result.hole_detected)
    return;
  // Edges within a few px of the flange's ellipse whose gradient points outwards (the face is
  // darker than what lies around it; with any polarity, either way).
  const Circle& f = result.flange;
  const double semi_x = f.r_horizontal > 0.0 ? f.r_horizontal : f.r;
  const double semi_y = f.r_vertical > 0.0 ? f.r_vertical : f.r;
  const double band = std::max(3.0, 0.02 * semi_y);
  const bool either = polarity != Polarity::kDark;
  for (const EdgePoint& e : edges_)
  {
    const double vx = (e.x - f.x) / semi_x;
    const double vy = (e.y - f.y) / semi_y;
    const double rho = std::sqrt(vx * vx + vy * vy);
    if (std::abs(rho - 1.0) * semi_y > band || rho == 0.0)
      continue;
    const double outward = (e.dx * vx + e.dy * vy) / rho;
    if (either ? std::abs(outward) > 0.8 : outward > 0.8)
      rim_.emplace_back(e.x, e.y);
  }
}

template <typename Move>
void SpoolDetector::movePixelCentres(SpoolDetection& result, Move move)
{
  auto moved = [&move](double& x, double& y)
  {
    const cv::Point2d p = move(cv::Point2d(x, y));
    x = p.x;
    y = p.y;
  };
  moved(result.reference.x, result.reference.y);
  if (result.detected)
    moved(result.flange.x, result.flange.y);
  if (result.hole_detected)
    moved(result.hole.x, result.hole.y);
  if (result.lens_detected)
    moved(result.lens.x, result.lens.y);
  if (result.parallax_measured)
    moved(result.lens_centroid.x, result.lens_centroid.y);
}

void SpoolDetector::toFramePixels(const CameraIntrinsics& camera, SpoolDetection& result)
{
  if (camera.distorted())
    movePixelCentres(result, [&camera](const cv::Point2d& p) { return distortPixel(camera, p); });
}

void SpoolDetector::toUndistortedPixels(const CameraIntrinsics& camera, SpoolDetection& result)
{
  if (camera.distorted())
    movePixelCentres(result, [&camera](const cv::Point2d& p) { return undistortPixel(camera, p); });
}

bool SpoolDetector::takesSecondSearch(const SpoolDetection& second) const
{
  if (!second.hole_detected)
    return false;
  const bool solid = second.flange.score >= ConcentricMatcher::kSolidRimScore &&
                     second.hole.score >= ConcentricMatcher::kSolidRimScore;
  const bool sharp_bore = second.hole.r >= kSecondSearchBoreRadius && second.hole.score >= kSecondSearchBoreScore &&
                          second.flange.score >= kSecondSearchRimScore;
  const bool agreeing_bore = bore_agrees_at_own_size_ && second.flange.score >= kSecondSearchRimScore;
  return solid || sharp_bore || agreeing_bore || weak_match_rim_taken_ || small_bore_spool_taken_;
}

std::size_t SpoolDetector::edgeBudget(cv::Size size) const
{
  const double scale = search_.second ? kRetryBudgetScale : 1.0;
  return static_cast<std::size_t>(scale * params_.hough.edge_budget * (size.width + size.height));
}

void SpoolDetector::extractHoleEdges(const cv::Rect2d& centres, double reach, const LinearLight* linear)
{
  const cv::Rect window(cvFloor(centres.x - reach), cvFloor(centres.y - reach), cvCeil(centres.width + 2.0 * reach) + 1,
                        cvCeil(centres.height + 2.0 * reach) + 1);
  edge_detector_.extract(params_.hough.hole_edge_threshold, window, edgeBudget(window.size()), hole_edges_, linear);
}

namespace
{
// Reports `flange` (and `hole`) as the detection. Both rims: confidence 0.5 and up with the
// weaker's support; the flange alone: at most 0.5.
void takeSpool(const Circle& flange, const std::optional<Circle>& hole, SpoolDetection& result)
{
  result.detected = true;
  result.flange = flange;
  result.confidence = hole ? 0.5 + 0.5 * std::min(flange.score, hole->score) : 0.5 * flange.score;
  result.hole_detected = hole.has_value();
  if (hole)
    result.hole = *hole;
}

// `circles` nearest `point` first (px).
void orderByDistanceTo(const cv::Point2d& point, std::vector<Circle>& circles)
{
  std::sort(circles.begin(), circles.end(),
            [&](const Circle& a, const Circle& b)
            { return std::hypot(a.x - point.x, a.y - point.y) < std::hypot(b.x - point.x, b.y - point.y); });
}
}  // namespace

bool SpoolDetector::obliqueSpool(const cv::Mat& image, PixelFormat format, const cv::Point2d& reference,
                                 const std::vector<Circle>& flanges, const HoughSearch& hole_search, double bound,
                                 bool bore_led, SpoolDetection& result)
{
  if (params_.matcher.mode != MatchMode::kMcht || params_.hough.hole_polarity == Polarity::kBright)
    return false;
  // A spool already taken keeps its hole candidates unless this one replaces it.
  const bool replacing = std::isfinite(bound);
  if (replacing)
    std::swap(holes_, target_holes_);
  ConcentricMatcher::orderByReference(flanges, reference, candidate_order_);
  // The candidates' own windows first, then beside them: a bore beside the first one's window must
  // not pass over a sharp bore in the second one's (oblique seed 159 #27 of 50 at 320x240).
  for (const bool beside : {false, true})
  {
    int tried = 0;
    for (const std::size_t i : candidate_order_)
    {
      const Circle flange = flanges[i];
      if (flange.r_vertical < kObliqueRimMinRadius)
        continue;
      // Only another spool, nearer the reference than the one taken, can replace it.
      if (ConcentricMatcher::targetCost({flange.x, flange.y}, flange.score, reference) >= bound)
        break;
      if (replacing && std::hypot(flange.x - result.flange.x, flange.y - result.flange.y) < result.flange.r)
        continue;
      if (tried++ == kObliqueCandidates)
        break;
      HoughSearch holes = hole_search;
      const double shift = kObliqueBoreShift * flange.r_vertical;
      const cv::Rect2d near_centre(flange.x - shift, flange.y - shift, 2.0 * shift, 2.0 * shift);
      holes.center_window = near_centre;
      const double expected = matcher_.holeRadius(flange);
      holes.r_min = std::max(hole_search.r_min, 0.5 * expected);
      holes.r_max = std::min(hole_search.r_max, 1.2 * expected);
      if (holes.r_min >= holes.r_max)
        continue;
      if (beside)
      {
        if (besideSilhouette(image, format, reference, flange, near_centre, holes, bound, result))
          return true;
        continue;
      }
      extractHoleEdges(holes.center_window, holes.r_max + 2.0);
      detectHoles(holes);
      if (spoolAboutHoles(image, format, reference, bound, kMinKnownSizeRadius, kObliqueHoles, result))
        return true;
      // A spool nearer the reference than the one taken, its bore too small to measure (160x120:
      // oblique seed 109 #151, #297, a neighbour reported where the target's 4 px bore was plain):
      // sought about the nearest sharp bore as smallBoreSpool() does, the candidate's larger bores
      // standing for the lens test.
      if (replacing && holes.r_min < kMinKnownSizeRadius)
      {
        larger_bores_.clear();
        std::copy_if(holes_.begin(), holes_.end(), std::back_inserter(larger_bores_),
                     [](const Circle& bore) { return bore.r >= kMinKnownSizeRadius; });
        keepBoresOutside(kMinKnownSizeRadius, kSharpHoleScore);
        orderByDistanceTo(reference, holes_);
        if (spoolAboutHoles(image, format, reference, bound, hole_search.r_min, kBoreLedHoles, result))
          return true;
      }
    }
  }
  if (!replacing && bore_led)
  {
    // No flange circle led to the spool (none among the candidates, or its circle a third of its
    // size off the bore): the bores nearest the reference lead to it instead, over the rows where a
    // spool's axis can be at the puller's level (atPullerLevel() at distance_min..distance_max)
    // and at sizes whose rim can be measured (wholeBoreRim()): fewer accumulator cells. Then the
    // bores too small for that about the nearest candidates (smallBoreSpool()).
    const auto [top, bottom] = geometry_->pullerLevelRows();
    const cv::Rect2d rows = cv::Rect2d(0.0, top, preprocessed_.cols, bottom - top) &
                            cv::Rect2d(0.0, 0.0, preprocessed_.cols, preprocessed_.rows);
    HoughSearch holes = hole_search;
    holes.r_min = std::max(hole_search.r_min, kMinKnownSizeRadius);
    holes.center_window = rows;
    if (holes.r_min < holes.r_max && !holes.center_window.empty())
    {
      extractHoleEdges(holes.center_window, holes.r_max + 2.0);
      detectHoles(holes);
      orderByDistanceTo(reference, holes_);
      if (spoolAboutHoles(image, format, reference, bound, kMinKnownSizeRadius, kBoreLedHoles, result))
        return true;
    }
    if (smallBoreSpool(image, format, reference, flanges, hole_search, rows, result))
      return true;
  }
  if (replacing)
    std::swap(holes_, target_holes_);
  else
    holes_.clear();  // no target: its hole candidates are none
  return false;
}

bool SpoolDetector::besideSilhouette(const cv::Mat& image, PixelFormat format, const cv::Point2d& reference,
                                     const Circle& flange, const cv::Rect2d& searched, HoughSearch& holes, double bound,
                                     SpoolDetection& result)
{
  // The joint silhouette's circle lies between the two flanges' centres, the back one's
  // hub_length * sin(view) / (flange_diameter / 2) = 0.73 of the flange's height aside at 40 deg:
  // the front bore can be farther aside than the window searched (0.36 of it on oblique seed 47
  // #10 at 1280x720, 0.51 on seed 131 #3), in the rows the circle gives it.
  // Only bores whose rim can be searched about (spoolAboutHoles()' least) are sought.
  holes.r_min = std::max(holes.r_min, kMinKnownSizeRadius);
  if (holes.r_min >= holes.r_max)
    return false;
  const double aside = kSilhouetteBoreShift * flange.r_vertical;
  holes.center_window = cv::Rect2d(flange.x - aside, searched.y, 2.0 * aside, searched.height);
  extractHoleEdges(holes.center_window, holes.r_max + 2.0);
  detectHoles(holes);
  // Only the bores beside the window searched, on their rims alone: out there a weak ring with a
  // dark disc is as often off the bore or a neighbour's (oblique seed 131 #11 at 1280x720: a rim
  // 1.75 times the flange was then taken about a rib ring; seed 97 #18 at 320x240: a neighbour).
  const double least = params_.matcher.weak_hole_score;
  holes_.erase(std::remove_if(holes_.begin(), holes_.end(),
                              [&](const Circle& hole) {
                                return searched.contains({hole.x, hole.y}) || hole.score < least;
                              }),
               holes_.end());
  return spoolAboutHoles(image, format, reference, bound, kMinKnownSizeRadius, kObliqueHoles, result);
}

bool SpoolDetector::smallBoreSpool(const cv::Mat& image, PixelFormat format, const cv::Point2d& reference,
                                   const std::vector<Circle>& flanges, const HoughSearch& hole_search,
                                   const cv::Rect2d& rows, SpoolDetection& result)
{
  HoughSearch holes = hole_search;
  holes.r_max = std::min(hole_search.r_max, kMinKnownSizeRadius);
  if (holes.r_min >= holes.r_max)
    return false;
  // The bores of measurable size just searched: a ring inside one of them is its lit lens.
  larger_bores_ = holes_;
  int tried = 0;
  for (const std::size_t i : candidate_order_)
  {
    if (tried++ == kObliqueCandidates)
      break;
    const Circle& flange = flanges[i];
    const double shift = kObliqueBoreShift * flange.r_vertical;
    holes.center_window = cv::Rect2d(flange.x - shift, flange.y - shift, 2.0 * shift, 2.0 * shift) & rows;
    if (holes.center_window.empty())
      continue;
    extractHoleEdges(holes.center_window, holes.r_max + 2.0);
    detectHoles(holes);
    keepBoresOutside(std::numeric_limits<double>::infinity(), params_.matcher.weak_hole_score);
    orderByDistanceTo(reference, holes_);
    if (spoolAboutHoles(image, format, reference, kNoMatch, hole_search.r_min, kBoreLedHoles, result))
    {
      small_bore_spool_taken_ = true;
      return true;
    }
  }
  return false;
}

void SpoolDetector::keepBoresOutside(double below, double least)
{
  // Only rims scoring `least`: a fainter ring that small is any dark speck of the face (oblique seed
  // 103 #109: a neighbour's rim about one, where the target was not found).
  holes_.erase(std::remove_if(holes_.begin(), holes_.end(),
                              [&](const Circle& hole)
                              {
                                return !(hole.r < below) || hole.score < least ||
                                       std::any_of(
                                           larger_bores_.begin(), larger_bores_.end(),
                                           [&](const Circle& bore)
                                           { return std::hypot(bore.x - hole.x, bore.y - hole.y) + hole.r <= bore.r; });
                              }),
               holes_.end());
}

Circle SpoolDetector::rimSeenAt(const RimPoseFit& fit) const
{
  // The flange's circle at the fitted pose, its extent in the image (undistorted px).
  const CameraIntrinsics& camera = geometry_->camera();
  const cv::Vec3d centre(fit.position.x, fit.position.y, fit.position.z);
  cv::Vec3d across = fit.axis.cross(cv::Vec3d(0.0, 1.0, 0.0));
  across = cv::norm(across) > 1e-9 ? cv::normalize(across) : cv::Vec3d(1.0, 0.0, 0.0);
  const cv::Vec3d up = cv::normalize(fit.axis.cross(across));
  const double radius = 0.5 * params_.geometry.flange_diameter;
  cv::Point2d low(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity());
  cv::Point2d high = -low;
  for (int k = 0; k < kRimExtentPoints; ++k)
  {
    const double t = 2.0 * M_PI * k / kRimExtentPoints;
    const cv::Vec3d p = centre + radius * (std::cos(t) * across + std::sin(t) * up);
    const cv::Point2d px(camera.fx * p[0] / p[2] + camera.cx, camera.fy * p[1] / p[2] + camera.cy);
    low = {std::min(low.x, px.x), std::min(low.y, px.y)};
    high = {std::max(high.x, px.x), std::max(high.y, px.y)};
  }
  Circle rim = fit.rim;
  rim.x = 0.5 * (low.x + high.x);
  rim.y = 0.5 * (low.y + high.y);
  rim.r_horizontal = 0.5 * (high.x - low.x);
  rim.r_vertical = 0.5 * (high.y - low.y);
  rim.r = 0.5 * (rim.r_horizontal + rim.r_vertical);
  return rim;
}

double SpoolDetector::columnWidening(double x, double axis_yaw) const
{
  const CameraIntrinsics& camera = geometry_->camera();
  const double view = std::atan((x - camera.cx) / camera.fx) - axis_yaw;
  return 1.0 / std::max(std::cos(view), std::cos(RimPoseSearch::kWidestViewAngle));
}

double SpoolDetector::stretchedColumn(double x) const
{
  const int cols = static_cast<int>(stretched_columns_.size()) - 1;
  const double inside = std::clamp(x, 0.0, cols - 1e-6);
  const int i = static_cast<int>(inside);
  return stretched_columns_[i] + (inside - i) * (stretched_columns_[i + 1] - stretched_columns_[i]) + (x - inside);
}

cv::Size SpoolDetector::stretchEdges(const std::vector<EdgePoint>& edges, double axis_yaw)
{
  const int cols = preprocessed_.cols;
  stretched_columns_.resize(static_cast<std::size_t>(cols) + 1);
  stretched_columns_[0] = 0.0;
  for (int x = 0; x < cols; ++x)
    stretched_columns_[x + 1] = stretched_columns_[x] + columnWidening(x + 0.5, axis_yaw);
  stretched_edges_.clear();
  for (const EdgePoint& e : edges)
  {
    const double dx = e.dx / columnWidening(e.x, axis_yaw);
    const double norm = std::hypot(dx, static_cast<double>(e.dy));
    if (norm > 0.0)
      stretched_edges_.push_back({static_cast<float>(stretchedColumn(e.x)), e.y, static_cast<float>(dx / norm),
                                  static_cast<float>(e.dy / norm)});
  }
  return {static_cast<int>(std::ceil(stretched_columns_[cols])), preprocessed_.rows};
}

cv::Rect2d SpoolDetector::stretchedWindow(const cv::Rect2d& window) const
{
  const double left = stretchedColumn(window.x);
  return {left, window.y, stretchedColumn(window.br().x) - left, window.height};
}

void SpoolDetector::unstretch(double axis_yaw, std::vector<Circle>& circles) const
{
  const int cols = static_cast<int>(stretched_columns_.size()) - 1;
  for (Circle& c : circles)
  {
    const auto column = std::upper_bound(stretched_columns_.begin(), stretched_columns_.end(), c.x);
    const int i = std::clamp(static_cast<int>(column - stretched_columns_.begin()) - 1, 0, cols - 1);
    c.x = i + (c.x - stretched_columns_[i]) / (stretched_columns_[i + 1] - stretched_columns_[i]);
    c.r_vertical = c.r_vertical > 0.0 ? c.r_vertical : c.r;
    c.r_horizontal = (c.r_horizontal > 0.0 ? c.r_horizontal : c.r) / columnWidening(c.x, axis_yaw);
    c.r = c.r_vertical;
  }
}

void SpoolDetector::detectTurnedBores(const HoughSearch& hole_search, double axis_yaw)
{
  // Seen far off its axis a bore is an ellipse as narrow as the cosine of the view. The columns
  // are stretched by its inverse, the view at each column taken about `axis_yaw`, so that the bore
  // votes as a circle there.
  const cv::Size size = stretchEdges(hole_edges_, axis_yaw);
  HoughSearch search = hole_search;
  search.center_window = stretchedWindow(hole_search.center_window);
  hole_hough_.detect(stretched_edges_, size, search, holes_);
  unstretch(axis_yaw, holes_);
}

bool SpoolDetector::nearerTurnedSpool(const cv::Mat& image, PixelFormat format, const cv::Point2d& reference,
                                      const HoughSearch& hole_search, SpoolDetection& result)
{
  if (params_.matcher.mode != MatchMode::kMcht || params_.hough.hole_polarity == Polarity::kBright ||
      hole_search.r_max < kTurnedBoreScale * kMinKnownSizeRadius)
    return false;
  // The neighbours' axis is the result's; where its pose gave none, either one its flange's
  // ellipse allows (as wide as the cosine of the view).
  std::array<double, 2> axis_yaws{};
  std::size_t axes = 0;
  const Circle& taken = result.flange;
  if (std::isfinite(result.axis[2]))
  {
    axis_yaws[axes++] = std::atan2(result.axis[0], result.axis[2]);
  }
  else if (taken.r_horizontal > 0.0 && taken.r_horizontal < taken.r_vertical)
  {
    const double view = std::acos(taken.r_horizontal / taken.r_vertical);
    const double sight = std::atan((result.hole.x - geometry_->camera().cx) / geometry_->camera().fx);
    if (view >= kObliqueAxisAngle)
      axis_yaws = {sight - view, sight + view}, axes = 2;
  }
  // The bores nearer the reference than the result's, at the puller's level and at sizes whose rim
  // can be measured.
  const double bound = std::hypot(result.hole.x - reference.x, result.hole.y - reference.y);
  HoughSearch holes = hole_search;
  holes.r_min = std::max(hole_search.r_min, kMinKnownSizeRadius);
  holes.center_window = nearerThan(reference, result);
  if (axes == 0 || holes.r_min >= holes.r_max || holes.center_window.empty())
    return false;
  std::swap(holes_, target_holes_);
  const cv::Point2d flange_centre(taken.x, taken.y);
  const double flange_radius = taken.r_vertical;
  for (std::size_t i = 0; i < axes; ++i)
  {
    // Each time: the rim searches about a bore measure it on hole_edges_ too.
    extractHoleEdges(holes.center_window, holes.r_max + 2.0);
    detectTurnedBores(holes, axis_yaws[i]);
    holes_.erase(std::remove_if(holes_.begin(), holes_.end(),
                                [&](const Circle& h)
                                {
                                  return std::hypot(h.x - reference.x, h.y - reference.y) >= bound ||
                                         std::hypot(h.x - flange_centre.x, h.y - flange_centre.y) < flange_radius;
                                }),
                 holes_.end());
    orderByDistanceTo(reference, holes_);
    if (spoolAboutHoles(image, format, reference, bound, kMinKnownSizeRadius, kTurnedHoles, result, axis_yaws[i]))
      return true;
  }
  std::swap(holes_, target_holes_);
  return false;
}

cv::Rect2d SpoolDetector::nearerThan(const cv::Point2d& reference, const SpoolDetection& result) const
{
  // Such a spool's centre lies outside the result's flange, on the reference's side of it.
  const Circle& taken = result.flange;
  const double bound = std::hypot(result.hole.x - reference.x, result.hole.y - reference.y);
  const auto [top, bottom] = geometry_->pullerLevelRows();
  const double half_width = taken.r_horizontal > 0.0 ? taken.r_horizontal : taken.r;
  double left = reference.x - bound;
  double right = reference.x + bound;
  if (taken.x > reference.x)
    right = std::min(right, taken.x - half_width);
  else
    left = std::max(left, taken.x + half_width);
  if (!(right > left))
    return {};
  return cv::Rect2d(left, top, right - left, bottom - top) &
         cv::Rect2d(0.0, 0.0, preprocessed_.cols, preprocessed_.rows);
}

bool SpoolDetector::nearerTurnedFlange(const cv::Mat& image, PixelFormat format, const cv::Point2d& reference,
                                       const HoughSearch& flange_search, SpoolDetection& result)
{
  if (params_.matcher.mode != MatchMode::kMcht || !std::isfinite(result.axis[2]) || edges_.empty())
    return false;
  // The shelf's spools stand with about parallel axes: about the result's, every flange's ellipse
  // is as narrow as the cosine of its own view, and the frame's edges stretched by its inverse
  // column by column round them all. Only where a spool at the reference is seen so far off its
  // axis that the circle search misses its ellipse.
  const CameraIntrinsics& camera = geometry_->camera();
  const double axis_yaw = std::atan2(result.axis[0], result.axis[2]);
  const cv::Rect2d centres = nearerThan(reference, result);
  if (centres.empty() || std::abs(std::atan((reference.x - camera.cx) / camera.fx) - axis_yaw) < kTurnedFlangeView)
    return false;
  // A spool of the same row: its size within kTurnedFlangeSizes of the result's. The edges that
  // can vote for a centre there.
  HoughSearch search = flange_search;
  search.r_min = std::max(flange_search.r_min, result.flange.r_vertical / kTurnedFlangeSizes);
  search.r_max = std::min(flange_search.r_max, result.flange.r_vertical * kTurnedFlangeSizes);
  if (search.r_min >= search.r_max)
    return false;
  const double reach = search.r_max / std::cos(RimPoseSearch::kWidestViewAngle);
  const cv::Rect2d voters(centres.x - reach, centres.y - search.r_max, centres.width + 2.0 * reach,
                          centres.height + 2.0 * search.r_max);
  near_edges_.clear();
  std::copy_if(edges_.begin(), edges_.end(), std::back_inserter(near_edges_),
               [&](const EdgePoint& e) { return voters.contains(cv::Point2d(e.x, e.y)); });
  const cv::Size size = stretchEdges(near_edges_, axis_yaw);
  search.center_window = stretchedWindow(centres);
  flange_hough_.detect(stretched_edges_, size, search, turned_flanges_);
  unstretch(axis_yaw, turned_flanges_);
  orderByDistanceTo(reference, turned_flanges_);
  const SpoolGeometry& geometry = *geometry_;
  const double bound = std::hypot(result.hole.x - reference.x, result.hole.y - reference.y);
  int tried = 0;
  for (const Circle& flange : turned_flanges_)
  {
    if (std::hypot(flange.x - reference.x, flange.y - reference.y) >= bound || tried++ == kTurnedFlanges)
      break;
    // Its rim about its centre: from Eq. 3.2's depth on its height (a level axis keeps the rim's
    // vertical extent) and the result's axis, as a neighbour's is sought about its bore.
    const cv::Point3d start =
        geometry.backProject(flange.x, flange.y, geometry.depthFromDiameter(2.0 * flange.r_vertical));
    RimPoseFit& fit = turned_rim_;
    if (!rim_pose_search_.searchAbout(image, format, geometry, {flange.x, flange.y}, kTurnedNearest * start.z,
                                      kTurnedFarthest * start.z, obliqueRimSearch(flange.r_vertical), axis_yaw,
                                      kNeighbourAxisSpread, fit, 0, kTurnedOffCentre) ||
        fit.support < kTurnedFlangeSupport || !SpoolGeometry::plausiblePose(fit.position, fit.axis, start.z))
      continue;
    // Its bore, where the pose puts it, shows dark (too small at 160x120 for its rim to be fitted).
    const cv::Size2d extent = geometry.boreExtent(fit.position, fit.axis);
    Circle hole;
    const cv::Point2d seen = geometry.project(fit.position);
    hole.x = seen.x;
    hole.y = seen.y;
    hole.r = hole.r_vertical = extent.height;
    hole.r_horizontal = extent.width;
    hole.score = 1.0 - params_.hough.hole_sensitivity;
    hole.visible_fraction = 1.0;
    const Circle rim = rimSeenAt(fit);
    if (!(extent.height > 0.0) || !geometry.atPullerLevel(rim, hole.y) ||
        signedBoreContrast({hole.x, hole.y}, hole.r, extent.width / extent.height) < params_.matcher.bore_contrast)
      continue;
    oblique_rim_ = fit;
    oblique_rim_.rim = rim;
    takeSpoolAboutBore(geometry, hole, result);
    measureBoreAtKnownSize(result, std::nullopt, result.axis, true);
    return true;
  }
  return false;
}

bool SpoolDetector::ringAboutLargeBore(const cv::Point2d& reference, const HoughSearch& hole_search,
                                       SpoolDetection& result)
{
  ConcentricMatcher::orderByReference(flanges_, reference, candidate_order_);
  int tried = 0;
  for (const std::size_t i : candidate_order_)
  {
    if (tried++ == kObliqueCandidates)
      break;
    const Circle& ring = flanges_[i];
    HoughSearch holes = hole_search;
    if (!matcher_.narrowHoleSearch(ring, preprocessed_.size(), holes))
      continue;
    // Beyond the sizes the match allows the ring, up to a bore kRibRingBoreMax times them.
    const double expected = matcher_.holeRadius(ring);
    holes.r_min =
        std::max({hole_search.r_min, (1.0 + params_.matcher.hole_ratio_tolerance) * expected, kMinKnownSizeRadius});
    holes.r_max = std::min(hole_search.r_max, kRibRingBoreMax * expected);
    if (holes.r_min >= holes.r_max)
      continue;
    extractHoleEdges(holes.center_window, holes.r_max + 2.0);
    detectHoles(holes);
    for (const Circle& bore : holes_)
    {
      // At the puller's level as the flange the bore's size gives sees it.
      Circle flange = ring;
      const double scale = bore.r / expected;
      flange.r *= scale;
      flange.r_vertical *= scale;
      if (bore.score >= kSharpBoreScore && wholeBoreRim(bore) && geometry_->atPullerLevel(flange, bore.y))
      {
        takeSpool(ring, bore, result);
        return true;
      }
    }
  }
  holes_.clear();
  return false;
}

bool SpoolDetector::spoolAboutHoles(const cv::Mat& image, PixelFormat format, const cv::Point2d& reference,
                                    double bound, double min_bore_radius, int max_holes, SpoolDetection& result,
                                    std::optional<double> axis_yaw)
{
  const SpoolGeometry& geometry = *geometry_;
  int searched = 0;
  for (std::size_t h = 0; h < holes_.size() && searched < max_holes; ++h)
  {
    // A bore whose whole rim is in the frame and which shows as a disc (a ring of the bore's
    // size on a neighbour's face cut by the border, or on a plate, is no spool).
    const Circle hole = holes_[h];
    // A bore seen far off its axis is dark, an ellipse as narrow as the view (detectTurnedBores()).
    const double contrast = axis_yaw ? signedBoreContrast({hole.x, hole.y}, hole.r, hole.r_horizontal / hole.r_vertical)
                                     : boreContrast({hole.x, hole.y}, hole.r);
    // A sharp rim about a bore seen through (a lit lens in part of it) counts as a disc too.
    const double least = params_.matcher.bore_contrast;
    if (!wholeBoreRim(hole, min_bore_radius) ||
        (contrast < least && !(hole.score >= kSharpBoreScore && litBoreContrast({hole.x, hole.y}, hole.r) >= least)))
      continue;
    ++searched;
    // With no spool taken, a face the frame cuts is searched densely in view too. (Retried in every
    // pose search, rib rings cut by the frame replaced right spools: hard seed 43 #37 at 320x240,
    // 103 #16 and packed 43 #17 at 640x480; here where a spool was taken, no frame changed.)
    if (!searchRimAbout(image, format, geometry, hole, kBoreRimFallbackPoses, axis_yaw, !std::isfinite(bound)) ||
        oblique_rim_.support < kBoreAgreedSupport || !geometry.atPullerLevel(oblique_rim_.rim, hole.y) ||
        (cutByBorder(oblique_rim_.rim) && hole.score < params_.matcher.cut_flange_hole_score) ||
        ConcentricMatcher::targetCost({hole.x, hole.y}, axis_yaw ? 1.0 : oblique_rim_.support, reference) >= bound)
      continue;
    // The bore measured at the size the rim gives it (a search of its own, the costliest check,
    // so last and once) must agree with the rim where the rim keeps under kObliqueSpoolSupport of
    // its samples, and where the hole's circle does not agree with it: the Hough circle of a dark
    // bore seen 25-35 deg off its axis, shaded across, can fit its darker part only, at 0.7 of its
    // height (oblique seed 89 #55 at 640x480: 15.5 px of 22, the rim about it right).
    const bool needs_own_size = oblique_rim_.support < kObliqueSpoolSupport || !boreAgreesWith(hole, oblique_rim_);
    // (takesSecondSearch() reads the agreement too.)
    SpoolDetection about_hole;
    about_hole.flange = oblique_rim_.rim;
    about_hole.hole = hole;
    const std::optional<Circle> own =
        needs_own_size || search_.second ? boreAtOwnSize(about_hole, oblique_rim_.axis) : std::optional<Circle>();
    const bool own_size_agrees = own && ownSizeAgrees(*own, oblique_rim_.rim);
    if (needs_own_size && !own_size_agrees)
    {
      // A bore kObliqueInnerRingScale or more of what the rim allows says the rim is a rib ring
      // about it (1.1-1.34 on the 19 rendered sets of session 50, their depths 9-47% long; right
      // rims 1.08 at most): with no spool taken, the first leads outwards (takeBoreRing()).
      if (!std::isfinite(bound) && !bore_ring_ && own &&
          own->r_vertical >= kObliqueInnerRingScale * matcher_.holeRadius(oblique_rim_.rim))
      {
        bore_ring_ = BoreRing{{oblique_rim_.rim, oblique_rim_.position, oblique_rim_.axis}, hole, *own};
      }
      continue;
    }
    bore_agrees_at_own_size_ = own_size_agrees;
    takeSpool(oblique_rim_.rim, hole, result);
    keepSearchedPose();
    measureBoreAtKnownSize(result);
    findLens(result);
    return true;
  }
  return false;
}

double SpoolDetector::selectTarget(const cv::Point2d& reference, const HoughSearch& flange_search,
                                   const HoughSearch& hole_search, SpoolEvidence evidence, double bound,
                                   SpoolDetection& result)
{
  ConcentricMatcher::orderByReference(flanges_, reference, order_);
  holes_.clear();
  if (params_.matcher.mode == MatchMode::kCht)
  {
    // The thesis baseline: the flange nearest the reference, the strongest hole anywhere.
    if (order_.empty())
      return kNoMatch;
    edge_detector_.extract(params_.hough.hole_edge_threshold, cv::Rect(cv::Point(), preprocessed_.size()),
                           edgeBudget(preprocessed_.size()), hole_edges_);
    detectHoles(hole_search);
    const Circle& target = flanges_[order_.front()];
    takeSpool(target, matcher_.matchHole(target, holes_), result);
    return kNoMatch;
  }
  double best_cost = bound;
  if (const std::optional<SpoolMatch> best = nearestSpool(reference, flange_search, hole_search, best_cost))
  {
    std::swap(holes_, target_holes_);
    takeSpool(best->flange, best->hole, result);
    if (!measureBoreAtKnownSize(result))
      measureBoreAboutFlangeCentre(result);
    // With hole_polarity bright (the thesis) the "hole" is the lit region itself.
    if (params_.hough.hole_polarity != Polarity::kBright)
      findLens(result);
    return best_cost;
  }
  holes_.clear();
  if (order_.empty())
    return kNoMatch;
  switch (evidence)
  {
    case SpoolEvidence::kHole:
      break;
    case SpoolEvidence::kBore:
      if (const auto i = strongFlangeWithBore(hole_search))
        takeSpool(flanges_[*i], std::nullopt, result);
      break;
    case SpoolEvidence::kFlange:
      takeSpool(flanges_[order_.front()], std::nullopt, result);
      break;
  }
  return kNoMatch;
}

std::optional<SpoolMatch> SpoolDetector::nearestSpool(const cv::Point2d& reference, const HoughSearch& flange_search,
                                                      const HoughSearch& hole_search, double& best_cost)
{
  // MCHT: a flange is a spool only with a concentric hole of the right size, so false circles
  // (arcs of neighbours, shelf edges, round objects without a bore) do not become the target.
  // The target is the spool whose hole (its axis) is nearest the reference in bearing, weighted
  // by the rim score (ConcentricMatcher::targetCost()); candidates are tried in that order, and
  // one that cannot beat the best so far even with a solid rim is skipped.
  std::optional<SpoolMatch> best;
  for (const std::size_t i : order_)
  {
    HoughSearch search = hole_search;
    if (!matcher_.narrowHoleSearch(flanges_[i], preprocessed_.size(), search))
      continue;
    const cv::Rect2d& w = search.center_window;
    const double nearest = std::hypot(reference.x - std::clamp(reference.x, w.x, w.x + w.width),
                                      reference.y - std::clamp(reference.y, w.y, w.y + w.height));
    if (nearest >= best_cost)
      continue;
    std::optional<SpoolMatch> match = matchSpool(flanges_[i], search, flange_search);
    if (match && match->hole->score < kSharpHoleScore)
      refitWeakMatch(hole_search, flange_search, *match);
    if (!match || !geometry_->atPullerLevel(match->flange, match->hole->y) || !holeCountsOn(*match))
      continue;
    const double cost =
        ConcentricMatcher::targetCost({match->hole->x, match->hole->y}, bearingSupport(*match), reference);
    if (cost < best_cost)
    {
      best = match;
      best_cost = cost;
      std::swap(holes_, target_holes_);
    }
  }
  return best;
}

double SpoolDetector::bearingSupport(const SpoolMatch& match)
{
  const double score = match.flange.score;
  if (!(match.hole->score >= kSharpBoreScore && match.hole->r >= kMinKnownSizeRadius))
    return score;
  constexpr double kSolid = ConcentricMatcher::kSolidRimScore;
  return kSolid * std::cbrt(std::min(1.0, score / kSolid));
}

void SpoolDetector::refitWeakMatch(const HoughSearch& hole_search, const HoughSearch& flange_search, SpoolMatch& match)
{
  Circle refit = match.flange;
  if (!flange_hough_.refitOnMostSupport(edges_, preprocessed_.size(), flange_search, refit) ||
      !(refit.score > match.flange.score))
    return;
  HoughSearch search = hole_search;
  if (!matcher_.narrowHoleSearch(refit, preprocessed_.size(), search))
    return;
  // The candidate's holes stay unless the refit's match replaces it (matchSpool() fills holes_ anew).
  holes_.swap(refit_holes_);
  const std::optional<SpoolMatch> other = matchSpool(refit, search, flange_search);
  if (other && other->hole->score >= kSharpHoleScore && other->flange.score >= match.flange.score)
    match = *other;
  else
    holes_.swap(refit_holes_);
}

bool SpoolDetector::boreAtPrediction(const cv::Mat& image, PixelFormat format, const FlangeWindow& window,
                                     SpoolDetection& result)
{
  if (params_.matcher.mode != MatchMode::kMcht || params_.hough.hole_polarity == Polarity::kBright)
    return false;
  Circle predicted;
  predicted.x = window.centre.x;
  predicted.y = window.centre.y;
  predicted.r = predicted.r_vertical = matcher_.holeRadius(flanges_.front());
  if (predicted.r < kMinKnownSizeRadius)
    return false;
  const double shift = std::min(kKnownSizeShift * predicted.r + 1.0, window.bore_reach);
  prepareAround(image, format, cv::Rect2d(predicted.x, predicted.y, 0.0, 0.0),
                kDiscReach * predicted.r + shift + kWindowPad, false);
  SpoolDetection bore;
  takeSpool(flanges_.front(), predicted, bore);
  if (!measureBoreAtKnownSize(bore, shift) || !matcher_.accepts(bore.flange, bore.hole) ||
      !geometry_->atPullerLevel(bore.flange, bore.hole.y) || !holeCountsOn(SpoolMatch{bore.flange, bore.hole}))
    return false;
  takeSpool(bore.flange, bore.hole, result);
  findLens(result);
  return true;
}

std::optional<SpoolDetector::BoreShape> SpoolDetector::boreShape(const SpoolDetection& result,
                                                                 std::optional<double> max_shift,
                                                                 const std::optional<cv::Vec3d>& axis, bool projected)
{
  // The bore is a circle on the flange's face, 3.6/35 of it: its ellipse is the flange's, scaled.
  const Circle& flange = result.flange;
  const Circle& hole = result.hole;
  const CameraIntrinsics& camera = geometry_->camera();
  const double scale = matcher_.holeRadius(flange) / flange.r_vertical;
  BoreShape shape;
  const double height = scale * flange.r_vertical;
  const double depth = geometry_->depthFromDiameter(2.0 * flange.r_vertical);
  // With the spool's axis known, the bore's ellipse narrows across by the cosine of the angle
  // between the axis and the line of sight (a circle this small projects affinely); the flange's
  // measured width is a looser guide (a near-circle fit to an oblique rim is 5-8% wide).
  shape.ellipse = {scale * (flange.r_horizontal > 0.0 ? flange.r_horizontal : flange.r), height, 0.0};
  if (axis && projected)
  {
    // The projection is also tilted where the bore is above or below the axis's vanishing point
    // (11 deg at 640x480 on oblique seed 131 #8: an upright ellipse of that shape, fitted on its
    // sharp half, came out 1.3 px off centre). The tilt follows the axis's pitch, which the rim
    // measures 2-4 deg off where its yaw is right (oblique seed 89 #55: 7 deg of tilt from 3 deg of
    // pitch): a level spool's pitch is taken.
    const EllipseShape seen = geometry_->boreEllipse(geometry_->backProject(hole.x, hole.y, depth), levelAxis(*axis));
    if (seen.halfHeight() > 0.0)
      shape.ellipse = seen.scaled(height / seen.halfHeight());
  }
  else if (axis)
  {
    const cv::Point3d ray = geometry_->backProject(hole.x, hole.y, 1.0);
    shape.ellipse.semi_x = height * std::abs(cv::normalize(cv::Vec3d(ray.x, ray.y, ray.z)).dot(*axis));
  }
  if (height < kMinKnownSizeRadius)
    return std::nullopt;
  // The free fit's centre can be off by a quarter of the radius; a tracked bore's by its 3 sigma.
  shape.shift = max_shift.value_or(kKnownSizeShift * height + 1.0);
  // Deeper in the bore a circle of the wall projects nearer the axis's vanishing point (the
  // principal point for an axis along the line of sight, as the back flange does), so the wall
  // near the opening, lit like the face, shows inside the rim on the side away from it: a band
  // about |hole - vanishing point| * a_z * depth / Z px wide for the ~1.5 cm of wall the light
  // reaches. Where that is a fraction of a pixel the whole rim counts; else only its half facing
  // the vanishing point, which is sharp.
  const cv::Vec3d along = axis.value_or(cv::Vec3d(0.0, 0.0, 1.0));
  const cv::Point2d vanishing(camera.cx + camera.fx * along[0] / along[2], camera.cy + camera.fy * along[1] / along[2]);
  const cv::Point2d outward(hole.x - vanishing.x, hole.y - vanishing.y);
  constexpr double kLitWall = 0.015;  // m
  if (std::hypot(outward.x, outward.y) * along[2] * kLitWall / depth > 0.3)
    shape.side = -outward;
  shape.search.polarity = params_.hough.hole_polarity;
  return shape;
}

cv::Vec3d SpoolDetector::levelAxis(const cv::Vec3d& axis) const
{
  const TrackerParams& tp = params_.tracker;
  if (!(tp.level_pitch_sigma > 0.0) || !(axis[2] > 0.0))
    return axis;
  return cv::normalize(cv::Vec3d(axis[0], tp.level_pitch * axis[2], axis[2]));
}

void SpoolDetector::extractBoreEdges(const Circle& hole, double reach)
{
  const CameraIntrinsics& camera = geometry_->camera();
  const PreprocessParams& pre = params_.preprocess;
  const double sigma = pre.filter == FilterType::kGaussian ? pre.filter_sigma * camera.fy : 0.0;
  // The rim's edges are placed in the frame's light (a binarized frame has none to read); its
  // profile is read over three filter sigmas, the blur the filter is set for at this size.
  const bool in_light = pre.binarize == BinarizeType::kNone;
  const LinearLight light{&preprocessor_.gray(), preprocessor_.linearLight().data(), std::max(2.0, 3.0 * sigma)};
  extractHoleEdges(cv::Rect2d(hole.x, hole.y, 0.0, 0.0), reach, in_light ? &light : nullptr);
}

bool SpoolDetector::measureBoreAtKnownSize(SpoolDetection& result, std::optional<double> max_shift,
                                           const std::optional<cv::Vec3d>& axis, bool sized_by_pose)
{
  const std::optional<BoreShape> shape = boreShape(result, max_shift, axis, sized_by_pose);
  if (!shape)
    return false;
  // The pose's size: the bore's front rim projected from the rim's 3-D pose.
  BoreShape by_pose = *shape;
  by_pose.ellipse = sized_by_pose && axis ? geometry_->boreEllipse(result.position, levelAxis(*axis)) : EllipseShape{};
  const bool pose_sized = by_pose.ellipse.halfHeight() >= kMinKnownSizeRadius;
  Circle& hole = result.hole;
  auto reach = [](const BoreShape& s) { return std::max(s.ellipse.semi_x, s.ellipse.semi_y) + s.shift + 2.0; };
  extractBoreEdges(hole, std::max(reach(*shape), pose_sized ? reach(by_pose) : 0.0));
  auto fitAt = [&](const BoreShape& s, Circle& fitted)
  {
    return hole_hough_.fitCentreAtSize(hole_edges_, preprocessed_.size(), s.search, {hole.x, hole.y}, s.ellipse,
                                       s.shift, s.side, fitted);
  };
  Circle fitted;
  bool fits = fitAt(*shape, fitted);
  // Of the two sizes the better supported (the pose's on a tie): the flange's ellipse measures 3-6%
  // tall or wide seen 30-40 deg off the axis while the pose's depth is within 1-2%, but a pose
  // whose depth is 4% off gives the bore a size its edges do not bear out (oblique seed 11 #98).
  Circle at_pose_size;
  if (pose_sized && fitAt(by_pose, at_pose_size) && !(fits && fitted.score > at_pose_size.score))
  {
    fitted = at_pose_size;
    fits = true;
  }
  if (fits && fitted.score >= 1.0 - params_.hough.hole_sensitivity)
  {
    hole = fitted;
    return true;
  }
  return false;
}

bool SpoolDetector::measureBoreAboutFlangeCentre(SpoolDetection& result)
{
  if (oval(result.flange))
    return false;
  const Circle hole = result.hole;
  result.hole.x = result.flange.x;
  result.hole.y = result.flange.y;
  // A bore the frame cuts is no evidence of where the spool's axis is (ConcentricMatcher::accepts()).
  if (measureBoreAtKnownSize(result) && result.hole.visible_fraction >= ConcentricMatcher::kMinHoleVisibleFraction)
    return true;
  result.hole = hole;
  return false;
}

std::optional<Circle> SpoolDetector::boreAtOwnSize(const SpoolDetection& spool, const cv::Vec3d& axis)
{
  const std::optional<BoreShape> shape =
      boreShape(spool, std::nullopt, offAxis(axis) ? std::optional<cv::Vec3d>(axis) : std::nullopt, false);
  if (!shape)
    return std::nullopt;
  const Circle& hole = spool.hole;
  extractBoreEdges(hole, kOwnScaleMax * std::max(shape->ellipse.semi_x, shape->ellipse.semi_y) + shape->shift + 2.0);
  Circle bore;
  if (!hole_hough_.fitCentreAndScale(hole_edges_, preprocessed_.size(), shape->search, {hole.x, hole.y}, shape->ellipse,
                                     shape->shift, shape->side, kOwnScaleMin, kOwnScaleMax, bore) ||
      bore.score < 1.0 - params_.hough.hole_sensitivity)
    return std::nullopt;
  return bore;
}

bool SpoolDetector::obliqueInnerRing(const SpoolDetection& result, Circle& bore)
{
  const std::optional<Circle> own = boreAtOwnSize(result, result.axis);
  if (!own)
    return false;
  bore = *own;
  return bore.r_vertical >= kObliqueInnerRingScale * matcher_.holeRadius(result.flange);
}

bool SpoolDetector::ownSizeAgrees(const Circle& bore, const Circle& flange) const
{
  return std::abs(bore.r_vertical / matcher_.holeRadius(flange) - 1.0) <= kOwnScaleAgreement;
}

bool SpoolDetector::takeBoreRing(SpoolDetection& result) const
{
  if (!bore_ring_)
    return false;
  takeSpool(bore_ring_->ring.flange, bore_ring_->hole, result);
  return true;
}

bool SpoolDetector::boreAgreesAtOwnSize(const SpoolDetection& spool, const cv::Vec3d& axis)
{
  const std::optional<Circle> own = boreAtOwnSize(spool, axis);
  return own && ownSizeAgrees(*own, spool.flange);
}

bool SpoolDetector::frontRimAboutOwnBore(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                                         SpoolDetection& result)
{
  if (result.hole.score >= kSilhouetteBoreWhole)
    return true;
  const std::optional<Circle> own = boreAtOwnSize(result, result.axis);
  // A smaller circle inside the bore that is lighter than the rest of it is a lens, not the rim.
  if (!own || own->r_vertical > kSilhouetteBoreScale * matcher_.holeRadius(result.flange) ||
      litInside(*own, result.hole))
    return true;
  if (!searchRimAbout(image, format, geometry, *own, 0) || oblique_rim_.support < kObliqueSpoolSupport ||
      !boreAgreesWith(*own, oblique_rim_))
  {
    // Without its front rim, a weak outline too large for its bore is not reported as a spool.
    if (result.flange.score >= ConcentricMatcher::kSolidRimScore)
      return true;
    noSpool(geometry, result);
    return false;
  }
  takeSpoolAboutBore(geometry, *own, result);
  return true;
}

void SpoolDetector::noSpool(const SpoolGeometry& geometry, SpoolDetection& result)
{
  result = SpoolDetection();
  geometry.measure(result);
}

bool SpoolDetector::offAxis(const cv::Vec3d& axis)
{
  return axis[2] > 0.0 && std::acos(std::min(1.0, axis[2])) >= kObliqueAxisAngle;
}

bool SpoolDetector::oval(const Circle& circle)
{
  return circle.r_horizontal > 0.0 && circle.r_horizontal < kNearAxisAspect * circle.r_vertical;
}

bool SpoolDetector::roundBoreInOvalFlange(const SpoolDetection& result)
{
  return oval(result.flange) && !oval(result.hole);
}

void SpoolDetector::remeasureBore(const SpoolGeometry& geometry, const std::optional<cv::Vec3d>& axis,
                                  bool sized_by_pose, SpoolDetection& result, std::optional<double> max_shift)
{
  const double score = result.hole.score;
  if (!measureBoreAtKnownSize(result, max_shift, axis, sized_by_pose))
    return;
  // The score stays the evidence the spool was taken on (the second search's gate reads it): a
  // half rim at a given size scores higher than the free fit did.
  result.hole.score = score;
  geometry.moveBoreCentre(result);
}

bool SpoolDetector::ownBore(const SpoolDetection& result, const HoughSearch& hole_search, Circle& bore)
{
  const Circle& hole = result.hole;
  const double expected = matcher_.holeRadius(result.flange);
  // The hole's fit is free within the hole search's sizes: it may have measured the bore larger
  // than the flange allows already (within 3% of it on the hard set's right flanges at 640x480;
  // 15% on a rib ring at 0.86 of the rim). Only near the spool axis (far off it a blurred dark
  // bore's circle fit runs up to 15% large: heldout_v2 pos_073, 33 deg off), and on a bore large
  // enough for a pixel not to be 12% of it (kMinKnownSizeRadius; this and the tie below cost
  // 160x120 frames of the hard set), its rim seen nearly whole (kSharpHoleScore: a part of a rim
  // leaves its size loose, 17% large on oblique seed 7 #73 at 320x240).
  const double aspect = result.flange.r_horizontal > 0.0 ? result.flange.r_horizontal / result.flange.r_vertical : 1.0;
  const bool measurable = hole.r >= kMinKnownSizeRadius && aspect >= kNearAxisAspect && hole.score >= kSharpHoleScore;
  if (measurable && hole.r >= kInnerRingRatio * expected)
  {
    bore = hole;
    return true;
  }
  // The detected hole can be a smaller circle inside the true bore (its lit part, an arc of its
  // rim).
  const Circle* best = bestBoreAbout(hole, expected, hole_search, kInnerRingRatio * expected, hole_search.r_max);
  // The bore's rim at its own size must be better supported than the one the flange's size gave,
  // by kOwnBoreMargin: a faint ring about a true bore (a hub, a chamfer) is not its rim, and a
  // sharp bore whose size the flange gave right supports a circle a pixel or two larger as well
  // as its own (the fit's band): a tie is no evidence.
  // A hole on the flange's centre is on the spool's axis: a circle farther off it is another ring,
  // not the bore about that axis (hard seed 19 #121 at 320x240: 9 px off a hole 1 px off the
  // centre; a rim 1.8 times the flange was taken outside it). A lit lens off the axis, or a hole
  // off a Hough circle that is itself off the bore (oblique seed 71 #40), says nothing of this.
  const double tolerance = matcher_.tolerancePx();
  const double hole_off = std::hypot(hole.x - result.flange.x, hole.y - result.flange.y);
  if (!best || (hole_off <= tolerance &&
                std::hypot(best->x - result.flange.x, best->y - result.flange.y) > hole_off + tolerance))
    return false;
  // A tie is evidence where the larger circle holds the hole inside it, well beyond the fit's
  // band: the hole is then the lit lens inside the bore's rim (hard set seed 7 #10: both whole),
  // which shows near the spool axis only.
  const bool holds_hole = measurable && best->r >= hole.r + std::max(kOwnBoreBandPx, kOwnBoreBand * hole.r) &&
                          std::hypot(best->x - hole.x, best->y - hole.y) + hole.r <= best->r + kOwnBoreAgreementPx &&
                          litInside(hole, *best);
  if (best->score < hole.score + (holds_hole ? 0.0 : kOwnBoreMargin))
    return false;
  bore = *best;
  return true;
}

void SpoolDetector::findLens(SpoolDetection& result)
{
  // A bright disc inside the front rim, smaller than it, its centre within half the rim's radius.
  const Circle& rim = result.hole;
  HoughSearch search;
  search.polarity = Polarity::kBright;
  search.min_score = 1.0 - params_.hough.hole_sensitivity;
  search.min_visible_fraction = params_.hough.min_visible_fraction;
  search.max_circles = 2;
  search.r_min = std::max(1.0, 0.3 * rim.r);
  search.r_max = 0.9 * rim.r;  // a lens as big as the rim is the rim itself
  search.center_window = cv::Rect2d(rim.x - 0.5 * rim.r, rim.y - 0.5 * rim.r, rim.r, rim.r);
  extractHoleEdges(cv::Rect2d(rim.x, rim.y, 0.0, 0.0), rim.r + 2.0);
  lens_hough_.detect(hole_edges_, preprocessed_.size(), search, lenses_);
  for (const Circle& lens : lenses_)
    if (std::hypot(lens.x - rim.x, lens.y - rim.y) + lens.r <= 1.1 * rim.r + 1.0)  // touching it inside
    {
      result.lens_detected = true;
      result.lens = lens;
      return;
    }
}

void SpoolDetector::measureBoreParallax(const SpoolGeometry& geometry, SpoolDetection& result)
{
  // With hole_polarity bright (the thesis) the "hole" is the lit region itself.
  if (!result.hole_detected || params_.hough.hole_polarity == Polarity::kBright || !(result.position.z > 0.0))
    return;
  const LinearLight light{&preprocessor_.gray(), preprocessor_.linearLight().data()};
  const std::optional<LensView> lens =
      measureLens(light, geometry.camera(), {result.hole.x, result.hole.y}, result.hole.r, lens_samples_);
  if (!lens)
    return;
  const std::optional<ParallaxAxis> axis = axisFromBoreParallax(
      params_.geometry, geometry.camera(), {result.hole.x, result.hole.y}, result.position.z, *lens);
  if (!axis)
    return;
  result.parallax_measured = true;
  result.lens_centroid = lens->centroid;
  result.parallax_slopes = axis->slopes;
  result.parallax_covariance = axis->covariance;
}

namespace
{
// The grey levels of a disc of radius 0.8 r about `centre` in `gray` (an ellipse `aspect` as wide
// as high) and the means of the four quarters of the ring 1.3 r .. 2 r about it. `inner`: how many
// of the disc's pixels take each level. False where a quarter lies off the image (not judged).
bool discAndRing(const cv::Mat& gray, const cv::Point2d& centre, double r, double aspect, std::array<int, 256>& inner,
                 std::array<double, 4>& ring_mean)
{
  const double inner2 = 0.8 * 0.8 * r * r;
  const double ring_min2 = 1.3 * 1.3 * r * r;
  const double ring_max2 = 4.0 * r * r;
  const double across2 = 1.0 / (aspect * aspect);  // a column's share of the ellipse's radius, squared
  const int x0 = std::max(0, cvFloor(centre.x - 2.0 * r * aspect));
  const int x1 = std::min(gray.cols - 1, cvCeil(centre.x + 2.0 * r * aspect));
  const int y0 = std::max(0, cvFloor(centre.y - 2.0 * r));
  const int y1 = std::min(gray.rows - 1, cvCeil(centre.y + 2.0 * r));
  inner.fill(0);
  std::array<double, 4> ring_sum{};
  std::array<int, 4> ring_n{};
  for (int y = y0; y <= y1; ++y)
  {
    const uchar* row = gray.ptr<uchar>(y);
    const double dy = y - centre.y;
    for (int x = x0; x <= x1; ++x)
    {
      const double dx = x - centre.x;
      const double d2 = dx * dx * across2 + dy * dy;
      if (d2 <= inner2)
      {
        ++inner[row[x]];
      }
      else if (d2 >= ring_min2 && d2 <= ring_max2)
      {
        const std::size_t q = (dx < 0.0 ? 1u : 0u) | (dy < 0.0 ? 2u : 0u);
        ring_sum[q] += row[x];
        ++ring_n[q];
      }
    }
  }
  for (std::size_t q = 0; q < 4; ++q)
  {
    if (ring_n[q] == 0)
      return false;
    ring_mean[q] = ring_sum[q] / ring_n[q];
  }
  return true;
}

// Mean level of the disc's pixels from the `from` to the `to` fraction of them, darkest first
// (`inner` as discAndRing() counts them); NaN for an empty disc.
double meanBetween(const std::array<int, 256>& inner, double from, double to)
{
  long total = 0;
  for (const int n : inner)
    total += n;
  const double lo = from * static_cast<double>(total);
  const double hi = to * static_cast<double>(total);
  double sum = 0.0;
  double taken = 0.0;
  double seen = 0.0;
  for (int level = 0; level < 256; ++level)
  {
    const double n = inner[static_cast<std::size_t>(level)];
    const double share = std::max(0.0, std::min(seen + n, hi) - std::max(seen, lo));
    sum += share * level;
    taken += share;
    seen += n;
  }
  return taken > 0.0 ? sum / taken : std::numeric_limits<double>::quiet_NaN();
}

// How much a disc of radius r about `centre` in `gray` differs from the face around it, as a
// fraction of full scale: the smallest difference between its mean and the means of the four
// quarters of the ring 1.3 r .. 2 r, when all four differ the same way (0 otherwise). A bore
// shows as a disc darker (unlit) or brighter (lit) than the face on every side, even where it is
// too small or faint for its rim to be fitted; a mark beside it changes one quarter only.
double discContrast(const cv::Mat& gray, const cv::Point2d& centre, double r, double aspect)
{
  std::array<int, 256> inner{};
  std::array<double, 4> ring{};
  if (!discAndRing(gray, centre, r, aspect, inner, ring))
    return 0.0;  // a quarter off the image: not judged
  const double in_mean = meanBetween(inner, 0.0, 1.0);
  if (!std::isfinite(in_mean))
    return 0.0;
  double lowest = 1.0;
  int darker = 0;
  for (const double ring_mean : ring)
  {
    const double d = ring_mean - in_mean;
    darker += d > 0.0 ? 1 : -1;
    lowest = std::min(lowest, std::abs(d) / 255.0);
  }
  // Signed: positive for a disc darker than all around it, negative for one lighter.
  return std::abs(darker) == 4 ? (darker > 0 ? lowest : -lowest) : 0.0;
}

// A bore seen through, its far end's light a lens in part of it: its darker half darker than the
// face on every side, its brightest fifth brighter. As a fraction of full scale, the smaller of
// the two least differences; 0 where either fails. (A lens over a third of the bore and a face
// shaded across it leave the whole disc's mean between the ring's quarters: discContrast() 0.)
double litBoreContrast(const cv::Mat& gray, const cv::Point2d& centre, double r)
{
  std::array<int, 256> inner{};
  std::array<double, 4> ring{};
  if (!discAndRing(gray, centre, r, 1.0, inner, ring))
    return 0.0;
  const double dark = meanBetween(inner, 0.0, 0.5);
  const double lit = meanBetween(inner, 0.8, 1.0);
  if (!std::isfinite(dark) || !std::isfinite(lit))
    return 0.0;
  double lowest = 1.0;
  for (const double ring_mean : ring)
    lowest = std::min({lowest, (ring_mean - dark) / 255.0, (lit - ring_mean) / 255.0});
  return std::max(lowest, 0.0);
}

// Mean grey level of `gray` over the pixels inside the circle (centre, r) and outside every one
// of `outside` (x, y, r), each in px; NaN where none is.
double meanInside(const cv::Mat& gray, const cv::Point2d& centre, double r, std::initializer_list<cv::Point3d> outside)
{
  const int x0 = std::max(0, cvFloor(centre.x - r));
  const int x1 = std::min(gray.cols - 1, cvCeil(centre.x + r));
  const int y0 = std::max(0, cvFloor(centre.y - r));
  const int y1 = std::min(gray.rows - 1, cvCeil(centre.y + r));
  double sum = 0.0;
  int n = 0;
  for (int y = y0; y <= y1; ++y)
  {
    const uchar* row = gray.ptr<uchar>(y);
    for (int x = x0; x <= x1; ++x)
    {
      bool in = std::hypot(x - centre.x, y - centre.y) <= r;
      for (const cv::Point3d& c : outside)
        in = in && std::hypot(x - c.x, y - c.y) > c.z;
      sum += in ? row[x] : 0.0;
      n += in ? 1 : 0;
    }
  }
  return n > 0 ? sum / n : std::numeric_limits<double>::quiet_NaN();
}
}  // namespace

cv::Point3d SpoolDetector::inFrame(const cv::Point2d& centre, double r) const
{
  // The frame is not undistorted: where the lens puts the centre, at its local scale.
  const cv::Point2d seen = distortPixel(geometry_->camera(), centre);
  const cv::Point2d edge = distortPixel(geometry_->camera(), {centre.x + r, centre.y});
  return {seen.x, seen.y, std::hypot(edge.x - seen.x, edge.y - seen.y)};
}

bool SpoolDetector::litInside(const Circle& hole, const Circle& rim) const
{
  const cv::Point3d lens_disc = inFrame({hole.x, hole.y}, hole.r);
  const cv::Point3d rim_disc = inFrame({rim.x, rim.y}, rim.r);
  const double lens = meanInside(preprocessed_, {lens_disc.x, lens_disc.y}, kLensCore * lens_disc.z, {});
  // Inside the larger rim and outside the hole's, a pixel clear of each.
  const double wall = meanInside(preprocessed_, {rim_disc.x, rim_disc.y}, rim_disc.z - 1.0,
                                 {cv::Point3d(lens_disc.x, lens_disc.y, lens_disc.z + 1.0)});
  return lens > wall;
}

double SpoolDetector::boreContrast(const cv::Point2d& centre, double r) const
{
  return std::abs(signedBoreContrast(centre, r));
}

double SpoolDetector::signedBoreContrast(const cv::Point2d& centre, double r, double aspect) const
{
  const cv::Point3d disc = inFrame(centre, r);
  return discContrast(preprocessed_, {disc.x, disc.y}, disc.z, aspect);
}

double SpoolDetector::litBoreContrast(const cv::Point2d& centre, double r) const
{
  const cv::Point3d disc = inFrame(centre, r);
  return spool_vision::litBoreContrast(preprocessed_, {disc.x, disc.y}, disc.z);
}

void SpoolDetector::detectHoles(const HoughSearch& hole_search)
{
  hole_hough_.detect(hole_edges_, preprocessed_.size(), hole_search, holes_);
  // A faint ring is a bore only where its disc shows too: on a plate, a can's lid or a
  // neighbour's face cut by the frame border, noise and ribs close weak rims of the bore's size.
  const MatcherParams& mp = params_.matcher;
  holes_.erase(std::remove_if(holes_.begin(), holes_.end(),
                              [&](const Circle& h)
                              {
                                if (h.score >= mp.weak_hole_score)
                                  return false;
                                // In a whole-frame search, from kMinKnownSizeRadius up, a weak ring
                                // about a lighter disc is copper, a label or the light between two
                                // spools (a lit bore's lens is ringed by its sharp rim there); a
                                // track's window is where its bore was, whatever lights it.
                                const double contrast = signedBoreContrast({h.x, h.y}, h.r);
                                const bool darker = search_.whole_frame && h.r >= kMinKnownSizeRadius;
                                return (darker ? contrast : std::abs(contrast)) < mp.bore_contrast;
                              }),
               holes_.end());
}

bool SpoolDetector::holeCountsOn(const SpoolMatch& match) const
{
  const Circle& hole = *match.hole;
  const double least = params_.matcher.bore_contrast;
  // A weak circle about a hole rim short of sharp whose disc is neither darker nor lighter than
  // the face, nor lit through, is a ring of the face's texture: at 160x120 a rib's arc or a
  // speck a sixth of the rim off the bore, with the circle through the rim and its back
  // flange's silhouette 15-30% off in depth (oblique seed 97 #44, #84, #91 at 320x240; seed 7
  // #21 at 160x120). Without it the search about the bore finds the rim.
  const bool weak = match.flange.score < kBareHoleFlangeScore && hole.score < kSharpHoleScore;
  // On a flange cut by the border, a hole rim short of cut_flange_hole_score needs its disc.
  const bool cut = cutByBorder(match.flange) && hole.score < params_.matcher.cut_flange_hole_score;
  if (!weak && !cut)
    return true;
  // The disc is read once (the costliest test here).
  const double contrast = boreContrast({hole.x, hole.y}, hole.r);
  if (weak && contrast < least && litBoreContrast({hole.x, hole.y}, hole.r) < least)
    return false;
  return !cut || contrast >= least;
}

std::optional<std::size_t> SpoolDetector::strongFlangeWithBore(const HoughSearch& hole_search) const
{
  for (const std::size_t i : order_)
  {
    const Circle& flange = flanges_[i];
    HoughSearch search = hole_search;
    // Strong evidence: (nearly) the whole rim in view and supported; a rim cut by the border
    // leaves room for neighbours' back flanges and shelf arcs.
    if (flange.score < params_.matcher.flange_only_score ||
        flange.visible_fraction < ConcentricMatcher::kMinHoleVisibleFraction ||
        !geometry_->atPullerLevel(flange, flange.y) || !matcher_.narrowHoleSearch(flange, preprocessed_.size(), search))
      continue;
    // The bore's size is known from the flange; its centre anywhere in the concentric window,
    // sampled at a quarter of its radius (at most 7 x 7 places). The contrast must peak inside
    // the window: one growing towards its border is a mark beside the bore's place.
    const double r = matcher_.holeRadius(flange);
    const cv::Rect2d& w = search.center_window;
    const int nx = std::min(6, static_cast<int>(w.width / std::max(0.25 * r, 0.5)));
    const int ny = std::min(6, static_cast<int>(w.height / std::max(0.25 * r, 0.5)));
    double best = 0.0;
    bool on_border = false;
    for (int iy = 0; iy <= ny; ++iy)
      for (int ix = 0; ix <= nx; ++ix)
      {
        const cv::Point2d at(w.x + (nx > 0 ? ix * w.width / nx : 0.5 * w.width),
                             w.y + (ny > 0 ? iy * w.height / ny : 0.5 * w.height));
        const double contrast = boreContrast(at, r);
        if (contrast > best)
        {
          best = contrast;
          on_border = (nx > 1 && (ix == 0 || ix == nx)) || (ny > 1 && (iy == 0 || iy == ny));
        }
      }
    if (best >= params_.matcher.bore_contrast && !on_border)
      return i;
  }
  return std::nullopt;
}

std::optional<SpoolMatch> SpoolDetector::matchSpool(const Circle& flange, const HoughSearch& hole_search,
                                                    const HoughSearch& flange_search)
{
  // Only edges that can lie on the hole's rim, at the hole's own threshold.
  const cv::Rect2d& w = hole_search.center_window;
  extractHoleEdges(w, hole_search.r_max + 2.0);
  detectHoles(hole_search);
  // A hole off the fitted centre may mean the fit followed the front and back flanges' joint
  // silhouette: the front rim is then measured again about the hole (the spool's axis); that
  // pair too must pass the concentric rule, and it must explain the fit.
  HoughSearch front_search = flange_search;
  front_search.r_min = std::max(flange_search.r_min, 0.9 * flange.r_vertical);
  front_search.r_max = std::min(flange_search.r_max, 1.1 * flange.r_vertical * matcher_.backToFront(flange));
  auto frontAbout = [&](const Circle& hole) -> std::optional<Circle>
  {
    Circle front;
    if (flange_hough_.fitAt(edges_, preprocessed_.size(), front_search, {hole.x, hole.y}, matcher_.backFlange(),
                            front) &&
        front.score >= flange_search.min_score && matcher_.accepts(front, hole) && matcher_.explainsFit(front, flange))
      return front;
    return std::nullopt;
  };
  if (const auto hole = matcher_.matchHole(flange, holes_))
  {
    // The spool's support is the better of the two rims: a front rim partly hidden by its own
    // back flange must not lose the target to a neighbour for it. The rim about the hole, when
    // better supported, replaces the fit only when that is off the hole by more than
    // concentric_tolerance, or smaller than it by as much (the fit took a rib inside the rim):
    // an ellipse fit on the rim measures better than a circle about the hole. On a rim cut by
    // the frame border a tie will do (scores cap at 1): the fit to its arc is the less certain.
    Circle kept = flange;
    if (const auto front = frontAbout(*hole);
        front && (cutByBorder(flange) ? front->score >= flange.score : front->score > flange.score))
    {
      const double tol = matcher_.tolerancePx();
      if (std::abs(hole->x - flange.x) > tol || std::abs(hole->y - flange.y) > tol ||
          front->r_vertical > flange.r_vertical + tol)
        kept = *front;
      kept.score = front->score;
    }
    return SpoolMatch{kept, hole};
  }
  for (const Circle& hole : holes_)
    if (const auto front = frontAbout(hole))
      return SpoolMatch{*front, hole};
  return std::nullopt;
}

}  // namespace spool_vision
