"""Tests of dda/tradeoff/."""
