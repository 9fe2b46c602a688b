"""Tests of dda/scene/rockmass/: rock masses cut into blocks, their drawings."""
