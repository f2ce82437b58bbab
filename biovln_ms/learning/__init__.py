"""Learning from trajectories: the recorder, the dataset, behavioural cloning and RL helpers."""
