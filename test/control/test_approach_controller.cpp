#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "spool_vision/control/approach_controller.h"
#include "spool_vision/spool_geometry.h"

namespace sv = spool_vision;

namespace
{
constexpr double kDeg = M_PI / 180.0;
constexpr double kDt = 0.1;

// The bore `depth` ahead on the puller's height, `right` of the puller's axis, its axis turned
// `turn` (rad) to the right of the optical axis.
sv::ApproachObservation boreAhead(double depth, double right = 0.0, double turn = 0.0)
{
  sv::ApproachObservation o;
  o.detected = true;
  o.position = {right, sv::GeometryParams{}.puller_offset_y, depth};
  o.axis = {std::sin(turn), 0.0, std::cos(turn)};
  return o;
}
}  // namespace

TEST(ApproachController, FloorErrorsOfABoreBesideAndTurned)
{
  double lateral = 0.0;
  double heading = 0.0;
  double to_face = 0.0;
  // The bore 1 cm right of the puller, its axis parallel: the puller is 1 cm left of the axis.
  sv::ApproachController::floorErrors(boreAhead(0.6, 0.01), sv::GeometryParams(), lateral, heading, to_face);
  EXPECT_NEAR(lateral, -0.01, 1e-12);
  EXPECT_NEAR(heading, 0.0, 1e-12);
  EXPECT_NEAR(to_face, 0.6, 1e-12);
  // Straight ahead but the axis turned 2 deg right: the axis passes 0.6 sin(2 deg) left of the
  // puller's point, i.e. the puller is right of the axis.
  sv::ApproachController::floorErrors(boreAhead(0.6, 0.0, 2.0 * kDeg), sv::GeometryParams(), lateral, heading, to_face);
  EXPECT_NEAR(lateral, 0.6 * std::sin(2.0 * kDeg), 1e-12);
  EXPECT_NEAR(heading, 2.0 * kDeg, 1e-12);
  EXPECT_NEAR(to_face, 0.6 * std::cos(2.0 * kDeg), 1e-12);
}

TEST(ApproachController, BadParametersNameTheKey)
{
  sv::ApproachControllerParams p;
  p.lookahead = 0.0;
  try
  {
    sv::ApproachController controller(p, sv::GeometryParams());
    FAIL() << "lookahead 0 accepted";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("lookahead"), std::string::npos) << e.what();
  }
  p = sv::ApproachControllerParams();
  p.line_memory = 1.0;
  EXPECT_THROW(sv::ApproachController(p, sv::GeometryParams()), std::invalid_argument);
  p = sv::ApproachControllerParams();
  p.min_speed = 2.0 * p.max_speed;
  EXPECT_THROW(sv::ApproachController(p, sv::GeometryParams()), std::invalid_argument);
  sv::ApproachController controller{sv::ApproachControllerParams(), sv::GeometryParams()};
  EXPECT_THROW(controller.update(boreAhead(1.0), sv::OdometryPose(), 0.0), std::invalid_argument);
}

TEST(ApproachController, DrivesTowardsABoreOnTheLeftAndStopsAtTheStandoff)
{
  sv::ApproachController controller{sv::ApproachControllerParams(), sv::GeometryParams()};
  const sv::ApproachCommand far = controller.update(boreAhead(1.0, -0.05), sv::OdometryPose(), kDt);
  EXPECT_GT(far.speed, 0.0);
  EXPECT_LT(far.yaw_rate, 0.0) << "the bore is left: turn left";
  EXPECT_FALSE(far.insert);
  // The same bore seen from the standoff: stop (the line estimate keeps 80% of the far view,
  // which is the same line).
  sv::OdometryPose there;
  there.x = -0.05;
  there.z = 1.0 - sv::ApproachControllerParams().standoff_depth;
  const sv::ApproachCommand near =
      controller.update(boreAhead(sv::ApproachControllerParams().standoff_depth), there, kDt);
  EXPECT_EQ(controller.phase(), sv::ApproachPhase::kHold);
  EXPECT_EQ(near.speed, 0.0);
}

TEST(ApproachController, LiftsThePullerToTheBoresHeight)
{
  sv::ApproachController controller{sv::ApproachControllerParams(), sv::GeometryParams()};
  sv::ApproachObservation low = boreAhead(1.0);
  low.position.y += 0.01;  // the bore 1 cm lower than the puller (camera y down)
  EXPECT_LT(controller.update(low, sv::OdometryPose(), kDt).lift_rate, 0.0);
}

