"""Experiments as commands: sweep jobs that train a method's stages and evaluate them (paper IV)."""
