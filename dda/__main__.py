"""``python -m dda``: the ``dda`` command (:mod:`dda.cli`)."""

import sys

from dda.cli import main

sys.exit(main())
