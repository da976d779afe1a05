// The whole pipeline: pre-processing, Hough for flange and hole, MCHT matching and geometry.
#pragma once

#include <array>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "spool_vision/concentric_matcher.h"
#include "spool_vision/detector_params.h"
#include "spool_vision/hough_accumulator.h"
#include "spool_vision/moving_edges.h"
#include "spool_vision/preprocessor.h"
#include "spool_vision/rim_pose_search.h"
#include "spool_vision/spool_geometry.h"
#include "spool_vision/types.h"

namespace spool_vision
{
class SpoolDetector
{
public:
  /// Throws ParamError when `params` are inconsistent.
  explicit SpoolDetector(const DetectorParams& params = DetectorParams());

  /// Replaces the parameters (validated; throws ParamError and keeps the old ones on error).
  void setParams(const DetectorParams& params);
  const DetectorParams& params() const
  {
    return params_;
  }

  /// Camera intrinsics for frames of the matching size. Without them (or for another size) the
  /// thesis camera scaled to the frame is used; usingFallbackCamera() tells which applied last.
  /// The camera's lens table (undistortionTable()) and geometry are built here, not in the first
  /// frame. Throws std::invalid_argument on invalid intrinsics.
  void setCamera(const CameraIntrinsics& camera);
  void clearCamera();
  bool usingFallbackCamera() const
  {
    return using_fallback_;
  }

  /// Processes one frame. Throws std::invalid_argument on an empty, too small or mistyped
  /// image. Steady state (same size and format) does not allocate (test_allocations counts every
  /// malloc), except with morphology or min_component_area on (seed.yaml): OpenCV's morphology
  /// and connected components allocate on every call. With a camera that has lens
  /// distortion the edges are undistorted (EdgeDetector::setUndistortion) and every circle is
  /// measured in the undistorted image; the circle centres and the reference in the result are
  /// then mapped back to where they appear in the frame given (radii stay those of the
  /// undistorted image), while the candidates below stay undistorted and preprocessed() is the
  /// frame's own geometry.
  /// Threads: the whole call runs on the calling thread, OpenCV's worker pool included (the
  /// colour conversion goes through as one row; see Preprocessor::toGray), for every filter but
  /// `median`, `average` and the thesis' binarization, morphology and area opening, which OpenCV
  /// may split among its threads. One detector per thread; different detectors share nothing.
  SpoolDetection detect(const cv::Mat& image, PixelFormat format);
  /// detect() with the flange searched only in `window` (centres and radii): while a track holds
  /// the spool, a concentric rib ring or a neighbour outside the window cannot be taken for its
  /// flange, only the square the window's rims can reach is preprocessed and searched for edges
  /// (the same pixels and edges there as detect()'s, but for the edge budget now spent on that
  /// square alone), and the vote spans a few radii instead of the whole
  /// working range. A window with a rim prediction (window->rim) is first measured along that
  /// rim by moving edges (MovingEdges, window->rim_reach px each way, edges of either polarity), kept when it scores as
  /// the window demands with its vertical semi-axis and centre in the window; its bore is then fitted at its known size
  /// about the window's centre (window->bore_reach px), and only the bore's surroundings are preprocessed; its edges on
  /// the fit are the rim SpoolGeometry fits the pose to. Where that rim is not found, the window is searched as above.
  /// Without `window`, detect() exactly.
  SpoolDetection detect(const cv::Mat& image, PixelFormat format, const std::optional<FlangeWindow>& window);
  /// The camera the last frame was measured with (the thesis camera when none fit the frame);
  /// the thesis camera at 640x480 before any frame.
  CameraIntrinsics camera() const;
  /// The camera a frame of `size` is measured with: setCamera()'s when its size matches, else the
  /// thesis camera scaled to `size` (fallback_focal_length).
  CameraIntrinsics cameraFor(cv::Size size) const;

  /// Intermediate results of the last frame, for overlays and debugging.
  const cv::Mat& preprocessed() const
  {
    return preprocessed_;
  }
  /// The last flange search's candidates (the flange_retry search's when it ran).
  const std::vector<Circle>& flangeCandidates() const
  {
    return flanges_;
  }
  /// The hole candidates of the result's target.
  const std::vector<Circle>& holeCandidates() const
  {
    return holes_;
  }

