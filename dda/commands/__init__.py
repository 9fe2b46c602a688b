"""Every ``dda`` sub-command in one place: ``cli`` (the ``dda`` command itself: run,
render, and the registration of the others), ``plot``, ``cut``, ``bench`` and
``tradeoff``; ``dda verify`` is registered by the ``verify`` package. The top layer:
may import anything in :mod:`dda`.
"""
