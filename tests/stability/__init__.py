"""Tests of dda/stability/: the factor of safety and the probability of failure."""
