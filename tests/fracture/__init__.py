"""Tests of dda/fracture/."""
