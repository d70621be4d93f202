"""`roar ros2 URL`: the car at URL as a ROS 2 node (roar.ros2.bridge) until Ctrl-C or --for;
neutral at the end."""

from __future__ import annotations

import math
import os
import time
from pathlib import Path

from roar.cli.sdk import (ArgumentParser, UserError, add_calibration_option, number_option, open_vehicle,
                          path_option)

# What a car whose link does not say what it is (a real car over serial, BLE, Wi-Fi) is taken to
# be unless told: the ROAR car's figures (roar_sim's default profile, its measured top speed)
WHEELBASE_M = 0.325  # [m]
MAX_STEER_DEG = 22.9  # [deg] the front wheels' angle at full steering (0.4 rad)
TOP_SPEED_M_S = 2.93  # [m/s] at full throttle
ROS_ARGS = "--ros-args"


def domain_option(text: str) -> int:
    value = number_option(0, 232, "")(text)
    if value != int(value):
        raise UserError(f"--domain must be a whole number 0..232, got {text!r}")
    return int(value)


def parser() -> ArgumentParser:
    p = ArgumentParser(
        prog="roar ros2",
        description="Serve the car as a ROS 2 node: /drive (ackermann_msgs/AckermannDriveStamped: speed m/s, "
                    "steering angle rad) and /cmd_vel (geometry_msgs/Twist) drive it; /odom, /tf, /imu, /scan "
                    "(a car with a lidar), /camera/*, /map (a track), /clock (the simulator) and /diagnostics say "
                    "what it measures. No command for --timeout puts it to neutral. Discovery stays on this machine "
                    "unless --discovery subnet. Arguments after --ros-args go to ROS (remapping: -r /drive:=/x). "
                    "roar ros2 --bag RECORDING --out FOLDER writes a recording as a rosbag2; roar ros2 --localize-bag "
                    "BAG --map MAP runs our particle filter over anyone's.",
        epilog="examples:\n  roar ros2 sim://oval                    the simulated car on the oval, /map included\n"
               "  roar ros2 sim://oval --f1tenth          f1tenth_gym_ros's names: /ego_racecar/odom, /scan, /drive\n"
               "  roar ros2 serial:///dev/ttyUSB0 --wheelbase 0.33 --top-speed 4\n"
               "  ros2 topic pub /drive ackermann_msgs/msg/AckermannDriveStamped \"{drive: {speed: 1.0}}\" -r 20")
    p.add_argument("url", metavar="URL", nargs="?", default="sim://",
                   help="the car (default sim://; sim://oval: the simulator on a track)")
    p.add_argument("--f1tenth", action="store_true",
                   help="f1tenth_gym_ros's topic and frame names (/ego_racecar/odom in the map frame, "
                        "ego_racecar/base_link, ego_racecar/laser), so its nodes drive this car unchanged")
    p.add_argument("--timeout", type=number_option(0.02, 5.0, "s"), default=0.25, metavar="SECONDS",
                   help="no /drive or /cmd_vel for this long -> neutral (default 0.25; it cannot be turned off)")
    p.add_argument("--domain", type=domain_option, default=None, metavar="ID",
                   help="the ROS domain (default: ROS_DOMAIN_ID, else 0)")
    p.add_argument("--discovery", choices=("localhost", "subnet"), default=None,
                   help="where nodes are found (default: ROS_AUTOMATIC_DISCOVERY_RANGE, else localhost)")
    p.add_argument("--camera", type=number_option(0, 30, "Hz"), default=0.0, metavar="HZ",
                   help="camera frames a second on /camera/image_raw, camera_info and depth (default 0: none; the "
                        "simulator renders each frame on its own thread, delaying its serial input: /drive's p99 "
                        "latency goes from 18 to 34-40 ms at 10 Hz)")
    p.add_argument("--localize", action="store_true",
                   help="run our particle filter on the scans and the map: the car's pose on /pose, map -> odom on "
                        "/tf (needs a lidar and a map)")
    p.add_argument("--map", metavar="TRACK", default=None,
                   help="serve this track or map on /map (default: the simulator's track)")
    p.add_argument("--wheelbase", type=number_option(0.05, 2.0, "m", low_open=True), default=None, metavar="M",
                   help=f"a car whose link does not say: its wheelbase (default {WHEELBASE_M})")
    p.add_argument("--max-steer", type=number_option(1, 60, "deg"), default=None, metavar="DEG",
                   help=f"... its front wheels' angle at full steering (default {MAX_STEER_DEG})")
    p.add_argument("--top-speed", type=number_option(0.1, 50, "m/s"), default=None, metavar="M/S",
                   help=f"... its speed at full throttle (default {TOP_SPEED_M_S})")
    p.add_argument("--for", dest="seconds", type=number_option(0, 86400, "s", low_open=True), default=None,
                   metavar="SECONDS", help="stop after this long (default: Ctrl-C)")
    add_calibration_option(p)
    return p


