"""What the agents (``jaxnav/dqn.py``, ``jaxnav/pqn.py``) are made of: the trainer
contract, the Q-network and TD loss, exploration strategies, the replay buffer and the
run axis over devices. Imports the environment and below; no files."""
