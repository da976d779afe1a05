// The input stream's diagnostics, "Frame rate" and "Frame age": diagnostic_updater's
// FrequencyStatus and TimeStampStatus, kept right where they alone go wrong. Under sim time a
// paused bag stops the clock (their window would be zero: "too high"), a looping bag sends the
// clock and the stamps back (a negative window, stamps "in the future"), and a camera that
// stalls leaves an old window that says "too low" long after frames resume.
#pragma once

#include <optional>
#include <string>

#include <diagnostic_updater/DiagnosticStatusWrapper.h>
#include <diagnostic_updater/update_functions.h>
#include <ros/time.h>

namespace spool_vision
{
class StreamMonitor
{
public:
  /// Rate bounds as FrequencyStatus reads them (pointers: the owner may change them); `age` are
  /// TimeStampStatus's bounds on ros::Time::now() - stamp, in s; a restarted rate window is
  /// reported once it spans `min_window` s of ros::Time.
  StreamMonitor(double* min_rate, double* max_rate, const diagnostic_updater::TimeStampStatusParam& age,
                double min_window);

  /// A frame stamped `stamp` arrived (ros::Time::now() is its arrival).
  void tick(const ros::Time& stamp);

  /// "Frame rate": STALE while no frame arrived since the last update (idle, paused); the rate
  /// over FrequencyStatus's window otherwise. The window restarts when the clock or the stamps
  /// go back (a bag loop) and when frames resume after a stale update; until it spans
  /// `min_window` an update only says so (a few frames over a few milliseconds are no rate).
  void diagnoseRate(diagnostic_updater::DiagnosticStatusWrapper& status);
  /// "Frame age" (now - stamp): STALE without frames; frames of an update in which time
  /// jumped back are left out (the clock and the stamps jump at different moments).
  void diagnoseAge(diagnostic_updater::DiagnosticStatusWrapper& status);

private:
  /// Restarts the windows when ros::Time::now() is before the last time seen.
  void checkClock();
  void restart(const std::string& why, bool time_jumped);

  diagnostic_updater::FrequencyStatus frequency_;
  diagnostic_updater::TimeStampStatusParam age_param_;
  double min_window_;
  std::optional<diagnostic_updater::TimeStampStatus> age_;

  ros::Time last_clock_;
  ros::Time last_stamp_;
  ros::Time window_start_;
  std::string restart_reason_;
  bool rate_restarted_ = false;  ///< the window is younger than min_window_
  bool age_skipped_ = false;     ///< time jumped back in this update: no ages taken
  bool stale_ = true;            ///< the last rate update saw no frame
  int rate_frames_ = 0;          ///< since the last rate update
  int age_frames_ = 0;           ///< since the last age update
  int restarts_ = 0;
};

}  // namespace spool_vision
