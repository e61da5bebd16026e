"""The host side of a training run: the loop around the compiled trainer (chunks,
progress, checkpoints, resume) and TensorBoard curves. Imports the agent and below."""
