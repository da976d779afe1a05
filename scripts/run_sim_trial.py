#!/usr/bin/env python3
"""Run one closed-loop trial through ROS (launch/sim.launch) and print its outcome in one line.

Sends an empty goal to the `approach_and_insert` action (spool_approach_controller), waits for its
result and for spool_sim_world's judgement (latched ~outcome, spool_vision/SimTrialOutcome: the
renderer's geometry, not what the detector published), prints

    trial seed 1: inserted after 97 frames, 9.6 s to the push, misses 0.4/0.9 mm (t_f 2.5 mm); controller: inserted, 0 retries

and exits 0 when both came (whatever the outcome), 1 when either did not within --timeout wall seconds.
"""
import argparse
import math
import sys
import threading

import actionlib
import rospy

from spool_vision.msg import ApproachAndInsertAction, ApproachAndInsertGoal, SimTrialOutcome


def mm(value):
    return "nan" if math.isnan(value) else "%.1f" % (1e3 * value)


def describe(outcome, result):
    """One line from the world's SimTrialOutcome and the action's result (or None)."""
    push = "" if math.isnan(outcome.time_to_insert) else ", %.1f s to the push" % outcome.time_to_insert
    controller = "no result" if result is None else "%s, %d retries" % (result.outcome, result.retries)
    return "trial seed %d: %s after %d frames%s, misses %s/%s mm (t_f %s mm); controller: %s" % (
        outcome.seed, outcome.outcome, outcome.steps, push, mm(outcome.front_miss), mm(outcome.back_miss),
        mm(outcome.tolerance), controller)


def run_trial(timeout, outcome_topic="spool_sim_world/outcome", action="approach_and_insert"):
    """Sends the goal and waits; returns (SimTrialOutcome, ApproachAndInsertResult or None), or
    raises RuntimeError naming what did not come within `timeout` wall seconds."""
    outcome = {}
    judged = threading.Event()

    def on_outcome(msg):
        outcome["msg"] = msg
        judged.set()

    rospy.Subscriber(outcome_topic, SimTrialOutcome, on_outcome)
    client = actionlib.SimpleActionClient(action, ApproachAndInsertAction)
    # The world's clock runs at wall speed until the goal, so ROS-time timeouts work here.
    if not client.wait_for_server(rospy.Duration(timeout)):
        raise RuntimeError("no action server %s within %.0f s: is spool_approach_controller running?" %
                           (action, timeout))
    client.send_goal(ApproachAndInsertGoal())
    if not judged.wait(timeout):
        raise RuntimeError("no judgement on %s within %.0f s (wall): is spool_sim_world running?" %
                           (outcome_topic, timeout))
    # A push ends the goal at once; a give-up ends it before the world judges.
    finished = client.wait_for_result(rospy.Duration(5.0))
    return outcome["msg"], client.get_result() if finished else None


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--timeout", type=float, default=600.0, help="wall seconds to wait for the judgement")
    args = parser.parse_args(rospy.myargv()[1:])
    rospy.init_node("run_sim_trial")
    try:
        outcome, result = run_trial(args.timeout)
    except RuntimeError as error:
        rospy.logerr("run_sim_trial: %s", error)
        return 1
    print(describe(outcome, result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
