"""For users with a ROS 2 install: the car as a node beside your own, from one launch file.

    ros2 launch examples/ros2/bridge.launch.py track:=oval f1tenth:=true
    ros2 launch examples/ros2/bridge.launch.py url:=serial:///dev/ttyUSB0 localize:=false

`roar ros2` is a plain process (roar's own rclpy from PyPI, or your install's); this starts it with
the arguments below and ends it with the launch (SIGINT: the car goes to neutral). Add your nodes
beside it. The launch packages come with a ROS install (PyPI has no wheels of them), so the suite
checks the command lines this file makes against roar's own parser rather than launching it.
"""

ARGUMENTS = {  # name: (default, what it is)
    "roar": ("roar", "the roar command (in a virtual environment: its path, .venv/bin/roar)"),
    "url": ("sim://", "the car; sim:// is the simulator, on track:="),
    "track": ("oval", "the simulator's track: a name roar knows (random:7, circuit:3, ...) or a file"),
    "f1tenth": ("false", "f1tenth_gym_ros's topic and frame names"),
    "localize": ("true", "our particle filter: /pose and map -> odom (not with f1tenth:=true)"),
}


def bridge_command(roar: str, url: str, track: str, f1tenth: str, localize: str) -> list[str]:
    """The roar ros2 command line for these launch arguments (each as launch gives it: text)."""
    if url.startswith("sim://") and track and "?" not in url:
        url = f"{url}?track={track}"
    # --f1tenth puts odometry in the map frame, where --localize has no map -> odom to publish
    flag = ["--f1tenth"] if f1tenth.lower() == "true" else ["--localize"] if localize.lower() == "true" else []
    return [roar, "ros2", url, *flag]


def generate_launch_description():
    from launch import LaunchDescription
    from launch.actions import DeclareLaunchArgument, ExecuteProcess, OpaqueFunction
    from launch.substitutions import LaunchConfiguration

    def bridge(context):
        values = {name: LaunchConfiguration(name).perform(context) for name in ARGUMENTS}
        return [ExecuteProcess(cmd=bridge_command(**values), output="screen", sigterm_timeout="2")]

    declared = [DeclareLaunchArgument(name, default_value=default, description=about)
                for name, (default, about) in ARGUMENTS.items()]
    return LaunchDescription([*declared, OpaqueFunction(function=bridge)])
