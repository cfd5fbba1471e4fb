"""Synthetic scenes with ground truth: rendered stereo views of buildings (demo and tests)."""
