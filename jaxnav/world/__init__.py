"""The world the robot lives in: geometry, mazes and maze files, the LiDAR, the reward.

Everything ``jaxnav/env.py`` is made of. Imports only :mod:`jaxnav.core`."""
