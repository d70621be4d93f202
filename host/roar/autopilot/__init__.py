"""Autopilot: agents, planners and controllers that drive a car round a closed line.

    from roar.autopilot import race_agent, CarModel, CarLimits
"""

from roar.autopilot.agent import Agent, CarIO, Command, Module, Observation, Passthrough, Runner
from roar.autopilot.longitudinal import DirectionEstimator, SpeedController, SpeedSetpoint
from roar.autopilot.pid import PID
from roar.autopilot.pure_pursuit import PurePursuit, goal_on_path
from roar.autopilot.race_agent import (CarModel, DiffDriveController, DiffDriveModel, HeadingController, Plan,
                                      RaceController, RacePlanner, diff_drive_agent, race_agent)
from roar.autopilot.speed_profile import CarLimits, curvature, lap_time, limit_lap_time, speed_profile
from roar.autopilot.waypoints import LoopWaypointFollower, WaypointError, load_waypoints, save_waypoints

__all__ = ["PID", "Agent", "CarIO", "CarLimits", "CarModel", "Command", "DiffDriveController", "DiffDriveModel",
           "DirectionEstimator", "HeadingController", "LoopWaypointFollower", "diff_drive_agent",
           "Module", "Observation", "Passthrough", "Plan", "PurePursuit", "RaceController", "RacePlanner", "Runner",
           "SpeedController", "SpeedSetpoint", "WaypointError", "curvature", "goal_on_path", "lap_time", "limit_lap_time",
           "load_waypoints", "race_agent", "save_waypoints", "speed_profile"]
