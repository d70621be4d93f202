"""Where is the car? A particle filter on a known map, fed what a real car measures: its lidar's
scans and its odometry (the distance its wheels rolled and its gyro's yaw rate). It runs the
same on the simulator and on a car; only the URL, the map and the start pose change.

    python examples/localize.py                                     # sim://tunnel:5 and its map
    python examples/localize.py URL MAP.yaml X,Y,YAW                # your car, your map, where you put it

Make a map of a simulated world with `roar world tunnel:5 --save maps/tunnel5_map.yaml` (its
start pose is in maps/tunnel5_course.yaml); of a real place with any ROS mapper (slam_toolbox,
gmapping) and map_saver. The car creeps ahead for 4 s; the filter's pose is printed twice a second."""
import math
import sys
import tempfile
import time
from pathlib import Path

from roar import Vehicle
from roar.localization import LaserScan, Odometry, ParticleFilter
from roar.tracks.occupancy_map import load_map

LIDAR_AHEAD_M = 0.265  # [m] the lidar in front of the car's reference point (measure your own car's)
LIDAR_FOV_RAD = math.radians(270)  # a Hokuyo UST-10LX's 1,080 beams, right to left

if len(sys.argv) > 1:
    url, map_file, start = sys.argv[1], sys.argv[2], tuple(float(v) for v in sys.argv[3].split(","))
else:  # the simulated tunnel's map and start pose, as `roar world tunnel:5 --save` writes them
    from roar.tracks import get
    from roar.tracks.occupancy_map import save_map, track_map

    url, world = "sim://tunnel:5", get("tunnel:5")
    map_file = Path(tempfile.mkdtemp()) / "tunnel5_map.yaml"
    save_map(map_file, track_map(world))
    start = world.course.start

pf = ParticleFilter(load_map(map_file), particles=1000, beams=60, sensor=(LIDAR_AHEAD_M, 0.0, 0.0))
pf.start_at(start)  # or pf.start_global() when you do not know (it then needs to drive to find out)
odometry, travelled, last = Odometry(start), 0.0, None
with Vehicle(url) as car:
    car.wait_armed(timeout_s=5)
    s = car.state()  # one scan standing still first: the filter's kernels compile now (seconds, once), not on the move
    pf.correct(LaserScan.fan(car.lidar(), LIDAR_FOV_RAD, s.time_s))
    car.drive(throttle=0.15)
    end = time.monotonic() + 4.0
    printed = 0.0
    while time.monotonic() < end:
        s = car.state()
        if last is not None and s.time_s > last:  # a car that reports distance_m (the IARRC car): use it instead
            travelled += s.speed_m_s * (s.time_s - last)
        last = s.time_s
        pf.predict(odometry.update(s.time_s, travelled, s.yaw_rate_rad_s))
        pf.correct(LaserScan.fan(car.lidar(), LIDAR_FOV_RAD, s.time_s))
        if s.time_s - printed >= 0.5:
            x, y, yaw = pf.pose
            print(f"t {s.time_s:5.2f} s   x {x:6.2f} m   y {y:6.2f} m   heading {math.degrees(yaw):7.1f} deg   "
                  f"spread {pf.spread_m:.3f} m   fit {pf.fit:.0%}", flush=True)
            printed = s.time_s
        time.sleep(0.04)  # a scan at 25 Hz
    s = car.state()
if s.x_m is not None:  # the simulator also knows where the car truly is
    print(f"the filter's error: {math.hypot(pf.pose[0] - s.x_m, pf.pose[1] - s.y_m):.3f} m "
          f"(odometry alone: {math.hypot(odometry.pose[0] - s.x_m, odometry.pose[1] - s.y_m):.3f} m)")
