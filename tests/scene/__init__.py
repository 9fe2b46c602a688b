"""Tests of dda/scene/."""
