"""The agent's parts around ``jaxnav/dqn.py``: the replay buffer and the run axis.

Imports the environment and :mod:`jaxnav.core`; never reads or writes files."""
