"""Tests of verify/, the FEM verification harness, and of its catching engine faults."""
