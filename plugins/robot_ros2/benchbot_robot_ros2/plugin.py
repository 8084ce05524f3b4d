"""Hook implementations of the robot_ros2 plugin: robots of type ``ros2`` (``carter_ros2``, ``turtlebot4``), their
backend, and the commands ``benchbot ros2 serve-sim`` and ``benchbot ros2 example-room``. Imports nothing heavy:
cyclonedds/rclpy/Taichi load lazily."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Optional

from benchbot.core.hookspecs import hookimpl

ROBOTS_DIR = Path(__file__).resolve().parent / "robots"

EXAMPLE_ROOM = Path(__file__).resolve().parent / "example_room"
"""The example real-environment pack (original add-on layout): ``environments/example_room_1.yaml`` (type ``real``:
start pose, trajectory, ground truth) with its simulated twin ``example_room_sim_1.yaml``, and their ground truths
in ``ground_truths/``. Installed with ``benchbot install``; ``benchbot ros2 example-room DEST`` copies it to edit
(docs/your-robot.md)."""


@hookimpl
def benchbot_robots() -> list[Path]:
    """``carter_ros2`` (the simulator behind ROS 2) and ``turtlebot4`` (the YAML files in ``robots/``)."""
    return [ROBOTS_DIR]


def _factory(robot_spec: dict, options: dict):
    from benchbot_robot_ros2.backend import Ros2RobotBackend

    return Ros2RobotBackend(robot_spec, options)


@hookimpl
def benchbot_robot_backends() -> dict:
    """``{'ros2': factory}``; ``factory(robot_spec, options) -> Ros2RobotBackend``."""
    return {"ros2": _factory}


@hookimpl
def benchbot_settings() -> list:
    """The environment variables this package reads (benchbot_robot_ros2.settings): ``ROS_DOMAIN_ID``, ``CYCLONEDDS_URI``, ``FASTRTPS_DEFAULT_PROFILES_FILE`` (ROS 2's own) and
    ``BENCHBOT_ROS2_TIME_SCALE``."""
    from benchbot_robot_ros2.settings import SETTINGS

    return list(SETTINGS)


@hookimpl
def benchbot_commands(app: Any) -> None:
    """``benchbot ros2 serve-sim --env ENV`` (the Taichi simulator served as a ROS 2 robot) and ``benchbot ros2
    example-room DEST`` (a copy of :data:`EXAMPLE_ROOM` to edit)."""
    import typer

    from benchbot.cli.options import ARCH_HELP, arch_value, at_most, check_count
    from benchbot.core.limits import MAX_SEED

    ros2 = typer.Typer(help="ROS 2 robots: serve the simulator as a ROS 2 robot; the example room pack.",
                       no_args_is_help=True)

    @ros2.command("serve-sim")
    def serve_sim(
        env: str = typer.Option(..., "--env", "-e", help="Environment, e.g. miniroom:1."),
        domain_id: Optional[int] = typer.Option(None, "--domain-id", min=0, max=232, help="ROS_DOMAIN_ID (default: $ROS_DOMAIN_ID or 0)."),
        camera_size: Optional[str] = typer.Option(None, "--camera-size", help="Camera resolution WIDTHxHEIGHT (default 640x480)."),
        arch: str = typer.Option("auto", "--arch", callback=arch_value, help=ARCH_HELP),
        time_scale: float = typer.Option(1.0, "--time-scale", min=0.01, help="Simulated seconds per wall second."),
        camera_hz: float = typer.Option(10.0, "--camera-hz", min=0.1, help="Camera rate (simulated time)."),
        transport: str = typer.Option("auto", "--transport", help="auto (rclpy if importable), rclpy or cyclonedds."),
        network: str = typer.Option("loopback", "--network", help="loopback (Cyclone DDS on lo unless CYCLONEDDS_URI is set) or system."),
        seed: int = typer.Option(0, "--seed", help=f"Scene seed ({at_most(MAX_SEED)})."),
        robot: str = typer.Option("carter", "--robot", "-r", help="The simulated robot (a robot of type sim_taichi: its camera, laser and footprint)."),
        ros_robot: str = typer.Option("carter_ros2", "--ros-robot", help="The ROS 2 robot definition whose topic and frame names are served (e.g. turtlebot4: its oakd_… frames and topics)."),
    ) -> None:
        """Publish the simulated carter's camera, depth, laser, odometry and TF over ROS 2 and obey /cmd_vel in
        real time; /benchbot/reset (std_msgs/String JSON) reloads the scene. Ctrl-C stops."""
        from benchbot.cli.common import handle_errors
        from benchbot.core.errors import UsageError

        from benchbot_robot_ros2.sim_bridge import parse_size, serve

        @handle_errors
        def _run() -> None:
            check_count("--seed", seed, MAX_SEED)
            domain = domain_id
            if domain is None:
                from benchbot.core import settings
                from benchbot_robot_ros2.settings import ROS_DOMAIN_ID

                try:
                    domain = settings.value(ROS_DOMAIN_ID)
                except UsageError as exc:
                    raise UsageError(exc.message, "use a domain id 0..232, or --domain-id") from None
            w, h = parse_size(camera_size)
            serve(env, domain_id=domain, width=w, height=h, arch=arch, time_scale=time_scale, camera_hz=camera_hz,
                  transport=transport, network=network, seed=seed, robot=robot, ros_robot=ros_robot)

        _run()

    @ros2.command("example-room")
    def example_room(
        dest: Path = typer.Argument(..., help="A new folder to write the pack into (e.g. ./my_room)."),
    ) -> None:
        """Write the example real-environment pack (a room of type real with its start pose, trajectory and
        ground-truth template, and its simulated twin) into DEST, to edit for your own room and install with
        `benchbot install DEST` (docs/your-robot.md)."""
        import shutil

        from benchbot.cli.common import handle_errors
        from benchbot.core.errors import UsageError

        @handle_errors
        def _run() -> None:
            if dest.exists():
                raise UsageError(f"{dest} already exists", "name a new folder, e.g. ./my_room")
            try:
                shutil.copytree(EXAMPLE_ROOM, dest, ignore=shutil.ignore_patterns("__pycache__"))
            except OSError as exc:
                raise UsageError(f"{dest}: cannot write the pack ({exc.strerror or exc})",
                                 "choose a writable folder") from None
            print(f"wrote the example room pack to {dest}: edit environments/ and ground_truths/ (docs/your-robot.md),"
                  f" then `benchbot install {dest}`")

        _run()

    app.add_typer(ros2, name="ros2")
