"""Wall benchmark: the same as ``dda bench`` (see bench/README).

Usage: python bench/wall.py [--sizes 5 10 20 30 50 100] [--method penalty|augmented-lagrangian|both]
                            [--steps 100]
"""

from dda.bench.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
