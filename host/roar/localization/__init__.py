"""Where the car is: Monte Carlo localization on a known map from a laser and odometry, and a
local occupancy grid of what the map does not show. Runs on a real car's computer as it does in
the simulator: feed it LaserScans and the odometry's pose (docs/localization.md).

    from roar.localization import LaserScan, Odometry, ParticleFilter
    from roar.tracks.occupancy_map import load_map

    pf = ParticleFilter(load_map("tunnel_map.yaml"), particles=2500, beams=60)
    pf.start_global()
    ...
    pf.predict(odometry.update(t, travelled_m, yaw_rate))
    pf.correct(LaserScan.fan(ranges, math.radians(270), t))
    x, y, yaw = pf.pose
"""

from roar.localization.beam_model import BeamModel
from roar.localization.odometry import Encoder, Odometry
from roar.localization.particle_filter import LocalizationError, MotionNoise, ParticleFilter
from roar.localization.pose_history import PoseHistory
from roar.localization.raycast import BresenhamCaster, RayMarcher
from roar.localization.scan import LaserScan, ScanError

__all__ = ["BeamModel", "BresenhamCaster", "Encoder", "LaserScan", "LocalizationError", "MotionNoise", "Odometry",
           "ParticleFilter", "PoseHistory", "RayMarcher", "ScanError"]
