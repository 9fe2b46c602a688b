"""Tests of dda/jit/."""
