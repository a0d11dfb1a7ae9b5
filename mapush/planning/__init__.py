"""Reference paths for the high level: OMPL plans (evaluation, and training by default) and the paper's random
curved paths (training with `level.path.plan_in_training=false`)."""