  /// Least support of the hole rim of a spool found by the flange_retry search.
  static constexpr double kRetryHoleScore = 0.35;
  /// The search for a spool nearer the reference than the one taken (searchNearer()) asks its
  /// flange for (1 - this) of its rim: a grey or glossy face on a wall as light, or touching its
  /// neighbours, shows a third to half of its rim (packed seed 7 #124 at 640x480: 0.34). Its hole
  /// needs kNearerHoleScore of its rim: the ghosts such weak flanges admit (arcs of a neighbour
  /// and the boards) came with hole rims of 0.37 (hard seed 7 #69), the spools with 0.5 and up.
  static constexpr double kNearerSensitivity = 0.7;
  static constexpr double kNearerHoleScore = 0.5;
  /// The smallest frame the detector accepts (each side, px).
  static constexpr int kMinImageSide = 32;
  /// A window's flange rim reaches at most this many times its largest radius from the window's
  /// centres (a turned rim's ellipse, the rim fit's band), plus kWindowPad px.
  static constexpr double kWindowSlack = 1.08;
  /// A flange in a window needs (1 - this) of its rim, as `sensitivity` does in the whole frame
  /// (the larger of the two applies)
  static constexpr double kWindowSensitivity = 0.75;
  static constexpr double kWindowPad = 6.0;
  /// A bore measuring this many times the size its flange allows (or more) says the "flange" is
  /// an inner ring (issue 28: a raised rib on a face that overfills the frame); the outer rim is
  /// searched within kOuterRimMargin of the size the bore gives.
  static constexpr double kInnerRingRatio = 1.12;
  static constexpr double kOuterRimMargin = 0.12;
  /// Rims searched outwards from an inner ring at most (a face carries a few rib rings)
  static constexpr int kMaxRibRings = 3;
  /// The outer rim is taken where its own hole is that bore: its centre within concentric_tolerance
  /// and its radius within kOuterRimMargin, or this many px where that is more (a 13 px bore at
  /// 320x240 is measured to about a pixel).
  static constexpr double kOwnBoreAgreementPx = 1.0;
  /// The bore's rim at its own size must outscore the one at the flange's size by this (rim
  /// support, 0-1): rib rings gave 0.31 against 0.89 (closed-loop seed 1844) and 0.54-0.65 against
  /// 1.0 (seed 1918), a drawn bore of the right size 1.0 against 1.0 a pixel and a half larger.
  static constexpr double kOwnBoreMargin = 0.1;
  /// ... unless it holds the hole inside it and is larger by this fraction of it, or this many px
  /// where that is more: a sharp rim supports circles within its fit's band, not this far out.
  static constexpr double kOwnBoreBand = 0.25;
  static constexpr double kOwnBoreBandPx = 3.0;
  /// A flange at least this wide for its height (seen within about 22 deg of its axis) has its
  /// hole's own fit taken as the bore's size, and a tie with a circle holding it as evidence.
  static constexpr double kNearAxisAspect = 0.93;
  /// ... where the hole's rim scores this much (nearly whole: its size is then measured).
  static constexpr double kSharpHoleScore = 0.8;
  /// The farthest (times the bore's radius) a sharp hole (kSharpHoleScore) of a rim outside an
  /// inner ring may lie from the bore measured inside it and still be that bore: two bores of one
  /// size this near overlap over most of their area.
  static constexpr double kSharpBoreAgreement = 0.5;
  /// A bore rim this whole is sharp enough for bearingSupport().
  static constexpr double kSharpBoreScore = 0.95;
  /// Around a tracked rim's hole window the pixels within this many of its largest radius are
  /// preprocessed: the bore's disc contrast reads a ring out to twice its radius.
  static constexpr double kDiscReach = 2.2;
  /// Along a predicted rim an edge needs this fraction of edge_threshold: it is searched for only
  /// within a few px of where the rim must be, while the whole frame's threshold keeps clutter out
  /// of the Hough votes and drops a faint rim (a grey face on a grey wall) with it.
  static constexpr double kAlongRimThreshold = 0.5;
  /// A tracked rim keeps the edges within 2% of its radius of the fit (RimSearch::max_band_share;
  /// at least 2 px): 1.2 px is 160x120's closest flange's 2%, 5 px 1280x720's. Not for the rim
  /// outside an inner ring, predicted from the ring's size (its prediction is a guess).
  static constexpr double kTrackedRimBandShare = 0.02;
  /// px: a smaller bore (160x120) is not measured again at its known size: half a rim of a few
  /// pixels has too few edges to place it better than the free fit, and there the lit band is
  /// within a pixel of the rim anyway.
  static constexpr double kMinKnownSizeRadius = 6.0;
  /// Where the whole frame gives no spool, it is searched again with this many times edge_budget,
  /// and a spool is taken from that only where its flange and hole rims both score
  /// ConcentricMatcher::kSolidRimScore, or where its bore's whole rim is sharp (takesSecondSearch()).
  /// On the hard and oblique sets of seeds 7 and 11 (640x480 and 160x120) this found 8 more
  /// targets and lost none, one more detection 10% off in depth; taking any spool (at 4/3 the
  /// budget) found 10 more on seed 7 but put 16 more over 10% off.
  static constexpr double kRetryBudgetScale = 2.0;
  /// The second search's spool with a hole rim under kSolidRimScore is taken where its bore, at
  /// least kSecondSearchBoreRadius, scores kSecondSearchBoreScore and its flange
  /// kSecondSearchRimScore: a flange seen 26-33 deg off its axis, its rim half hidden by its back
  /// flange's silhouette or cut by the frame, scores 0.59-0.77 about a sharp dark bore (oblique
  /// seed 7 #107, seed 13 #126, #192; hard seed 11 #188, seed 13 #85), while clutter's circles
  /// found with the larger budget came with a hole rim of 0.22-0.89 (oblique seed 7 #85, #124,
  /// #157, seed 11 #0, #18, #110). Only from 12 px up does a pixel stay under a tenth of the
  /// bore's size, so that the bore measured at its own size tells a rib ring taken as the flange
  /// (ownBore()): on smaller bores (8-11 px at 320x240, 4-5 px at 160x120) bores scoring 1.0 came
  /// with rib rings 13-44% deep.
  static constexpr double kSecondSearchBoreScore = 0.95;
  static constexpr double kSecondSearchBoreRadius = 12.0;
  static constexpr double kSecondSearchRimScore = 0.55;
  /// A free hole fit's centre lies within this fraction of its radius of the bore's.
  static constexpr double kKnownSizeShift = 0.25;
  /// How far (px) the reported bore of a pose near its axis may move when measured again on the
  /// pose's ellipse: it was measured at its known size already (the misses were 1.0-1.2 px), and a
  /// search over a quarter of its radius on every such frame cost 14% of main 640x480's
  /// instructions.
  static constexpr double kReportedBoreShift = 2.0;
  /// rad: a spool axis this far off the optical axis (offAxis()) puts its bore's lit wall on
  /// another side than the principal point's (remeasureBore()), and its own rim, cut by
  /// the frame, is sampled as densely as a whole one (measureObliqueRim()).
  static constexpr double kObliqueAxisAngle = 10.0 * M_PI / 180.0;
  /// The scales of the bore's ellipse obliqueInnerRing() tries, and the least that says the flange
  /// is an inner ring: on oblique seeds 7, 11 and 13 at 640x480, the right flanges' bores measured
  /// 0.88-1.04 of their size (5th-95th percentile; at most 1.08), rib rings' 1.10-1.32.
  static constexpr double kOwnScaleMin = 0.7;
  static constexpr double kOwnScaleMax = 1.35;
  static constexpr double kObliqueInnerRingScale = 1.1;
  /// A rim found about a bore (spoolAboutHoles()) supported on kBoreAgreedSupport of its samples,
  /// under kObliqueSpoolSupport, is the spool where the bore at its own size agrees with it within
  /// kOwnScaleAgreement (a rib ring's bore measures 1.1-1.3 of what the ring allows, a joint
  /// silhouette's under 0.92).
  static constexpr double kBoreAgreedSupport = 0.3;
  static constexpr double kOwnScaleAgreement = 0.06;

private:
  /// A rim's pose as RimPoseSearch found it with the rim (undistorted px) it gave a spool taken
  /// about a bore (searched_pose_: the reported pose's rim fit starts from it too while that rim is
  /// the flange), or an inner ring's pose carried out to the flange outside it (BoreRing,
  /// searchedPoseSupportsMore()'s ring_pose).
  struct SearchedPose
  {
    Circle flange;
    cv::Point3d position;  ///< m, camera optical frame
    cv::Vec3d axis;        ///< unit
  };
  const SpoolGeometry& geometryFor(cv::Size size);
  /// preprocessed_ and the edge detector's gradients for the circles whose centres lie in
  /// `centres` and reach `reach` px beyond (undistorted px): only their pixels; with
  /// `flange_edges`, edges_ too (edge_threshold).
  void prepareAround(const cv::Mat& image, PixelFormat format, const cv::Rect2d& centres, double reach,
                     bool flange_edges);
  /// `window`'s rim measured by moving edges (detect()); false when it is not found as
  /// `flange_search` (the window's) demands. `tracked`: the window is a track's (the outermost
  /// detect()), whose prediction is sharp: the fit keeps kTrackedRimBandShare.
  bool measureAlongRim(const cv::Mat& image, PixelFormat format, const FlangeWindow& window,
                       const HoughSearch& flange_search, bool tracked, Circle& flange);
  /// rim_: the edges of the result's flange rim (for SpoolGeometry::fitRimPose).
  void gatherRim(const SpoolDetection& result, Polarity polarity);
  /// Whether the result's bore, measured at its own size, says its flange is an inner ring: then
  /// `bore` is the hole itself where it measures kInnerRingRatio times the size the flange gives
  /// it or more, else the best circle within that size of the hole's centre, from
  /// kInnerRingRatio times that size up to `hole_search`'s largest, outscoring the hole by
  /// kOwnBoreMargin, or scoring as well where it holds the hole inside it (these two on a flange
  /// within kNearAxisAspect of round and a hole of kMinKnownSizeRadius or more scoring
  /// kSharpHoleScore) (px, undistorted). Uses hole_edges_ and own_bores_.
  bool ownBore(const SpoolDetection& result, const HoughSearch& hole_search, Circle& bore);
  /// Whether `hole` (px, undistorted), held inside the larger rim `rim`, is the lit lens of a bore
  /// whose front rim is `rim`: the mean grey level of its core (kLensCore of its radius) above that
  /// of the ring between the two rims. A dark bore inside a groove or hub ring on the face (the
  /// ring's inside is face, lighter than the bore: heldout_v2 pos_013) is not: 4 against 80 there,
  /// 183 against 58 for the lens of hard seed 7 #10.
  bool litInside(const Circle& hole, const Circle& rim) const;
  /// Where the lens puts the circle (`centre`, `r`; undistorted px) in the frame: its centre (x, y)
  /// and its radius there (z), px.
  cv::Point3d inFrame(const cv::Point2d& centre, double r) const;
  static constexpr double kLensCore = 0.8;
  /// The rim support a spool's bearing is weighed with (ConcentricMatcher::targetCost()): its
  /// flange's score, or, about a sharp bore (kSharpBoreScore, kMinKnownSizeRadius and up), its
  /// cube root relative to kSolidRimScore. targetCost() guards against a weak circle closed by
  /// arcs of several objects in the middle of the frame; a circle with a sharp bore of its own
  /// size at its centre is no such ghost, and a glossy band or a dark wall that leaves its rim at
  /// 0.5 must not hand the target to a neighbour 15% farther off the puller (hard seed 7 #40 at
  /// 1280x720, hard seed 11 #68 at 640x480).
  static double bearingSupport(const SpoolMatch& match);
  /// A candidate's match whose hole scores under kSharpHoleScore, with its flange fitted again on
  /// the circle nearby that the most edges support (HoughAccumulator::refitOnMostSupport):
  /// replaced by that flange's match where its hole scores kSharpHoleScore (a weak ring on a
  /// neighbour's face cut by the border scores higher for a refit too) and its flange higher. A rim fit
  /// that slid onto a neighbour's silhouette beside the rim has its hole search off the bore
  /// (heldout_v2 pos_002: hole score 0.55 for the fit, 1.0 for the refit).
  void refitWeakMatch(const HoughSearch& hole_search, const HoughSearch& flange_search, SpoolMatch& match);
  /// Moves the result's pixel centres from the undistorted image to the frame (distortPixel).
  static void toFramePixels(const CameraIntrinsics& camera, SpoolDetection& result);
  /// toFramePixels()'s inverse (undistortPixel).
  static void toUndistortedPixels(const CameraIntrinsics& camera, SpoolDetection& result);
  /// Moves the result's pixel centres (reference, flange, hole, lens, lens centroid) by `move`.
  template <typename Move>
  static void movePixelCentres(SpoolDetection& result, Move move);
  /// Whether the second search's `second` (kRetryBudgetScale) is taken where the first found no
  /// spool: both its rims solid (ConcentricMatcher::kSolidRimScore), or its bore's whole rim sharp
  /// (kSecondSearchBoreScore, kSecondSearchBoreRadius and up) and its flange kSecondSearchRimScore,
  /// or its weak match's flange replaced by the rim about its bore (weak_match_rim_taken_),
  /// or found about a bore whose size, measured at the size the rim gives it, agrees with the rim
  /// (bore_agrees_at_own_size_) and its flange kSecondSearchRimScore: a dark bore seen 34-38 deg off
  /// its axis scores 0.5-0.6 as a free circle (oblique seed 19 #96, seed 89 #64 at 640x480), while
  /// a rib ring's bore measures larger than the ring allows,
  /// or found about a bore too small to measure (small_bore_spool_taken_): such a spool is sought
  /// only in the frame's last search, which is the second one where the first filled the edge
  /// budget, and its bore can pass none of the tests above.
  bool takesSecondSearch(const SpoolDetection& second) const;
  /// The most edges kept from a region of `size` (edge_budget; kRetryBudgetScale times it in the
  /// second search).
  std::size_t edgeBudget(cv::Size size) const;
  /// hole_edges_: the edges at hole_edge_threshold of a rim whose centre lies in `centres`
  /// (a rectangle, or a point) and whose radius is at most `reach` px; placed in `linear` light
  /// when given (EdgeDetector::extract).
  void extractHoleEdges(const cv::Rect2d& centres, double reach, const LinearLight* linear = nullptr);
  /// Picks the target among the flange candidates (flanges_, found in `flange_search`) and
  /// finds its hole in `hole_search` (thesis Rule 2); without a hole rim, `evidence` decides.
  /// Returns the target's cost (ConcentricMatcher::targetCost(), px); infinite without a hole
  /// rim, and in mode cht (no cost there). Candidates that cannot cost less than `bound` are
  /// not tried.
  double selectTarget(const cv::Point2d& reference, const HoughSearch& flange_search, const HoughSearch& hole_search,
                      SpoolEvidence evidence, double bound, SpoolDetection& result);
  /// mcht: of the flanges in order_, the spool with a concentric hole rim that costs least and
  /// under `best_cost` (which it lowers to that cost); its hole search's circles are left in
  /// target_holes_.
  std::optional<SpoolMatch> nearestSpool(const cv::Point2d& reference, const HoughSearch& flange_search,
                                         const HoughSearch& hole_search, double& best_cost);
  /// flange_retry: the flange search again with either polarity (after flange_hough_.detect() of
  /// `flange_search`), less the ghosts enclosing a solid rim, each spool needing a hole rim of
  /// kRetryHoleScore. Replaces `result` and returns true when its target costs less than `cost`
  /// (selectTarget()'s of the first search).
  bool searchEitherPolarity(const cv::Point2d& reference, const HoughSearch& flange_search,
                            const HoughSearch& hole_search, double cost, SpoolDetection& result);
  /// The flange centres (in preprocessed_ px) of spools whose hole can cost less than `cost`
  /// (ConcentricMatcher::targetCost()): within cost plus the widest hole window's reach (that of
  /// the largest flange) of the reference.
  cv::Rect2d centresCostingLess(const cv::Point2d& reference, const HoughSearch& flange_search,
                                const HoughSearch& hole_search, double cost) const;
  /// A spool nearer the reference than the one taken (costing `cost`) whose rim the flange search
  /// missed: that search's votes measured again over centresCostingLess(), its least rim score
  /// lowered to 1 - kNearerSensitivity, each spool needing a hole rim of kNearerHoleScore and its
  /// whole rim in the frame. Right after flange_hough_.detect() of `flange_search`. Replaces
  /// `result` and `cost` (with its target's) and returns true when its target costs less than `cost`.
  bool searchNearer(const cv::Point2d& reference, const HoughSearch& flange_search, const HoughSearch& hole_search,
                    double& cost, SpoolDetection& result);
  /// `flange`'s spool: the flange (measured again about the hole when the fit was off it) and a
  /// hole found in `hole_search` that passes the concentric rule; nullopt when none does.
  std::optional<SpoolMatch> matchSpool(const Circle& flange, const HoughSearch& hole_search,
                                       const HoughSearch& flange_search);
  /// spool_evidence bore, when no flange has a concentric hole rim: the first candidate (in
  /// order_) whose rim is (nearly) whole in view and scores at least flange_only_score, and
  /// whose concentric window shows a disc of the bore's size that differs from the face around
  /// it by bore_contrast.
  std::optional<std::size_t> strongFlangeWithBore(const HoughSearch& hole_search) const;
  /// The target's hole measured again at the size its flange gives it (the rim's far side hides
  /// behind the lit bore wall, so a free fit comes out small and off centre); kept (true) when its
  /// support passes hole_sensitivity. Its centre is searched within `max_shift` px of the hole's
  /// (default kKnownSizeShift of its radius plus a px).
  /// `axis` (unit, camera optical frame, into the spool; unknown: along the optical axis) says
  /// which side of the rim the lit wall hides, the one away from the axis's vanishing point, and
  /// how much narrower than high the bore's ellipse is (the cosine of its angle to the line of
  /// sight; without an axis, the flange's measured width scaled). `sized_by_pose` (with `axis`):
  /// measured too at the size `result`'s pose (position, m, and axis) projects its 3.6 cm front
  /// rim to, and the better supported of the two kept; both are then the projected ellipse of a
  /// level spool's bore (boreShape()'s `projected`), tilted where the bore is above or below the
  /// axis's vanishing point: this is the bore that is reported.
  bool measureBoreAtKnownSize(SpoolDetection& result, std::optional<double> max_shift = std::nullopt,
                              const std::optional<cv::Vec3d>& axis = std::nullopt, bool sized_by_pose = false);
  /// The bore measured again at its known size once the flange's pose is measured (a hole score
  /// unchanged: it stays the evidence the spool was taken on); the position moved through it.
  /// With the spool's `axis` (seen far off it: offAxis()), the lit wall on the side it gives;
  /// without, the flange's measured ellipse gives the bore's shape. `sized_by_pose`: as
  /// measureBoreAtKnownSize(); `max_shift` too (px the centre may move; default: a quarter of its
  /// radius and a px).
  void remeasureBore(const SpoolGeometry& geometry, const std::optional<cv::Vec3d>& axis, bool sized_by_pose,
                     SpoolDetection& result, std::optional<double> max_shift = std::nullopt);
  /// Whether `result`'s bore was measured round while its flange measures as an ellipse narrower
  /// than kNearAxisAspect: the bore was measured on the flange's Hough circle, before the flange's
  /// pose, and where the pose gives no axis nothing measured it again (a 0.8-wide dark bore 2-5
  /// px off centre and 10-20% large: oblique seed 7 #74, seed 19 #1 at 640x480).
  static bool roundBoreInOvalFlange(const SpoolDetection& result);
  /// Whether `circle` was measured as an ellipse narrower than kNearAxisAspect (a circle fit has no
  /// r_horizontal: round).
  static bool oval(const Circle& circle);
  /// measureBoreAtKnownSize() about the flange's centre instead of the hole's, where the flange is
  /// within kNearAxisAspect of round (near its axis the bore is on the flange's centre); true and
  /// `result.hole` replaced where it finds a bore whole enough in the frame
  /// (kMinHoleVisibleFraction). For a hole circle that followed a lit lens inside the bore, 7-12 px
  /// off its centre, beyond the known-size fit's reach from it: the pose's axis then came out 16 deg
  /// off and the depth 3.6% short (approach_hard seed 83011 at 1.0 m).
  bool measureBoreAboutFlangeCentre(SpoolDetection& result);
  /// The bore of a spool seen far off its axis (offAxis()) measured at its own size (the
  /// ellipse's shape as measureBoreAtKnownSize() with the axis sets it, its scale free in
  /// kOwnScaleMin..kOwnScaleMax: HoughAccumulator::fitCentreAndScale()) into `bore`; true where
  /// it is kObliqueInnerRingScale or more of the size the flange gives it (the flange is then an
  /// inner ring: its rib).
  bool obliqueInnerRing(const SpoolDetection& result, Circle& bore);
  /// `spool`'s bore measured at its own size: the ellipse's shape as measureBoreAtKnownSize() sets
  /// it with `axis` where that is offAxis() (camera optical frame; a round shape otherwise), its
  /// scale free in kOwnScaleMin..kOwnScaleMax of the size the flange gives it
  /// (HoughAccumulator::fitCentreAndScale()); none where its rim scores under hole_sensitivity.
  std::optional<Circle> boreAtOwnSize(const SpoolDetection& spool, const cv::Vec3d& axis);
  /// Where `result`'s bore, under kSilhouetteBoreWhole at the size its flange gives it and measured
  /// at its own size (boreAtOwnSize(), with the pose's axis where it is offAxis()), is
  /// kSilhouetteBoreScale or less of the size its flange gives it and is no lit lens inside the bore
  /// (litInside()), the flange is an outline larger than the spool's front rim: the joint silhouette
  /// of its front and back flanges seen 25-40 deg off its axis, whose circle is 15-25% large and off
  /// the bore towards the back flange (depth 8-20% short). The front rim is then searched about the
  /// bore at its own size (searchRimAbout(): the depth its size gives, RimPoseSearch) and taken, with
  /// that bore, where it has kObliqueSpoolSupport and agrees with the bore (boreAgreesWith()); the
  /// pose is measured again. Where none is and the outline's circle is weak (under
  /// ConcentricMatcher::kSolidRimScore: the two flanges' arcs, 0.46-0.58 on oblique seeds 43 and 89)
  /// it is no spool: `result` is cleared (a right flange whose dark bore measured small is solid,
  /// 0.85-1.0 on the packed and hard sets), and false is returned: the frame is not searched again
  /// with a larger edge budget (its edges found the spool's outline; the second search took a rib
  /// ring about the bore, 63% deep, on oblique seed 43 #7). Else `result` stays, and true.
  bool frontRimAboutOwnBore(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                            SpoolDetection& result);
  /// `result` cleared to no spool, with the puller reference at the nominal distance as every
  /// result without a spool has it (undistorted px).
  static void noSpool(const SpoolGeometry& geometry, SpoolDetection& result);
  /// frontRimAboutOwnBore()'s bound: a bore this much smaller than its flange allows is not its
  /// rim's (the hard set's right flanges measure 0.74-0.82 only about a lit lens: litInside()).
  static constexpr double kSilhouetteBoreScale = 0.8;
  /// A bore whose rim at the size the flange gives it scores this much is that size (a bore 0.8 of
  /// it would leave that rim bare): frontRimAboutOwnBore() does not measure it (the joint
  /// silhouettes' bores scored 0.30-0.95 there; two in three of the hard set's right ones 0.97-1).
  static constexpr double kSilhouetteBoreWhole = 0.97;
  /// Whether `bore` (measured at its own size) is within kOwnScaleAgreement of the size `flange`
  /// gives it (ConcentricMatcher::holeRadius()).
  bool ownSizeAgrees(const Circle& bore, const Circle& flange) const;
  /// Whether `spool`'s hole, measured at its own size (boreAtOwnSize() with `axis`, camera optical
  /// frame; NaN: unknown), is within kOwnScaleAgreement of the size its flange gives it
  /// (undistorted px).
  bool boreAgreesAtOwnSize(const SpoolDetection& spool, const cv::Vec3d& axis);
  /// measureBoreAtKnownSize()'s ellipse, centre reach, lit-wall side and search for `result`'s
  /// bore; none where the bore is under kMinKnownSizeRadius. With `axis` and `projected`, the
  /// ellipse is the bore's front rim projected with the axis's yaw and a level spool's pitch
  /// (SpoolGeometry::boreEllipse(), levelAxis()), scaled to the height the flange gives it; with
  /// `axis` alone, upright (the shape the checks that judge the spool by its bore were set on).
  struct BoreShape
  {
    EllipseShape ellipse;  ///< px
    double shift = 0.0;    ///< px the centre may move
    cv::Point2d side;      ///< the sharp half's direction; zero: the whole rim
    HoughSearch search;
  };
  std::optional<BoreShape> boreShape(const SpoolDetection& result, std::optional<double> max_shift,
                                     const std::optional<cv::Vec3d>& axis, bool projected);
  /// `axis` (unit, camera optical frame) with the pitch of a level spool (tracker level_pitch) where
  /// the tracker takes spools as level (level_pitch_sigma > 0); else, or where `axis` does not point
  /// away from the camera, `axis`.
  cv::Vec3d levelAxis(const cv::Vec3d& axis) const;
  /// hole_edges_: the edges within `reach` px of `hole`'s centre, placed in the frame's light.
  void extractBoreEdges(const Circle& hole, double reach);
  /// True where `axis` (unit, camera optical frame) is kObliqueAxisAngle or more off the optical
  /// axis; false where it is NaN.
  static bool offAxis(const cv::Vec3d& axis);
  /// mcht with a dark hole: the tracked flange (flanges_'s only one) and its bore measured at its
  /// known size about the window's centre (where the track puts the bore's front centre), when
  /// that bore passes the concentric rule, lies at the puller's level and counts on its flange
  /// (holeCountsOn); then `result` is that spool (and its lens) and true.
  /// Only the pixels about that bore are preprocessed (prepareAround()).
  bool boreAtPrediction(const cv::Mat& image, PixelFormat format, const FlangeWindow& window, SpoolDetection& result);
  /// holes_: the hole rims among hole_edges_ (hole_hough_), less those scoring under
  /// weak_hole_score whose disc does not differ from the face by bore_contrast, or, in a
  /// whole-frame search from kMinKnownSizeRadius up, is not darker than it by that much
  /// (signedBoreContrast()).
  void detectHoles(const HoughSearch& hole_search);
  /// Whether `match`'s hole is evidence of a bore: not on a flange under kBareHoleFlangeScore
  /// with a hole rim under kSharpHoleScore whose disc differs from the face by less than
  /// bore_contrast either way and is not lit through (litBoreContrast()); else always on a flange
  /// with at least kCutFlangeVisibleFraction of its rim in the frame; on one cut by the border
  /// only with a rim scoring cut_flange_hole_score or a disc that differs from the face by
  /// bore_contrast.
  bool holeCountsOn(const SpoolMatch& match) const;
  /// holeCountsOn()'s weak flange: on the 41 rendered sets, a bare hole refused under it made 17
  /// more targets found and 38 fewer detections over 10% off in depth (oblique at 160x120 and
  /// 320x240), and 5 more neighbours reported where the target's circle had been 15-24% off; under
  /// 0.8, a packed target seen 5 deg off its axis gave way to its neighbour (packed seed 103 #287 at
  /// 160x120); a refusal at any hole score, 4 more neighbours.
  static constexpr double kBareHoleFlangeScore = 0.7;
  /// How much a disc of radius `r` px about `centre` (undistorted pixels) differs from the face
  /// around it, read where the lens puts it in the frame (fraction of full scale, 0 when not the
  /// same way on all four sides).
  double boreContrast(const cv::Point2d& centre, double r) const;
  /// boreContrast() with its sign: positive where the disc is darker than the face on all four
  /// sides (a dark bore), negative where it is lighter (a lit lens, copper, a label). `aspect`:
  /// the disc an ellipse `r` high and aspect * r wide (its ring the same shape).
  double signedBoreContrast(const cv::Point2d& centre, double r, double aspect = 1.0) const;
  /// A bore seen through, a lit lens in part of it: the smaller of how much darker than the face
  /// on all four sides its darker half is and how much brighter its brightest fifth is (fraction
  /// of full scale, 0 where either fails). Where the lens covers a third of it on a face shaded
  /// across it, boreContrast() is 0 (approach_hard seed 84 at 1.0-1.1 m).
  double litBoreContrast(const cv::Point2d& centre, double r) const;
  /// The see-through lens inside the target's hole rim, if one shows (SpoolDetection::lens).
  void findLens(SpoolDetection& result);
  /// How MovingEdges searches a predicted rim: `reach` px either way, either polarity, half of
  /// edge_threshold, smoothed as the detector's filter smooths.
  RimSearch rimSearch(double reach) const;
  /// rimSearch() for RimPoseSearch about a flange of `flange_px` (its vertical semi-axis, px):
  /// kObliqueRimReach of it, at least kObliqueRimReachPx.
  RimSearch obliqueRimSearch(double flange_px) const;
  /// Whole frame: a spool seen far off its axis, found about its bore. Where a spool was taken
  /// already (`result`, its targetCost() `bound`; infinite = none), only another spool nearer the
  /// `reference` can replace it: candidates costing less, centred outside its rim (a turned target
  /// whose joint silhouette with its back flange puts the hole out of the concentric window loses
  /// to a neighbour otherwise: heldout_v2 pos_013).
  /// About each of the first kObliqueCandidates flange candidates nearest the reference (at least
  /// kObliqueRimMinRadius), holes are searched within kObliqueBoreShift of its size of its centre
  /// (a circle the Hough search fitted around an oblique flange and its back flange's silhouette is
  /// that far off the bore) at 0.5-1.2 the size the candidate gives; about the best kObliqueHoles
  /// whose rim is in the frame (kMinHoleVisibleFraction), at least kMinKnownSizeRadius, and whose
  /// disc shows (bore_contrast), the rim is searched (RimPoseSearch) from kObliqueNearest to kObliqueFarthest of
  /// the depth the hole's size gives (within distance_min..distance_max). The first rim with
  /// kObliqueSpoolSupport whose bore is at the puller's level and agrees with it (boreAgreesWith, or
  /// boreAgreesAtOwnSize where that fails), on a rim cut by the border (cutByBorder) only with a hole rim of
  /// cut_flange_hole_score (a disc alone there was a label's print on a neighbour), is the spool: `result` (undistorted
  /// px, its rim in oblique_rim_) and true. Where no candidate's window leads to one, the bores
  /// beside each (besideSilhouette()). With `bore_led` and no spool taken, where no candidate gives one, the
  /// kBoreLedHoles bores nearest the reference found over the whole frame are searched the same way, then
  /// smallBoreSpool().
  /// The candidates are `flanges`, tried in order of ConcentricMatcher::targetCost().
  bool obliqueSpool(const cv::Mat& image, PixelFormat format, const cv::Point2d& reference,
                    const std::vector<Circle>& flanges, const HoughSearch& hole_search, double bound, bool bore_led,
                    SpoolDetection& result);
  /// obliqueSpool()'s last step about a candidate `flange` (undistorted px), after every
  /// candidate's window `searched` (kObliqueBoreShift of its size about its centre) led to no spool: seen 35-40 deg
  /// off its axis, the joint silhouette's circle is up to kSilhouetteBoreShift of the flange's
  /// height aside of the front bore. Holes are searched (`holes`: the candidate's sizes from
  /// kMinKnownSizeRadius up; its centre window is overwritten) in the rows of `searched` out to kSilhouetteBoreShift
  /// either side; those outside `searched` and scoring weak_hole_score are searched as spoolAboutHoles() does
  /// (`reference`, `bound`). True with the spool in `result` (undistorted px, its rim in oblique_rim_).
  bool besideSilhouette(const cv::Mat& image, PixelFormat format, const cv::Point2d& reference, const Circle& flange,
                        const cv::Rect2d& searched, HoughSearch& holes, double bound, SpoolDetection& result);
  /// obliqueSpool()'s last resort: seen 25-40 deg off its axis at 160x120, a spool's dark bore
  /// measures 3-6 px, under the bores searched so far (kMinKnownSizeRadius), and its outline is no
  /// circle that leads to it. Bores from the hole search's least radius up to kMinKnownSizeRadius
  /// are sought about the first kObliqueCandidates of `flanges` in candidate_order_ (within
  /// kObliqueBoreShift of their size of their centres, in `rows`, px), those under weak_hole_score
  /// (a 3-4 px bore's rim, blurred, scores 0.55-0.7: oblique seed 131 #251 of 300 at 160x120) or
  /// inside a larger bore of holes_ (the lit lens seen through it: hard seed 7 #10, seed 89 #1 at
  /// 160x120) left out, and the kBoreLedHoles nearest the reference searched as spoolAboutHoles()
  /// does. True with the spool in `result` (undistorted px, its rim in oblique_rim_), and
  /// small_bore_spool_taken_ set.
  bool smallBoreSpool(const cv::Mat& image, PixelFormat format, const cv::Point2d& reference,
                      const std::vector<Circle>& flanges, const HoughSearch& hole_search, const cv::Rect2d& rows,
                      SpoolDetection& result);
  /// holes_ less those of `below` px and up, those scoring under `least` and those inside a bore of
  /// larger_bores_ (its lit lens).
  void keepBoresOutside(double below, double least);
  /// Where no spool was found: the first kObliqueCandidates flange candidates nearest the reference
  /// (ConcentricMatcher::targetCost()) searched for a bore in their concentric window larger than
  /// the match allows them (1 + hole_ratio_tolerance times the size they give it, up to
  /// kRibRingBoreMax), sharp (kSharpBoreScore), whole in the frame and kMinKnownSizeRadius and up,
  /// at the puller's level. Such a candidate is a rib ring or an inner ring, not the flange: a
  /// bore larger than a rim allows lies inside a larger rim. `result`
  /// holds it and its bore (undistorted px) for detect()'s outer-rim search, which must find the
  /// flange outside it, and true. Hard seed 7 #10 at 160x120: a face at 0.51 m overfilling the
  /// frame, its bore's lens lit, the ring at 0.65 of the rim with a bore 1.5 times what it allows.
  bool ringAboutLargeBore(const cv::Point2d& reference, const HoughSearch& hole_search, SpoolDetection& result);
  /// Where no spool was found, the rib ring spoolAboutHoles() found about a bore (bore_ring_: a
  /// rim searched about it on which the bore at its own size is kObliqueInnerRingScale or more of
  /// what the rim allows) taken into `result` with that hole (undistorted px), for detect()'s
  /// outer-rim search, which must find the flange outside it, from the ring's pose; true. False
  /// where there is none.
  bool takeBoreRing(SpoolDetection& result) const;
  /// The flange rim of `fit`'s pose as the image shows it (undistorted px): the 3-D circle of
  /// flange_diameter about fit.position, normal to fit.axis, projected at kRimExtentPoints points;
  /// centre and semi-axes are those of its extent, r their mean, score and visible fraction
  /// fit.rim's. MovingEdges' own rim model is a circle beyond 20% of ellipticity (37 deg off the axis).
  Circle rimSeenAt(const RimPoseFit& fit) const;
  /// holes_: hole_search's bore rims among hole_edges_ seen as a spool turned to `axis_yaw` (rad,
  /// atan2(x, z) of its axis, camera optical frame) shows them: each column's edges stretched by
  /// 1 / cos of the view there (the line of sight's yaw minus `axis_yaw`; at most
  /// RimPoseSearch::kWidestViewAngle), where a bore's ellipse, as narrow as that cosine, votes as a
  /// circle. r and r_vertical are the rim's height, r_horizontal its width (undistorted px).
  void detectTurnedBores(const HoughSearch& hole_search, double axis_yaw);
  /// How much a column `x` (undistorted px) is widened where a spool turned to `axis_yaw` is seen:
  /// 1 / cos of the view there, the view at most RimPoseSearch::kWidestViewAngle.
  double columnWidening(double x, double axis_yaw) const;
  /// stretched_edges_: `edges` with each column widened by columnWidening() (stretched_columns_);
  /// returns the stretched frame's size.
  cv::Size stretchEdges(const std::vector<EdgePoint>& edges, double axis_yaw);
  /// Column `x` and `window` (px) in the frame stretchEdges() made last.
  double stretchedColumn(double x) const;
  cv::Rect2d stretchedWindow(const cv::Rect2d& window) const;
  /// Circles found in that stretched frame back in the frame: r and r_vertical their height,
  /// r_horizontal their width there.
  void unstretch(double axis_yaw, std::vector<Circle>& circles) const;
  /// Where the centre of a spool nearer `reference` than `result` can be: within the result's
  /// bore's distance of it, outside the result's flange on the reference's side, at the puller's
  /// level rows (px, undistorted). Empty where there is no room.
  cv::Rect2d nearerThan(const cv::Point2d& reference, const SpoolDetection& result) const;
  /// Whole frame, after the result's pose is measured (its axis finite), where nearerTurnedSpool()
  /// found no bore: a flange nearer the reference, turned farther from the camera than the
  /// result, whose ellipse the circle search missed (a packed shelf seen 25-40 deg off its axes at
  /// 160x120: the neighbour seen 10 deg off taken, the target beside it at 31 deg scoring under
  /// min_score, its 3.4 px bore too small for its rim). The frame's edges stretched about the
  /// result's axis (stretchEdges()) round the ellipses of the spools standing parallel to it; the
  /// kTurnedFlanges circles found there nearer the reference (nearerThan()), of sizes within
  /// kTurnedFlangeSizes of the result's, are searched about their centres at the depths about Eq.
  /// 3.2's on their height (kTurnedNearest..kTurnedFarthest) with axes within kNeighbourAxisSpread
  /// of the result's (RimPoseSearch::searchAbout), and the first whose rim keeps
  /// kTurnedFlangeSupport of its samples at a plausible pose
  /// (SpoolGeometry::plausiblePose), at the puller's level, with a dark disc where its bore's front
  /// rim projects (bore_contrast), replaces `result` (undistorted px; the hole from the pose,
  /// measured at its known size where it is large enough) and returns true. Only where a spool at
  /// the reference column is seen kTurnedFlangeView or more off the result's axis.
  bool nearerTurnedFlange(const cv::Mat& image, PixelFormat format, const cv::Point2d& reference,
                          const HoughSearch& flange_search, SpoolDetection& result);
  /// Whole frame, after the result's pose is measured: a spool nearer the `reference` than the
  /// result, seen farther off its axis than the circle search reaches. Spools on a shelf stand
  /// side by side with about parallel axes, so looking along a row the one nearest the puller can
  /// be seen 45-60 deg off its axis: its flange an ellipse half as wide as high, its bore a dark
  /// slit, and the Hough search's circles miss both (oblique seed 7 #1, #63, seed 11 #17). Bores
  /// nearer the reference than the result's, outside its flange on the reference's side, at the
  /// puller's level and kMinKnownSizeRadius and up, are found by detectTurnedBores() about the
  /// result's axis; about the kTurnedHoles nearest that show dark (bore_contrast, over the
  /// ellipse), the rim is searched with level axes within kNeighbourAxisSpread of the result's
  /// (RimPoseSearch::searchAbout) and passes spoolAboutHoles()' guards, its bearing weighed
  /// without its rim's support (the bore, the rim's 3-D fit and their agreement stand against a
  /// ghost). Where the result's pose gave no axis (SpoolGeometry::plausiblePose), its flange's
  /// ellipse gives the view off its axis (acos of its width over its height, kObliqueAxisAngle and
  /// up) but not its side: both axes are tried (oblique seed 19 #57, seed 37 #11, #57). Replaces
  /// `result` (undistorted px, the rim in oblique_rim_) and returns true. Nothing where bores are
  /// too small (kTurnedBoreScale).
  bool nearerTurnedSpool(const cv::Mat& image, PixelFormat format, const cv::Point2d& reference,
                         const HoughSearch& hole_search, SpoolDetection& result);
  /// obliqueSpool()'s search about the first `max_holes` of holes_ whose whole rim is in the frame
  /// (kMinHoleVisibleFraction), `min_bore_radius` (px) and up, and that show as discs: the first rim
  /// that passes its guards is the spool (`result`) and true.
  /// With `axis_yaw` (nearerTurnedSpool()): holes_ from detectTurnedBores(), each a dark ellipse,
  /// its rim searched about that axis (searchRimAbout()) and its bearing weighed without the rim's
  /// support.
  bool spoolAboutHoles(const cv::Mat& image, PixelFormat format, const cv::Point2d& reference, double bound,
                       double min_bore_radius, int max_holes, SpoolDetection& result,
                       std::optional<double> axis_yaw = std::nullopt);
  /// Whether `hole`'s size (its vertical semi-axis) is within kObliqueBoreAgreement of what the
  /// flange rim `fit.rim` gives its bore, its lower bound times the cosine of the angle between the
  /// fit's axis and its line of sight (a dark bore seen 35-39 deg off its axis was measured at 0.67-0.76
  /// of the size: oblique seed 7 #78, #140, #155): a rim about a bore is the flange only where it
  /// agrees with the bore's own size (a rib ring's hole taken with the flange outside it does not).
  bool boreAgreesWith(const Circle& hole, const RimPoseFit& fit) const;
  /// rim_ for a rim RimPoseSearch found: the frame's edges on it (gatherRim()) where there are
  /// kMinGatheredRim, else the search's moving edges.
  void takeObliqueRim();
  /// searched_pose_ from oblique_rim_ (its rim just taken as the flange).
  void keepSearchedPose();
  /// True where `a` and `b` are the same fitted circle (centre and radii equal).
  static bool sameCircle(const Circle& a, const Circle& b);
  /// Where `result`'s pose has an axis: a searched pose's rim and `result`'s own pose's rim
  /// measured by moving edges (RimPoseSearch::measure, kMeasuredRimMargin more support asked) and
  /// the searched one, refined, taken where it supports more and is plausible
  /// (SpoolGeometry::plausiblePose); true then, `result`'s pose and what follows from it measured
  /// again. The searched pose is searched_pose_ where `result`'s flange is the rim it was found
  /// with; for any other flange whose own pose's rim keeps under kObliqueRimSupport, the pose of
  /// the rim searched about the bore (searchRimAbout(), with its in-view retry) that agrees with
  /// the bore's size (boreAgreesWith()), both rims then sampled as densely in view as a whole rim.
  /// The same rim is searched for where the bore's own shape is clearly more oblique than the pose
  /// (boreViewBeyond(); also for a pose without an axis, whose rim's aspect gives its angle), and
  /// its pose taken where its rim keeps within kBoreViewMargin of the own pose's support and its
  /// angle off the axis is nearer the bore's (without an axis, its depth also within
  /// kBoreViewDepthAgreement of Eq. 3.2's on the flange). A searched pose whose rim keeps no fit
  /// about the hole is measured about the bore centre it projects to. Where the flange was not the
  /// searched rim, it is then reported as that pose's rim (rimSeenAt()). `result` in undistorted px.
  /// `outermost_rim`: the flange is the outermost rim found about its bore (outside an inner
  /// ring), so its height is the rim's: a searched pose is taken only where it gives its rim that
  /// height within kOutermostRimHeight or more (a higher rim is one outside it the window search
  /// missed), a lower rim's pose first scaled out to it
  /// (scaleToOutermostRim()). `ring_pose`, where given with `outermost_rim`: the pose searched about
  /// the bore and taken for the inner ring inside the flange, tried in place of a new search. Uses
  /// own_rim_, oblique_rim_, probe_rim_, scaled_rim_ and hole_edges_. `beyond_view`, where given
  /// (left as it is unless set true): about the bore of a flange no rim search gave (not outside an
  /// inner ring), the searched rim is supported, lies further off the axis than any rim is
  /// measured (SpoolGeometry::kMaxMeasuredViewAngle) and at a depth Eq. 3.2 on the flange
  /// contradicts (SpoolGeometry::kMaxDepthDisagreement): the flange circle is that spool's joint
  /// silhouette, the spool seen beyond the detector's range.
  bool searchedPoseSupportsMore(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                                SpoolDetection& result, bool outermost_rim = false,
                                const SearchedPose* ring_pose = nullptr, bool* beyond_view = nullptr);
  /// Where the rim of the pose searched about `bore` (probe_rim_, undistorted px) is lower than
  /// `outermost` (the outermost rim about that bore, undistorted px) by more than
  /// kOutermostRimHeight, it is a concentric ring of the same face (a rib ring, 0.83-0.91 of the
  /// rim's height on the oblique sets) seen at the right axis (the bore's shape bears it out): the
  /// pose's position is scaled by the ratio of the two heights (the scene scaled about the
  /// camera keeps the ring's image, which the outer rim's is scaled by that ratio) and the rim
  /// measured there (RimPoseSearch::measure with `search`); where it fits, that fit replaces
  /// probe_rim_. Uses scaled_rim_.
  void scaleToOutermostRim(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                           const cv::Point2d& bore, const RimSearch& search, const Circle& outermost);
  /// The angle (rad) between the spool's axis and the line of sight that `hole`'s rim (undistorted
  /// px) bears out, where it is at least kBoreViewGap beyond `pose_angle` (rad) and clearly so. The
  /// bore's front rim is a circle on the flange's face: seen at an angle off the axis, a level
  /// spool's is an upright ellipse narrowed across by its cosine (thesis Eq. 3.1's circle, turned).
  /// Of such ellipses at the rim's vertical semi-axis, every kBoreViewStep up to kBoreViewMax, the
  /// one the edges bear out best (HoughAccumulator::shapeDensity()) must have kBoreViewRatio times
  /// the density of the pose's; the search stops at the first unless it has kBoreViewEarly of it
  /// (past the bore's own angle the density falls). NaN otherwise, and for a bore under
  /// kMinKnownSizeRadius. Uses hole_edges_.
  double boreViewBeyond(const Circle& hole, double pose_angle);
  /// boreViewBeyond()'s least lead over the pose (rad: 10 deg), its steps (4 deg) and its largest
  /// angle (45 deg: the oblique sets reach 40 deg off the axis).
  static constexpr double kBoreViewGap = 10.0 * M_PI / 180.0;
  static constexpr double kBoreViewStep = 4.0 * M_PI / 180.0;
  static constexpr double kBoreViewMax = 45.0 * M_PI / 180.0;
  /// ... how much better its ellipse must be borne out than the pose's (on 19 rendered sets, 1.2
  /// with a 12 deg lead improved half as many poses as 1.1 with 10; 1.05 with 6 took two poses
  /// 30-67 deg off), and the first step's least share of the pose's density.
  static constexpr double kBoreViewRatio = 1.1;
  static constexpr double kBoreViewEarly = 0.9;
  /// ... and how far its centre is searched: this fraction of its vertical semi-axis, at least 1 px
  /// (the hole's centre, measured on the pose's shape, can be that far off the bore's own: at a
  /// tenth, oblique seed 19 #39 at 640x480 and 97 #98 at 320x240 kept poses 12 and 49 deg off).
  static constexpr double kBoreViewShift = 0.25;
  /// How much less support a rim searched on the bore's word may keep than the pose's own: the two
  /// rims are about the same circle (a round fit about an oblique rim keeps 0.6-0.65 of its
  /// samples, the right pose as much).
  static constexpr double kBoreViewMargin = 0.05;
  /// The depth agreement with Eq. 3.2 asked of a searched pose replacing one without an axis (a cut
  /// rim's vertical semi-axis gives the depth within 6%: SpoolGeometry::plausiblePose()).
  static constexpr double kBoreViewDepthAgreement = 0.06;
  /// searchedPoseSupportsMore()'s agreement with an outermost rim's height (a round circle about
  /// an oblique rim is as high as the rim, within 1-7% on the oblique sets; the rim of a rib ring
  /// 0.86 of the flange's size, searched about the same bore, 11% lower: oblique seed 7 #27 at
  /// 640x480).
  static constexpr double kOutermostRimHeight = 0.08;
  /// The rim RimPoseSearch found (oblique_rim_) as `result`'s flange, with `hole` as its bore; its
  /// edges as the rim (takeObliqueRim()) and the pose measured again.
  void takeSpoolAboutBore(const SpoolGeometry& geometry, const Circle& hole, SpoolDetection& result);
  /// A whole-frame result with a hole rim, measured again about its bore (RimPoseSearch) when its
  /// own pose's rim, measured by moving edges, has under kObliqueRimSupport of support: the
  /// search's rim replaces the flange and its edges the rim when it is supported by at least
  /// kObliqueRimMargin more (and kObliqueRimMinSupport) and agrees with the hole's size
  /// (boreAgreesWith), or where none does, the rim smallerBoreRim() finds with its bore; the pose is
  /// then measured again on it. `result` is in undistorted px. True where the own pose's rim was
  /// measured on kObliqueRimMinSamples in the frame (the rim judged, replaced or not).
  bool measureObliqueRim(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                         const HoughSearch& hole_search, SpoolDetection& result);
  /// A whole-frame result whose flange is a weak Hough circle (under
  /// ConcentricMatcher::kSolidRimScore) about its hole: its rim is searched about the hole
  /// (searchRimAbout(): RimPoseSearch at the depths the hole's size gives) and taken as the flange
  /// (takeSpoolAboutBore()) where it keeps kWeakMatchRimSupport of its samples, agrees with the
  /// hole's size (boreAgreesWith()) and lies at the puller's level. Unless the result is the second
  /// search's and would be dropped (takesSecondSearch()), the rim must also be seen off its axis
  /// (offAxis()) and, where the result's own pose's rim can be measured, be supported by
  /// kObliqueRimMargin more than it. Where measureObliqueRim() judged the result's rim
  /// (`rim_measured`), only one its own pose supports by kObliqueRimSupport is searched, and the
  /// rim off the axis need be supported only kMeasuredRimMargin more: a weak circle about an
  /// ellipse seen 30-35 deg off its axis keeps 0.6-0.75 of its own pose's samples (the circle lies
  /// within their reach), the ellipse 0.8 (oblique seed 131 #0 of 150 at 320x240: a round rim 13
  /// deg off its axis where the spool is seen 35 deg off). measureObliqueRim() leaves the others:
  /// at 160x120 a rim has under kObliqueRimMinRadius and too few samples for its own pose's fit,
  /// and seen 25-40 deg off its axis the Hough circle lies between the ellipse's semi-axes or about
  /// the back flange's silhouette (depth 5-25% off) or scores too little to be taken at all. True
  /// where the rim replaced the flange; `result` in undistorted px.
  bool rimAboutWeakMatch(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry, bool rim_measured,
                         SpoolDetection& result);
  /// Whether the rim about `hole` (undistorted px), measured by RimPoseSearch::measure() at
  /// `position` (camera frame, m) with the axis level and turned kWeakCircleProbeTurns off the line
  /// of sight either way, keeps more than `support` of its samples at any of them (`flange_px`:
  /// the flange's vertical semi-axis, for the moving edges' reach). Uses probe_rim_.
  bool turnedPoseSupportsMore(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                              const Circle& hole, const cv::Point3d& position, double flange_px, double support);
  /// The least support of the rim rimAboutWeakMatch() takes. Oblique sets of seeds 7-131 at all
  /// four sizes: at 0.6, a back flange's silhouette at 0.62 (oblique seed 109 #69 at 160x120, 11%
  /// near) was taken; right rims keep 0.65-0.97.
  static constexpr double kWeakMatchRimSupport = 0.65;
  /// Where that search finds no rim: the bore measured again about the result's hole at
  /// kSmallerBoreRatio to kInnerRingRatio of the size the flange gives it (a circle around an oblique
  /// rim and its back flange's silhouette is 12-30% too large, and so is the hole measured at its
  /// size), the best such bore rim whose rim is in the frame, at least kMinKnownSizeRadius, and whose
  /// disc shows dark (far off its axis a bore is dark; the smaller disc in a bore seen along its axis
  /// is the lit lens: hard seed 7 #10), and the rim searched about it as obliqueSpool() does. True, with the rim in
  /// oblique_rim_ and the bore in `hole`, where that rim has `least` support and agrees with the
  /// bore (boreAgreesWith). Uses hole_edges_ and own_bores_.
  bool smallerBoreRim(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                      const HoughSearch& hole_search, const SpoolDetection& result, double least, Circle& hole);
  /// The best-scoring bore rim of `hole_search` with radius r_min..r_max (px) centred within
  /// max(2 px, `expected`) of `hole`'s centre (undistorted px), or nullptr (none, or an empty
  /// range). Points into own_bores_; uses hole_edges_.
  const Circle* bestBoreAbout(const Circle& hole, double expected, const HoughSearch& hole_search, double r_min,
                              double r_max);
  /// A bore rim whose size can be taken as the bore's: at least `min_radius` (px), its whole rim in
  /// the frame (kMinHoleVisibleFraction).
  static bool wholeBoreRim(const Circle& hole, double min_radius = kMinKnownSizeRadius);
  /// The rim about `bore` (RimPoseSearch::search into oblique_rim_) at kObliqueBoreNearest to
  /// kObliqueBoreFarthest of the depth its size gives (within distance_min..distance_max); with
  /// `axis_yaw` (rad), RimPoseSearch::searchAbout() within kNeighbourAxisSpread of it, the rim
  /// then rimSeenAt() its pose. `fallback`: RimPoseSearch::search's (kBoreRimFallbackPoses where a
  /// spool is sought about a bore; 0 where a rim found is judged again); `in_view_retry`:
  /// RimPoseSearch::search's (without `axis_yaw` only).
  bool searchRimAbout(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry, const Circle& bore,
                      std::size_t fallback, std::optional<double> axis_yaw = std::nullopt, bool in_view_retry = false);
  /// The axis from the lit lens's centroid inside the target's hole rim (bore_parallax.h), once
  /// `result` is measured (undistorted px): SpoolDetection::parallax_*.
  void measureBoreParallax(const SpoolGeometry& geometry, SpoolDetection& result);

