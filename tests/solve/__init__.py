"""Tests of dda/solve/."""
