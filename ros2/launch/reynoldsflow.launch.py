"""Example: the ReynoldsFlow node on a robot's camera topic.

    ros2 launch reynoldsflow.launch.py camera:=/camera/image_raw cues:=true threads:=2

`reynoldsflow-ros2` is a plain executable (no ament package), so it is
started with ExecuteProcess; put it on PATH or pass `executable:=/path/to/it`.
Pair it with any camera driver (usb_cam, v4l2_camera, gscam, a bag): the
node reads mono8, rgb8, bgr8, rgba8 and bgra8 at the sensor-data QoS those
drivers publish with, and publishes rgb8 on <namespace>/reynoldsflow/image
(and vision_msgs/Detection2DArray on <namespace>/reynoldsflow/cues).
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess, LogInfo
from launch.conditions import IfCondition, UnlessCondition
from launch.substitutions import LaunchConfiguration


def generate_launch_description():
    arg = LaunchConfiguration
    declared = [
        DeclareLaunchArgument("executable", default_value="reynoldsflow-ros2"),
        DeclareLaunchArgument("namespace", default_value="/", description="the node's namespace, e.g. /drone1"),
        DeclareLaunchArgument("camera", default_value="/camera/image_raw", description="sensor_msgs/Image to read"),
        DeclareLaunchArgument("output", default_value="reynoldsflow/image"),
        DeclareLaunchArgument("cues", default_value="false", description="also publish reynoldsflow/cues"),
        DeclareLaunchArgument("threads", default_value="2", description="threads per pair (latency: one pair at a time)"),
        DeclareLaunchArgument("first_frame", default_value="drop", description="drop | repeat | black"),
        DeclareLaunchArgument("scale", default_value="minmax", description="minmax | fixed:KD,KC"),
        DeclareLaunchArgument("variant", default_value="dc", description="dc | dc0 | cd | hsv"),
    ]
    command = [
        arg("executable"),
        "--namespace", arg("namespace"),
        "--input", arg("camera"),
        "--output", arg("output"),
        "--threads", arg("threads"),
        "--first-frame", arg("first_frame"),
        "--scale", arg("scale"),
        "--variant", arg("variant"),
    ]
    with_cues = IfCondition(arg("cues"))
    without_cues = UnlessCondition(arg("cues"))
    return LaunchDescription(
        declared
        + [
            LogInfo(msg=["ReynoldsFlow of ", arg("camera")]),
            # SIGINT on Ctrl-C: the node finishes its frame and exits 0.
            ExecuteProcess(cmd=command + ["--cues"], output="screen", condition=with_cues),
            ExecuteProcess(cmd=command, output="screen", condition=without_cues),
        ]
    )
