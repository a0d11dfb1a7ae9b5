"""Tables and plots of the paper's experiments, generated from the sweep jobs under runs/."""
