"""``hil sim-bench``: start the simulated instruments in this process and print their bench file.

The drive is served over CAN-over-TCP on 127.0.0.1 (python-can-remote), the DAQ over Modbus TCP on
127.0.0.1 and the transducer on a pseudo-terminal. Another process runs against it with only the
printed file: ``pytest testplans --bench sim.toml`` or ``hil run --bench sim.toml``. It serves until
Ctrl-C / SIGTERM, or for ``--duration-s`` seconds, then removes its ``-o`` file (the addresses die
with it). A client killed mid-session ends its session quietly; a closed standard output is not
an error while the ``-o`` file carries the addresses.
"""

from __future__ import annotations

from hil.commands import description

import os
import signal
import sys
import threading
from pathlib import Path

from hil.commands.run import seed_value
from hil.errors import InputError


def register(subparsers) -> None:
    parser = subparsers.add_parser("sim-bench", help="start the simulated instruments; print a "
                                   "bench file for them", description=description(__doc__))
    parser.add_argument("--bench", metavar="FILE",
                        help="simulated bench file to start from (default: the shipped one)")
    parser.add_argument("-o", "--output", metavar="FILE.toml",
                        help="also write the bench file here (atomically, once all are ready)")
    parser.add_argument("--duration-s", type=float, default=None,
                        help="stop after this many seconds (default: until Ctrl-C / SIGTERM)")
    parser.add_argument("--seed", type=seed_value, default=0,
                        help="seed of the simulated drive, an integer >= 0")
    parser.add_argument("--defect", metavar="KEY=VALUE", action="append", default=[],
                        help="test-only defect of the simulated drive (repeatable; overrides the "
                        "bench file's [simulation.defects]), e.g. injection_scale=1.2, "
                        "ignore_injection=dead_time_s,ia_offset_a, daq_drop_every_nth=10")
    parser.set_defaults(func=run)


#: The header of the bench file `hil sim-bench` prints.
SERVED_HEADER = ("# Written by `hil sim-bench`: simulated instruments served by another process.\n"
                 "# The addresses below make `hil run --bench` connect to them instead of starting\n"
                 "# its own.\n")


def bench_file_text(config_dict: dict, header: str = SERVED_HEADER) -> str:
    """TOML of a bench as loaded, with unset (None) keys left out, after ``header``."""
    import tomli_w

    def drop_none(value):
        if isinstance(value, dict):
            return {k: drop_none(v) for k, v in value.items() if v is not None}
        if isinstance(value, list):
            return [drop_none(v) for v in value]
        return value

    return header + tomli_w.dumps(drop_none(config_dict))


def run(args) -> int:
    from hil.capture import atomic_write_bytes
    from hil.config import default_sim_bench, load_bench
    from hil.simbench import SimulatedBench

    if args.duration_s is not None and args.duration_s <= 0:
        raise InputError(f"--duration-s {args.duration_s:g} must be > 0")
    config = load_bench(args.bench) if args.bench else default_sim_bench()
    if not config.simulated:
        raise InputError(f"--bench {args.bench}: not a simulated bench (simulated = false)")
    if args.defect:
        from hil.sim.defects import parse_defect_option

        defects = dict(parse_defect_option(text) for text in args.defect)
        config = config.with_overrides({"simulation": {"defects": defects}})
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    simulated = SimulatedBench(config, seed=args.seed, cross_process=True)
    served = simulated.start()
    output = Path(args.output) if args.output else None
    text = ""
    try:
        text = bench_file_text(served.to_dict())
        if output is not None:
            atomic_write_bytes(output, text.encode())
        if print_bench_file(text) or output is not None:
            try:
                stop.wait(args.duration_s)
            except KeyboardInterrupt:
                pass
        else:
            sys.stderr.write("ripple-hil: sim-bench: standard output closed and no -o file: "
                             "nobody has the bench file, stopping\n")
    finally:
        simulated.stop()
        if output is not None:
            remove_bench_file(output, text)
    return 0


def print_bench_file(text: str) -> bool:
    """Write the bench file to standard output; False if its reader has gone (a closed pipe:
    stdout is then pointed at /dev/null, so the exit flush raises nothing either)."""
    try:
        sys.stdout.write(text)
        sys.stdout.flush()
        return True
    except BrokenPipeError:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
        return False


def remove_bench_file(path: Path, text: str) -> None:
    """Remove the ``-o`` bench file on exit: its addresses die with this process, and a stale
    file would send a later ``hil run --bench`` to ports nobody serves (issue 22.8). A file
    rewritten meanwhile by someone else is left alone."""
    try:
        if text and path.read_text(encoding="utf-8") == text:
            path.unlink()
    except OSError:
        pass
