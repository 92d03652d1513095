"""``hil station``: one bench's operator page in the browser (design.md §10).

The station is a *sink* of the run record: it starts the same ``hil run`` the command line
starts (a child process, so Stop is the same Ctrl-C and the same safe stop), tails the record's
``journal.jsonl`` for live progress, plots and verdicts, and states the end of a run with the one
derivation page 1 uses (``reports/statement.py``). Nothing it does can make a run fail or wait:
it only reads the record folder (and writes operator answers into its own folder).

Modules, one job each: :mod:`hil.station.journal` (follow one record folder),
:mod:`hil.station.runs` (start/stop the child run, one per bench), :mod:`hil.station.view`
(record → what the page shows), :mod:`hil.station.plots` (server-rendered SVG),
:mod:`hil.station.history` (the station's past runs from the record folders),
:mod:`hil.station.app` (the Starlette application: page, JSON, server-sent events).
"""
