"""The robot side: NumPy-only policy inference (``deploy``), the portable policy file
(``export``), the TurtleBot3 burger in MuJoCo (``mujoco_model``, ``mujoco_rollout``) and
that burger in real time behind ROS 2's topics (``mujoco_ros2``).

``deploy`` and the MuJoCo modules import no JAX; ``export`` reads a run with it."""
