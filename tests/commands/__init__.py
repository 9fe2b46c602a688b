"""Tests of dda/commands/."""
