"""Tests of dda/io/."""
