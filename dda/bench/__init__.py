"""Performance benchmarks: the standard wall scene, measurement and ``dda bench``."""
