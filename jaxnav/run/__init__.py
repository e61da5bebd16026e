"""The host side of a training run: the loop around the compiled trainer (chunks,
progress, checkpoints, resume), the greedy evaluation while it trains and
TensorBoard curves. Imports the agent and below."""
