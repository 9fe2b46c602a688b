"""Accuracy against time: sweep the settings that buy accuracy, measure both.

``grid``: the settings swept (contact method, penalty, AL tolerance, time
step, maximum displacement ratio). ``cases``: the studied cases, their
measured quantity and reference. ``checks``: every setting's scene checked
before any run. ``runner``: one run, and the sweep through
dask.distributed (or serially). ``pareto``: the non-dominated runs.
``report``: CSV, markdown table and the Pareto plot. ``cli``: ``dda tradeoff``.
"""