TEST(ApproachController, InsertsOnlyOnAlignedAndNeverWhileCoasting)
{
  sv::ApproachController controller{sv::ApproachControllerParams(), sv::GeometryParams()};
  sv::ApproachObservation o = boreAhead(0.56);
  o.aligned = true;
  o.coasting = true;
  EXPECT_FALSE(controller.update(o, sv::OdometryPose(), kDt).insert);
  o.coasting = false;
  o.aligned = false;
  EXPECT_FALSE(controller.update(o, sv::OdometryPose(), kDt).insert);
  o.aligned = true;
  EXPECT_TRUE(controller.update(o, sv::OdometryPose(), kDt).insert);
  EXPECT_EQ(controller.phase(), sv::ApproachPhase::kInsert);
}

TEST(ApproachController, BacksOffWhenAlignedDoesNotComeAndGivesUpAfterItsRetries)
{
  sv::ApproachControllerParams p;
  p.max_retries = 1;
  sv::ApproachController controller(p, sv::GeometryParams());
  const sv::ApproachObservation at_standoff = boreAhead(p.standoff_depth);
  int backed_off = 0;
  for (int step = 0; step < 400 && controller.phase() != sv::ApproachPhase::kGaveUp; ++step)
  {
    const sv::ApproachCommand c = controller.update(at_standoff, sv::OdometryPose(), kDt);
    EXPECT_FALSE(c.insert);
    backed_off += c.speed < 0.0 ? 1 : 0;
  }
  EXPECT_EQ(controller.phase(), sv::ApproachPhase::kGaveUp);
  EXPECT_EQ(controller.retries(), 2);
  // Two back-offs of backoff_distance at backoff_speed.
  EXPECT_NEAR(backed_off * kDt * p.backoff_speed, 2.0 * p.backoff_distance, 2.0 * kDt * p.backoff_speed);
}

TEST(ApproachController, StandsStillWithoutASpoolThenBacksOff)
{
  sv::ApproachControllerParams p;
  sv::ApproachController controller(p, sv::GeometryParams());
  controller.update(boreAhead(1.0), sv::OdometryPose(), kDt);
  sv::ApproachObservation none;
  none.position = {std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0};
  const sv::ApproachCommand wait = controller.update(none, sv::OdometryPose(), kDt);
  EXPECT_EQ(wait.speed, 0.0);
  EXPECT_EQ(wait.yaw_rate, 0.0);
  for (double t = kDt; t <= p.lost_timeout + kDt; t += kDt)
    controller.update(none, sv::OdometryPose(), kDt);
  EXPECT_EQ(controller.phase(), sv::ApproachPhase::kBackOff);
}

TEST(ApproachController, PosesThatDisagreeWithTheRobotsMotionAreNotTrusted)
{
  // Standing still (odometry unchanged), the bore 80 cm ahead; then poses putting it 10 cm
  // further (a circle too big): never inserted on, and after max_disagreements in a row the
  // approach stops and backs off.
  sv::ApproachControllerParams p;
  sv::ApproachController controller{p, sv::GeometryParams()};
  for (int i = 0; i < 3; ++i)
    controller.update(boreAhead(0.8), sv::OdometryPose(), kDt);
  sv::ApproachObservation further = boreAhead(0.9);
  further.aligned = true;
  for (int i = 0; i < p.max_disagreements; ++i)
  {
    EXPECT_EQ(controller.phase(), sv::ApproachPhase::kApproach) << i;
    EXPECT_FALSE(controller.update(further, sv::OdometryPose(), kDt).insert) << i;
  }
  EXPECT_EQ(controller.phase(), sv::ApproachPhase::kBackOff);
}

TEST(ApproachController, AtTheStandoffAimsThePushThroughTheBore)
{
  // Stopped at the standoff with the bore 4 mm right of the puller and the axes parallel: pushed
  // straight the puller would miss by 4 mm at both ends (t_f is 2.5 mm). Turning in place it
  // aims through the bore instead, both misses e L / (2 D + L) = 0.6 mm.
  const sv::GeometryParams g;
  const double right = 0.004;
  const double depth = sv::ApproachControllerParams{}.standoff_depth;
  sv::ApproachController controller{sv::ApproachControllerParams(), g};
  sv::OdometryPose odometry;
  double front = 0.0;
  double back = 0.0;
  // Within hold_timeout (3 s), after which it would back off.
  for (int i = 0; i < 25; ++i)
  {
    // The bore fixed on the floor, seen from the camera turned by the odometry's heading.
    const double c = std::cos(odometry.heading);
    const double s = std::sin(odometry.heading);
    sv::ApproachObservation o;
    o.detected = true;
    o.position = {c * right - s * depth, g.puller_offset_y, s * right + c * depth};
    o.axis = {-s, 0.0, c};
    sv::pullerMiss(g, o.position, o.axis, front, back);
    const sv::ApproachCommand command = controller.update(o, odometry, kDt);
    ASSERT_EQ(command.speed, 0.0) << "step " << i;
    ASSERT_EQ(controller.phase(), sv::ApproachPhase::kHold) << "step " << i;
    odometry.heading += command.yaw_rate * kDt;
  }
  const double best = right * g.bore_length_max / (2.0 * depth + g.bore_length_max);
  EXPECT_NEAR(front, best, 0.1e-3);
  EXPECT_NEAR(back, best, 0.1e-3);
  EXPECT_GT(odometry.heading, 0.0);  // towards the bore, to the right
}

