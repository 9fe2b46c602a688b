"""``python -m dda``: the ``dda`` command (:mod:`dda.commands.cli`)."""

import sys

from dda.commands.cli import main

sys.exit(main())