  /// A result whose own pose's rim has at least this support is not searched again about its bore
  /// (a rim the Hough search measured well has 0.8-1; a circle around an oblique rim's ellipse
  /// fails the 3-D fit: 0).
  static constexpr double kObliqueRimSupport = 0.5;
  /// Nor is a flange under this vertical semi-axis (px): its rim has too few moving-edge samples
  /// (one per 5 px) for the 3-D fit's 30.
  static constexpr double kObliqueRimMinRadius = 40.0;
  /// Nor a rim with fewer samples in the frame at its own pose (a flange mostly out of the frame).
  static constexpr std::size_t kObliqueRimMinSamples = 48;
  /// ... and the search's rim replaces it only with this much more support.
  static constexpr double kObliqueRimMargin = 0.15;
  /// rimAboutWeakMatch()'s margin over a weak circle's own pose that measureObliqueRim() judged.
  static constexpr double kMeasuredRimMargin = 0.05;
  /// turnedPoseSupportsMore()'s turns of the axis off the line of sight, either way (rad: 20 and
  /// 30 deg). With the search run only where one of them supports more, on the 40 rendered sets
  /// 5 of the 8 targets the search alone gained were kept, no target was lost, and the searches
  /// on the hard set at 640x480 went from 5 in 30 frames to 1.
  static constexpr std::array<double, 2> kWeakCircleProbeTurns{0.3490658503988659, 0.5235987755982988};
  /// ... and with at least this support (a rim cut by the border whose bore was found off centre
  /// gave a rib ring at 0.51; the oblique rims replaced 0.6-0.85).
  static constexpr double kObliqueRimMinSupport = 0.55;
  /// The smallest bore smallerBoreRim() seeks, as a share of the size the flange gives it.
  static constexpr double kSmallerBoreRatio = 0.6;
  /// The moving edges' reach there: this fraction of the flange's vertical semi-axis, at least
  /// kObliqueRimReachPx.
  static constexpr double kObliqueRimReach = 0.06;
  static constexpr double kObliqueRimReachPx = 3.0;
  /// The depths measureObliqueRim() tries, as fractions of the result's (a circle the Hough search
  /// took around an oblique rim is up to ~20% too large; one inside it, a rib ring, is the
  /// inner-ring check's).
  static constexpr double kObliqueNearest = 0.93;
  static constexpr double kObliqueFarthest = 1.21;
  /// obliqueSpool()'s candidates, the bore's offset from their centres (of their radius), holes per
  /// candidate, the depths it tries about the hole's (a dark bore's rim seen obliquely measures
  /// within ~15% of its size) and the support its rim needs.
  static constexpr int kObliqueCandidates = 2;
  /// ringAboutLargeBore()'s largest bore, of the size a candidate gives it: a rib at 0.56 of the rim.
  static constexpr double kRibRingBoreMax = 1.8;
  static constexpr double kObliqueBoreShift = 0.35;
  /// besideSilhouette()'s reach either side (of the candidate's radius). On the 40 rendered sets
  /// (sessions 38-41) it found 4 more targets (1280x720 1, 640x480 1, 320x240 2) and lost none;
  /// 0.75 (tried about each candidate before the next one's own window) found 2 more at 640x480
  /// but lost 2 at 320x240 and reported a neighbour.
  static constexpr double kSilhouetteBoreShift = 0.6;
  static constexpr int kObliqueHoles = 1;
  /// Bores over the whole frame tried where no flange circle led to a spool. On the oblique, hard
  /// and packed sets of seeds 7, 11 and 13 one found 10 more targets at 640x480 (oblique seed 7
  /// #26, #160, seed 13 #130: the Hough circle more than a third of its size off the bore, or not
  /// among the candidates; hard seed 11 #152) and one at 160x120 (hard seed 13 #36), lost none,
  /// and put one more detection over 10% off (a neighbour seen 45 deg off its axis); two bores
  /// found nothing more. Run in the first of two searches it took rib rings a flange circle
  /// would have led past in the second (oblique seed 7 #42, #107).
  static constexpr int kBoreLedHoles = 1;
  /// nearerTurnedSpool()'s bores searched for a rim: on the oblique sets of seeds 7-41 a third
  /// found 2 more targets in 1,100 frames and cost another pose search wherever two failed.
  static constexpr int kTurnedHoles = 2;
  /// nearerTurnedSpool() runs only where the nearest bores (hole_search's largest) measure this
  /// many times kMinKnownSizeRadius: seen 45-60 deg off, a bore is half as wide as high. At
  /// 160x120 (8 px at most) it found no spool on the oblique sets of seeds 7 and 73 and cost 15%
  /// of the hard set's instructions.
  static constexpr double kTurnedBoreScale = 2.0;
  /// nearerTurnedFlange()'s candidates, and the share of its rim's samples the 3-D fit must keep.
  static constexpr int kTurnedFlanges = 2;
  static constexpr double kTurnedFlangeSupport = 0.6;
  /// ... run where a spool at the reference column is seen this far off the result's axis (rad):
  /// under it the circle search finds its flange (the main and hard sets: +0.0% instructions).
  static constexpr double kTurnedFlangeView = 20.0 * M_PI / 180.0;
  /// ... its circles' heights within this factor of the result's (a spool of the same row).
  static constexpr double kTurnedFlangeSizes = 1.5;
  /// ... its rim's centre fitted within this share of its size of the circle's: the circle on the
  /// stretched frame leans 2 px (6%) towards the back flange's silhouette at 160x120 (packed
  /// oblique seed 7 #68), beyond RimPoseSearch::kBoreOffCentre.
  static constexpr double kTurnedOffCentre = 0.1;
  /// ... the depths its rim is searched at, as fractions of Eq. 3.2's on the circle's height.
  static constexpr double kTurnedNearest = 0.93;
  static constexpr double kTurnedFarthest = 1.07;
  /// rad: how far a neighbour's axis may turn from the result's (20 deg: shelves do not keep
  /// spools square).
  static constexpr double kNeighbourAxisSpread = 20.0 * M_PI / 180.0;
  static constexpr int kRimExtentPoints = 72;
  /// searchRimAbout()'s poses fitted where none of the best covered fits (RimPoseSearch::search's
  /// `fallback`): on the 40 rendered sets of session 42, oblique targets found +36 at 160x120, +3 at
  /// 320x240 and +8 at 640x480 with 8 (with the fallback in every search, 12 found 3 fewer at
  /// 160x120 than 8 and put 63 detections over 10% off where 8 put 56). Not where a rim found is
  /// judged again (measureObliqueRim(), smallerBoreRim(), frontRimAboutOwnBore()): there the poses
  /// fitted next were rib rings (hard 47 #22, packed 131 #32: 18% deep).
  static constexpr std::size_t kBoreRimFallbackPoses = 8;
  static constexpr double kObliqueBoreNearest = 0.7;
  static constexpr double kObliqueBoreFarthest = 1.25;
  /// A right rim seen 30-40 deg off, its back flange's silhouette beside it, keeps 0.52-0.69 of its
  /// samples on the fit (oblique seed 7 #42, #56 at 640x480); no ghost passed the guards at 0.55
  /// on the oblique, hard and packed sets of seeds 7, 11 and 13. At 0.45, 7 more targets at
  /// 640x480 (rims at 0.44-0.54) but 8 more detections over 10% off at 320x240 (rib rings).
  static constexpr double kObliqueSpoolSupport = 0.55;
  static constexpr std::size_t kMinGatheredRim = 60;
  static constexpr double kObliqueBoreAgreement = 0.2;

