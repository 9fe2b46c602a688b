"""Tests of dda/run/."""
