"""Benchmarks of ripple-hil (``make bench`` = ``python -m benchmarks``).

Each script in this folder measures one part and prints its figures; ``python -m benchmarks``
runs them all, collects the figures into a table on stdout and a JSON summary
(``benchmarks/results.json`` unless ``--json`` says otherwise). No benchmark asserts a time:
the figures depend on the machine and its load, which the summary records next to them.
"""