  /// Below this fraction of its rim in the frame a flange fit is often a neighbour's back flange
  /// or its joint silhouette with the front one, centred anywhere on that neighbour's face
  /// (whose own centre is out of view): a label's corner or rib arcs there close hole-sized rings.
  static constexpr double kCutFlangeVisibleFraction = 0.7;
  /// Whether under kCutFlangeVisibleFraction of `flange`'s rim is in the frame.
  static bool cutByBorder(const Circle& flange)
  {
    return flange.visible_fraction < kCutFlangeVisibleFraction;
  }

  DetectorParams params_;
  Preprocessor preprocessor_;
  EdgeDetector edge_detector_;
  HoughAccumulator flange_hough_;
  HoughAccumulator hole_hough_;
  HoughAccumulator lens_hough_;
  MovingEdges moving_edges_;  ///< its own: a shared one would be resized every frame
  RimPoseSearch rim_pose_search_;
  RimPoseFit own_rim_;      ///< the result's own pose's rim (measureObliqueRim)
  RimPoseFit oblique_rim_;  ///< the search's best rim (measureObliqueRim)
  std::optional<SearchedPose> searched_pose_;
  /// spoolAboutHoles(), with no spool taken: the first rim searched about a bore that the bore at
  /// its own size calls a rib ring (its rim and pose), that hole and that bore (undistorted px).
  /// takeBoreRing().
  struct BoreRing
  {
    SearchedPose ring;
    Circle hole;
    Circle bore;
  };
  std::optional<BoreRing> bore_ring_;
  ConcentricMatcher matcher_;
  std::optional<CameraIntrinsics> camera_;
  std::optional<SpoolGeometry> geometry_;
  bool using_fallback_ = true;

