"""Reference drivers: the privileged oracle planner and the dynamic window approach,
each a policy the test rollout plays exactly as it plays a learned one. Imports the
environment and the world; nothing of training."""
