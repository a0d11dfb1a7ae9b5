"""Scene building with MjSpec and the batched MuJoCo simulation core."""
