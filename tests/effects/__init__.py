"""Tests of dda/effects/."""