def bag_parser() -> ArgumentParser:
    p = ArgumentParser(prog="roar ros2 --bag",
                       description="Write a roar recording (roar record, --log) as a rosbag2: ROS 2 types, CDR, MCAP "
                                   "storage, for ros2 bag, rosbags and Foxglove (roar.ros2.bag has the topics).",
                       epilog="example:\n  roar ros2 --bag run.mcap --out run_bag")
    p.add_argument("recording", metavar="RECORDING", type=path_option, help="a roar recording (.mcap)")
    p.add_argument("--out", type=path_option, required=True, metavar="FOLDER", help="the rosbag2 folder (a new one)")
    return p


def localize_parser() -> ArgumentParser:
    p = ArgumentParser(prog="roar ros2 --localize-bag",
                       description="Run our particle filter over a rosbag2 (anyone's: a LaserScan topic, an Odometry "
                                   "topic of poses, and the map the run was on) and write its pose track as CSV: "
                                   "t_s, the odometry's x, y, yaw, the filter's x, y, yaw, its spread.",
                       epilog="example:\n  roar ros2 --localize-bag run_bag --map maps/oval_map.yaml --out out/track.csv")
    p.add_argument("bag", metavar="BAG", type=path_option, help="a rosbag2 folder")
    p.add_argument("--map", required=True, metavar="MAP", help="the map: a track name, a map .yaml, a .json or .csv")
    p.add_argument("--out", type=path_option, default=None, metavar="CSV",
                   help="the pose track (default out/<bag>_track.csv)")
    p.add_argument("--start", choices=("global", "odom"), default="global",
                   help="global: anywhere on the map (default); odom: at the first odometry pose")
    p.add_argument("--scan", default="/scan", metavar="TOPIC", help="default /scan")
    p.add_argument("--odom", default="/odom", metavar="TOPIC", help="default /odom")
    return p


def variants() -> dict:
    """--bag converts a recording, --localize-bag runs the filter over a bag: each its own parser."""
    return {("--bag",): bag_parser(), ("--localize-bag",): localize_parser()}


def localize_main(argv: list[str]) -> int:
    args = localize_parser().parse_args(argv)
    try:
        from roar.ros2.bag import localize
        from roar.tracks.names import map_of
    except ImportError as e:
        raise UserError(f"roar ros2 --localize-bag needs {e.name}: pip install 'roar-platform[ros2]'") from None
    from roar.user_files import unwritable

    out = args.out or Path("out") / f"{args.bag.name}_track.csv"
    if args.out is None:
        out.parent.mkdir(exist_ok=True)  # out/ is ours to make; a folder the user names must exist
    if unwritable(out):
        raise UserError(f"--out {unwritable(out)}")
    track = localize(args.bag, map_of(args.map), args.scan, args.odom, args.start)
    with open(out, "w") as f:
        f.write("t_s,odom_x_m,odom_y_m,odom_yaw_rad,x_m,y_m,yaw_rad,spread_m\n")
        for t, odom, pose, spread in track:
            f.write(",".join(f"{v:.4f}" for v in (t, *odom, *pose, spread)) + "\n")
    converged = next((t for t, _, _, spread in track if spread < 0.2), None)
    print(f"{len(track)} scans localized over {track[-1][0] - track[0][0]:.1f} s; "
          + (f"the particles gathered within 0.2 m at {converged - track[0][0]:.1f} s" if converged is not None
             else "the particles never gathered within 0.2 m")
          + f"; last pose ({track[-1][2][0]:.2f}, {track[-1][2][1]:.2f}, {math.degrees(track[-1][2][2]):.0f} deg); "
          f"track: {out}")
    return 0


def bag_main(argv: list[str]) -> int:
    args = bag_parser().parse_args(argv)
    try:
        from roar.ros2.bag import convert
    except ImportError as e:
        raise UserError(f"roar ros2 --bag needs {e.name}: pip install 'roar-platform[ros2]'") from None
    try:
        counts = convert(args.recording, args.out)
    except ImportError as e:
        raise UserError(f"roar ros2 --bag needs {e.name}: pip install 'roar-platform[ros2]'") from None
    left = counts.pop("left out")
    written = ", ".join(f"{topic} {n}" for topic, n in sorted(counts.items())) or "nothing"
    print(f"wrote {args.out} (rosbag2, MCAP): {written}; {left} message(s) of other topics left out")
    return 0


