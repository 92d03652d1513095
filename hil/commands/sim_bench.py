"""``hil sim-bench``: start the simulated instruments in this process and print their bench file.

The drive is served over CAN-over-TCP on 127.0.0.1 (python-can-remote), the DAQ over Modbus TCP on
127.0.0.1 and the transducer on a pseudo-terminal. Another process runs against it with only the
printed file: ``pytest testplans --bench sim.toml`` or ``hil run --bench sim.toml``. It serves until
Ctrl-C / SIGTERM, or for ``--duration-s`` seconds.
"""

from __future__ import annotations

import signal
import sys
import threading
from pathlib import Path

from hil.commands.run import seed_value
from hil.errors import InputError


def register(subparsers) -> None:
    parser = subparsers.add_parser("sim-bench", help="start the simulated instruments; print a "
                                   "bench file for them", description=__doc__.splitlines()[0])
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


def bench_file_text(config_dict: dict) -> str:
    """TOML of a bench as loaded, with unset (None) keys left out."""
    import tomli_w

    def drop_none(value):
        if isinstance(value, dict):
            return {k: drop_none(v) for k, v in value.items() if v is not None}
        if isinstance(value, list):
            return [drop_none(v) for v in value]
        return value

    header = ("# Written by `hil sim-bench`: simulated instruments served by another process.\n"
              "# The addresses below make `hil run --bench` connect to them instead of starting\n"
              "# its own.\n")
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
    try:
        text = bench_file_text(served.to_dict())
        if args.output:
            atomic_write_bytes(Path(args.output), text.encode())
        sys.stdout.write(text)
        sys.stdout.flush()
        try:
            stop.wait(args.duration_s)
        except KeyboardInterrupt:
            pass
    finally:
        simulated.stop()
    return 0
