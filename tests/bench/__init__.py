"""Tests of dda/bench/."""