def car_model(link_model, args):
    """What the car is: the link's model, unless the user says otherwise; else the defaults."""
    from dataclasses import replace

    from roar.autopilot import CarLimits, CarModel

    told = {k: v for k, v in (("wheelbase", args.wheelbase), ("max_steer", args.max_steer),
                              ("top_speed", args.top_speed)) if v is not None}
    if link_model is not None and not told:
        return link_model
    if link_model is not None and not hasattr(link_model, "wheelbase_m"):
        raise UserError(f"--{'/--'.join(k.replace('_', '-') for k in told)}: this car steers by its wheels' "
                        "speeds and its link says what it is")
    model = link_model or CarModel(WHEELBASE_M, math.radians(MAX_STEER_DEG), CarLimits(
        max_speed_m_s=TOP_SPEED_M_S, max_accel_m_s2=1.78, max_brake_m_s2=2.53, max_lateral_m_s2=3.38))
    if "top_speed" in told:
        model = replace(model, limits=replace(model.limits, max_speed_m_s=told["top_speed"]))
    if "wheelbase" in told:
        model = replace(model, wheelbase_m=told["wheelbase"])
    if "max_steer" in told:
        model = replace(model, max_steer_rad=math.radians(told["max_steer"]))
    return model


def main(argv: list[str]) -> int:
    if "--bag" in argv:
        return bag_main([a for a in argv if a != "--bag"])
    if "--localize-bag" in argv:
        return localize_main([a for a in argv if a != "--localize-bag"])
    ros_args = argv[argv.index(ROS_ARGS):] if ROS_ARGS in argv else []
    args = parser().parse_args(argv[:len(argv) - len(ros_args)])
    try:
        import rclpy
        from rclpy.signals import SignalHandlerOptions

        from roar.ros2.bridge import F1TENTH, STANDARD, Bridge
    except ImportError as e:
        raise UserError(f"roar ros2 needs {e.name}: pip install 'roar-platform[ros2]' "
                        "(the ROS 2 wheels, for Python 3.11)") from None
    if args.domain is not None:
        os.environ["ROS_DOMAIN_ID"] = str(args.domain)
    if args.discovery is not None or "ROS_AUTOMATIC_DISCOVERY_RANGE" not in os.environ:
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = (args.discovery or "localhost").upper()
    if args.map is not None:
        from roar.tracks import get

        get(args.map)  # a name or file that is no track: one line now, not once the node is up
    from roar.ros2.interfaces import ensure

    ensure(log=lambda line: print(f"roar ros2: {line}", flush=True))
    with open_vehicle(args) as car:
        model = car_model(car.transport.link.model(), args)
        track = args.map or car.transport.link.track()
        # our own SIGINT and SIGTERM handling (run_command's): Ctrl-C ends everything at once
        rclpy.init(args=["roar", *ros_args], signal_handler_options=SignalHandlerOptions.NO)
        node = rclpy.create_node("roar")
        bridge = None
        try:
            names = F1TENTH if args.f1tenth else STANDARD
            bridge = Bridge(car, node, model, names, timeout_s=args.timeout, track=track, camera_hz=args.camera,
                            localize=args.localize,
                            log=lambda line: print(f"roar ros2: {line}", flush=True))
            print(f"roar ros2: {car.url} is node /roar on ROS domain {os.environ.get('ROS_DOMAIN_ID', '0')} "
                  f"({os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'].lower()}); drive it on {names.drive} or "
                  f"{names.cmd_vel}; Ctrl-C ends (the car goes to neutral)", flush=True)
            end = None if args.seconds is None else time.monotonic() + args.seconds
            while end is None or time.monotonic() < end:
                rclpy.spin_once(node, timeout_sec=0.05)
        finally:
            try:
                if bridge is not None:
                    bridge.close()
            finally:  # whatever closing raised: a node left up kept the process alive after its error
                node.destroy_node()
                rclpy.try_shutdown()
            if bridge is not None:  # on Ctrl-C too
                c = bridge.counts
                print(f"{c.commands} command(s) driven, {c.refused} refused ({c.last_refusal or 'none'}), "
                      f"{c.timeouts} timeout(s) to neutral; {c.odoms} odometry and {c.scans} scan message(s) "
                      "published; the car was left at neutral", flush=True)
    return 0
