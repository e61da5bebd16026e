"""What is done with trained runs: evaluation rollouts, robustness, the reproduction,

ablation, study and sim-to-sim pipelines as functions. Those that train (the
reproduction, the ablation, studies and campaigns) train and test through the study
runner (``runner``); a study file of any kind runs through ``studies``. Commands call
these."""
