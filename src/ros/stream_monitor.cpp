#include "stream_monitor.h"

#include <diagnostic_msgs/DiagnosticStatus.h>

namespace spool_vision
{
namespace
{
using diagnostic_msgs::DiagnosticStatus;

// FrequencyStatus's defaults for a camera: 10% slack on the bounds, a window of 10 updates.
constexpr double kRateTolerance = 0.1;
constexpr int kRateWindow = 10;
}  // namespace

StreamMonitor::StreamMonitor(double* min_rate, double* max_rate, const diagnostic_updater::TimeStampStatusParam& age,
                             double min_window)
  : frequency_(diagnostic_updater::FrequencyStatusParam(min_rate, max_rate, kRateTolerance, kRateWindow), "Frame rate")
  , age_param_(age)
  , min_window_(min_window)
{
  age_.emplace(age_param_, "Frame age");
}

void StreamMonitor::tick(const ros::Time& stamp)
{
  checkClock();
  if (!last_stamp_.isZero() && stamp < last_stamp_)
    restart("the stamps went back", true);
  else if (stale_)
    restart(last_stamp_.isZero() ? "first frames" : "frames resumed", false);
  last_stamp_ = stamp;
  frequency_.tick();
  ++rate_frames_;
  if (age_skipped_)
    return;
  age_->tick(stamp);
  ++age_frames_;
}

void StreamMonitor::checkClock()
{
  const ros::Time now = ros::Time::now();
  if (now < last_clock_)
    restart("the clock went back", true);
  last_clock_ = now;
}

void StreamMonitor::restart(const std::string& why, bool time_jumped)
{
  frequency_.clear();
  window_start_ = ros::Time::now();
  rate_restarted_ = true;
  stale_ = false;
  restart_reason_ = why;
  if (time_jumped)
  {
    // The ages taken so far in this update may mix both sides of the jump.
    age_.emplace(age_param_, "Frame age");
    age_skipped_ = true;
    age_frames_ = 0;
    ++restarts_;
  }
}

void StreamMonitor::diagnoseRate(diagnostic_updater::DiagnosticStatusWrapper& status)
{
  checkClock();
  const int frames = rate_frames_;
  rate_frames_ = 0;
  status.add("Frames since last update", frames);
  status.add("Window restarts (time went back)", restarts_);
  if (frames == 0)
  {
    // Not fed to FrequencyStatus: an idle spell must not stay in its window afterwards.
    stale_ = true;
    status.summary(DiagnosticStatus::STALE, "no frames");
    return;
  }
  if (rate_restarted_ && (ros::Time::now() - window_start_).toSec() < min_window_)
  {
    status.summaryf(DiagnosticStatus::OK, "rate window restarted (%s): measured from %.2f s of frames on",
                    restart_reason_.c_str(), min_window_);
    return;
  }
  rate_restarted_ = false;
  frequency_.run(status);
}

void StreamMonitor::diagnoseAge(diagnostic_updater::DiagnosticStatusWrapper& status)
{
  checkClock();
  const int frames = age_frames_;
  const bool skipped = age_skipped_;
  age_frames_ = 0;
  age_skipped_ = false;
  if (frames > 0)
    age_->run(status);
  else if (skipped)
    status.summary(DiagnosticStatus::OK, "time went back: ages left out until the next update");
  else
    status.summary(DiagnosticStatus::STALE, "no frames");
}

}  // namespace spool_vision
