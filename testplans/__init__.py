"""The bench test plans: the paper's experiments, one module per ripple source, plus the baseline.

What a bench engineer edits: sweeps and operating points live in :mod:`testplans.conditions`;
the modules only say which points to run. No analysis or driver code lives here.
"""
