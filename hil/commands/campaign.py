"""``hil campaign GRID.toml``: a regression grid of whole plan runs on Dask.

Every run is a normal ``hil run`` on its own simulated bench (bench file = the grid's base with
the run's overrides: hil/campaign/grid_spec.py), on an embedded LocalCluster or an existing
Dask cluster (``--scheduler tcp://HOST:8786``); every record is sealed, kept in ``--out`` and
indexed in the results database. Ctrl-C keeps the finished runs: the same command resumes.
Example grid: hil/examples/grid.toml.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


from hil.commands import description

def register(subparsers) -> None:
    parser = subparsers.add_parser("campaign", help="a regression grid of plan runs on Dask "
                                   "(bench variations x plan selections)",
                                   description=description(__doc__),
                                   epilog=__doc__.split("\n\n")[1])
    parser.add_argument("grid", metavar="GRID.toml", help="grid file, e.g. hil/examples/grid.toml")
    parser.add_argument("--out", metavar="DIR", type=Path,
                        help="grid folder: records, run index (default: grid-<file name>)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="tcp://HOST:8786 of an existing Dask cluster (default: a "
                             "LocalCluster on this machine)")
    parser.add_argument("--workers", type=int, help="LocalCluster workers (default: cores)")
    parser.add_argument("--results-db", metavar="URL",
                        help="results database (SQLAlchemy URL or 'off'; default: "
                             "RIPPLE_HIL_RESULTS_DB, else results.sqlite in the grid folder)")
    parser.add_argument("--list", action="store_true",
                        help="print the grid's runs (keys, coordinates) and exit")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(func=run)


def run(args) -> int:
    from hil.campaign.grid import GridInterrupted, run_grid, summary_table
    from hil.campaign.grid_spec import load_grid
    from hil.errors import InputError

    runs = load_grid(args.grid)
    if args.list:
        for item in runs:
            print(f"{item.key}  {item.name}")
        return 0
    if args.workers is not None and args.workers < 1:
        raise InputError(f"--workers {args.workers} must be >= 1")
    folder = args.out or Path(f"grid-{Path(args.grid).stem}")
    try:
        result = run_grid(runs, folder, scheduler=args.scheduler, n_workers=args.workers,
                          results_db=args.results_db,
                          progress=not args.no_progress and sys.stderr.isatty())
    except GridInterrupted as stop:
        print(f"hil campaign: {stop}", file=sys.stderr)
        raise
    summary = {"folder": str(result.folder), "runs": result.rows,
               "computed": len(result.computed), "resumed": len(result.skipped),
               "no_record": len(result.failed), "indexed": result.indexed,
               "workers": result.workers, "wall_s": round(result.wall_s, 1)}
    (Path(folder) / "grid.json").write_text(json.dumps(summary, indent=1))
    if args.json:
        print(json.dumps(summary))
    else:
        print(summary_table(result.rows))
        print(f"{len(result.computed)} run(s) computed on {result.workers} worker(s), "
              f"{len(result.skipped)} resumed, {len(result.failed)} without a record; "
              f"{result.indexed} indexed; wall {result.wall_s:.0f} s; folder {folder}")
    return 1 if result.failed or any(r["state"] != "done" for r in result.rows) else 0
