"""The robot side: NumPy-only policy inference (``deploy``), the portable policy file
(``export``) and the TurtleBot3 burger in MuJoCo (``mujoco_model``, ``mujoco_rollout``).

``deploy`` and the MuJoCo modules import no JAX; ``export`` reads a run with it."""