namespace
{
// The bore's front centre fixed on the floor at (0, bore_z) of the odometry frame, its axis along
// +z, seen from `odometry` on the puller's height.
sv::ApproachObservation boreSeenFrom(const sv::OdometryPose& odometry, double bore_z)
{
  const double c = std::cos(odometry.heading);
  const double s = std::sin(odometry.heading);
  const double dx = -odometry.x;
  const double dz = bore_z - odometry.z;
  sv::ApproachObservation o;
  o.detected = true;
  o.position = {dx * c - dz * s, sv::GeometryParams{}.puller_offset_y, dx * s + dz * c};
  o.axis = {-s, 0.0, c};
  return o;
}

// One control period of a unicycle driving `command` exactly.
void drive(const sv::ApproachCommand& command, sv::OdometryPose& odometry)
{
  odometry.x += command.speed * std::sin(odometry.heading) * kDt;
  odometry.z += command.speed * std::cos(odometry.heading) * kDt;
  odometry.heading += command.yaw_rate * kDt;
}

// The largest bearing of the bore (rad) over an approach from 18 cm beside its axis, 1 m away,
// until the controller holds at the standoff; `lateral` the puller's distance from the axis then.
double widestBearingOfAnApproach(const sv::ApproachControllerParams& params, double& lateral)
{
  sv::ApproachController controller{params, sv::GeometryParams()};
  sv::OdometryPose odometry;
  odometry.x = 0.18;
  double widest = 0.0;
  for (int step = 0; step < 200 && controller.phase() == sv::ApproachPhase::kApproach; ++step)
  {
    const sv::ApproachObservation o = boreSeenFrom(odometry, 1.0);
    widest = std::max(widest, std::abs(std::atan2(o.position.x, o.position.z)));
    drive(controller.update(o, odometry, kDt), odometry);
  }
  lateral = odometry.x;
  return widest;
}
}  // namespace

TEST(ApproachController, KeepsTheBoreInViewWhileCrossingOverToItsAxis)
{
  // Unconstrained, the line follower heads for the axis 15 cm ahead and the bore leaves a
  // C270's view (22 deg each side) on the way; with the constraint its bearing stays within
  // max_bore_bearing (one period's turn of slack) and the crossing still gets half the way (the
  // back-off and the next run-up do the rest).
  sv::ApproachControllerParams p;
  double lateral = 0.0;
  const double constrained = widestBearingOfAnApproach(p, lateral);
  EXPECT_LT(constrained, p.max_bore_bearing + p.max_yaw_rate * kDt);
  EXPECT_LT(std::abs(lateral), 0.1);
  p.max_bore_bearing = 1.5;
  EXPECT_GT(widestBearingOfAnApproach(p, lateral), 22.0 * kDeg);
}

TEST(ApproachController, BacksOffClosingOnTheAxisWithTheBoreInView)
{
  // Held at the standoff 5 cm beside the axis and turned 8 deg towards it, `aligned` never comes.
  // Reversing straight would add 0.3 m sin 8 deg = 4 cm to the lateral error; the back-off
  // follows the axis line in reverse (the nose turned away from it), so the next run-up starts
  // nearer the axis, and the bore stays in view all the while.
  sv::ApproachControllerParams p;
  p.max_retries = 1;
  sv::ApproachController controller{p, sv::GeometryParams()};
  sv::OdometryPose odometry;
  odometry.x = 0.05;
  odometry.heading = -8.0 * kDeg;
  int reversing = 0;
  double widest = 0.0;
  for (int step = 0; step < 200 && controller.retries() == 0; ++step)
  {
    const sv::ApproachObservation o = boreSeenFrom(odometry, p.standoff_depth);
    widest = std::max(widest, std::abs(std::atan2(o.position.x, o.position.z)));
    const sv::ApproachCommand c = controller.update(o, odometry, kDt);
    reversing += c.speed < 0.0 ? 1 : 0;
    drive(c, odometry);
  }
  ASSERT_GT(reversing * kDt * p.backoff_speed, 0.9 * p.backoff_distance);
  EXPECT_LT(odometry.x, 0.04);
  EXPECT_LT(widest, p.max_bore_bearing + p.max_yaw_rate * kDt);
}
