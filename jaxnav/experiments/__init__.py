"""What is done with trained runs: evaluation rollouts, robustness, the reproduction,

ablation, study and sim-to-sim pipelines as functions. Commands call these."""
