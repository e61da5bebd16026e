"""The agent's parts around ``jaxnav/dqn.py``: exploration strategies, the replay
buffer and the run axis over devices. Imports the environment and below; no files."""
