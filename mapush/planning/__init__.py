"""Reference paths for the high level: random curved paths for training, OMPL plans for evaluation."""
