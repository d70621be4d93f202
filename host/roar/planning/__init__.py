"""Where the car should drive: RRT planners whose edges a car can follow (circular arcs from a
pose to a point, and Dubins curves from pose to pose for the asymptotically optimal variant),
collision by the car's own rectangle on an occupancy grid (the known map with what the lidar and
the camera found), a path follower that survives jumping poses and late plans, and the high-level
planner of the MIT challenge (docs/planning.md).

    from roar.planning import ArcRRT, Footprint, PlanningGrid
    grid = PlanningGrid.from_map(load_map("tunnel_map.yaml"))
    path = ArcRRT(grid, Footprint(), r_min_m=0.77, seed=1).plan(start_pose, goal_xy, budget_s=0.2)
"""

from roar.planning.arcs import Arcs, arcs
from roar.planning.dubins import dubins
from roar.planning.follower import FollowerState, PathFollower, Steer
from roar.planning.footprint import Footprint
from roar.planning.grid import NoPath, PlanningError, PlanningGrid
from roar.planning.path import Path
from roar.planning.rrt import ArcRRT
from roar.planning.rrt_star import DubinsRRTStar

__all__ = ["ArcRRT", "Arcs", "DubinsRRTStar", "FollowerState", "Footprint", "NoPath", "Path", "PathFollower",
           "PlanningError", "PlanningGrid", "Steer", "arcs", "dubins"]
