"""Tests of dda/contact/."""