  cv::Mat preprocessed_;
  std::vector<EdgePoint> edges_;
  std::vector<EdgePoint> hole_edges_;
  std::vector<cv::Point2f> rim_;
  std::vector<Circle> flanges_;
  std::vector<Circle> holes_;         ///< hole candidates of the target (or of the last search)
  std::vector<Circle> target_holes_;  ///< the best candidate's while the others are searched
  std::vector<Circle> first_holes_;   ///< the first search's target's during the flange_retry search
  /// What the running detect() is, for the steps deep in it.
  struct SearchSettings
  {
    bool whole_frame = true;  ///< the whole frame (or a window standing for it), not a track's window
    bool second = false;      ///< the whole frame searched again (kRetryBudgetScale)
    bool nested = false;      ///< within another detect() of the same frame
  };
  SearchSettings search_;
  std::vector<Circle> refit_holes_;    ///< a weak match's while its refit flange is matched (swapped)
  std::vector<Circle> first_flanges_;  ///< the first search's candidates during the flange_retry search
  /// searchNearer()'s candidates where they gave no spool: obliqueSpool() tries them too
  std::vector<Circle> nearer_flanges_;
  std::vector<Circle> lenses_;
  std::vector<double> stretched_columns_;   ///< detectTurnedBores(): stretched x of each column's left edge
  std::vector<EdgePoint> stretched_edges_;  ///< stretchEdges(): edges stretched
  std::vector<EdgePoint> near_edges_;       ///< nearerTurnedFlange(): the edges that can vote there
  std::vector<Circle> turned_flanges_;      ///< nearerTurnedFlange(): the stretched frame's circles
  RimPoseFit turned_rim_;                   ///< nearerTurnedFlange(): a candidate's rim
  RimPoseFit probe_rim_;                    ///< turnedPoseSupportsMore(): a turned pose's rim
  RimPoseFit scaled_rim_;                   ///< scaleToOutermostRim(): the searched pose scaled out
  /// The whole frame's search took its spool about a bore that, measured at the size the rim gives
  /// it, agrees with the rim (spoolAboutHoles(), boreAgreesAtOwnSize()), or the second search's
  /// spool's bore does so: takesSecondSearch() reads it.
  bool bore_agrees_at_own_size_ = false;
  /// The whole frame's search replaced its weak match by the rim about its bore
  /// (rimAboutWeakMatch()): takesSecondSearch() takes that spool.
  bool weak_match_rim_taken_ = false;
  /// The whole frame's search took its spool about a bore too small to measure (smallBoreSpool()):
  /// takesSecondSearch() takes that spool.
  bool small_bore_spool_taken_ = false;
  std::vector<Circle> larger_bores_;  ///< keepBoresOutside()'s bores of measurable size
  std::vector<Circle> own_bores_;     ///< innerRing()'s circles about the target's bore
  std::vector<float> lens_samples_;   ///< measureLens()'s scratch
  std::vector<std::size_t> order_;
  std::vector<std::size_t> candidate_order_;  ///< obliqueSpool()'s and ringAboutLargeBore()'s candidates in order
};

}  // namespace spool_vision
