"""Plan where a car can drive, the MIT racecar's way: an RRT of circular arcs no tighter than the
car turns, each checked by the car's own rectangle on the map -- here tunnel:3's known map with
its cones drawn in, from its start to 12 m along its corridors.

    python examples/plan.py
"""

import sys

from roar.planning import ArcRRT, Footprint, NoPath, PlanningGrid
from roar.tracks import get
from roar.tracks.occupancy_map import track_map

world = get("tunnel:3")
grid = PlanningGrid.from_map(track_map(world)).with_discs(world.course.cones, 0.15)  # [m] cone radius + clearance
start, goal = world.pose_at(0.0), world.pose_at(12.0)[:2]
try:
    path = ArcRRT(grid, Footprint(), r_min_m=0.81, seed=1, smooth=True).plan(start, goal, budget_s=1.0)
except NoPath as e:
    sys.exit(str(e))
print(f"{path.length_m:.2f} m in {len(path.nodes) - 1} arcs from ({start[0]:.2f}, {start[1]:.2f}) "
      f"to ({goal[0]:.2f}, {goal[1]:.2f}); {path.reverses} changes of direction")
