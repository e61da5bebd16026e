"""The host side of a training run: the loop around the compiled trainer, the run

directory, checkpoints and TensorBoard. Imports the agent and everything below it."""
