"""``hil station``: the operator's page for one bench, in the browser (issue 25).

Serves on 127.0.0.1 by default. Enter or scan the unit's serial number, pick the plans, Start:
the station runs the same ``hil run`` as the command line (simulated bench unless --bench);
Stop is Ctrl-C for that run (drive made safe, record ``interrupted``). One run per bench at a
time; closing the browser does not stop the run. Another address needs --host and an access
token (--token, or one generated and printed with the URL); on loopback a --token is allowed.
Requests naming another Host, and commands not from the station's own page, are refused (403).
"""

from __future__ import annotations

import errno
import ipaddress
import secrets
import socket
import sys

from hil.errors import InputError

DEFAULT_PORT = 8725


def register(subparsers) -> None:
    parser = subparsers.add_parser("station", help="the operator's page in the browser",
                                   description=__doc__.split("\n\n")[0].replace("``", ""),
                                   epilog=__doc__.split("\n\n")[-1])
    parser.add_argument("--bench", metavar="FILE", help="bench file (default: simulated bench)")
    parser.add_argument("--port", type=int, default=DEFAULT_PORT,
                        help=f"TCP port (default {DEFAULT_PORT})")
    parser.add_argument("--host", default="127.0.0.1",
                        help="address to serve on (default 127.0.0.1; any other needs a token)")
    parser.add_argument("--token", metavar="TEXT",
                        help="access token: required for a non-loopback --host (default: "
                             "generated), optional on loopback")
    parser.add_argument("--allow-host", action="append", default=[], metavar="NAME",
                        help="another name of --host the operators' browsers use (e.g. the "
                             "machine's DNS name); requests naming any other Host are refused; "
                             "repeatable")
    parser.add_argument("--record-dir", metavar="DIR", default="records",
                        help="folder of the run records (default: records)")
    parser.add_argument("--plan", action="append", default=[], metavar="FILE.py",
                        help="a plan of your own (a pytest file using the ripple-hil fixtures, "
                             "docs/writing-plans.md) offered beside the shipped plans; repeatable")
    parser.add_argument("--selection", action="append", default=[], metavar="NAME=PLAN,…",
                        help="a saved selection of plans the operator picks with one button, "
                             "e.g. 'end of line=self_check,baseline,dc_offset'; repeatable")
    parser.add_argument("--requirements", metavar="SPEC.toml",
                        help="the customer's requirements every unit is judged against (the "
                             "final banner states conformity to them; without any it says "
                             "none were given)")
    parser.add_argument("--selection-requirements", action="append", default=[],
                        metavar="NAME=SPEC.toml",
                        help="requirements of one saved --selection (a unit run with exactly "
                             "its plans is judged against them instead); repeatable")
    parser.add_argument("--results-db", metavar="URL",
                        help="results database every unit's record is indexed in (as hil run "
                             "--results-db; default: hil run's rule)")
    parser.set_defaults(func=run)


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def own_plans(files: list[str]) -> dict[str, str]:
    """``--plan FILE.py`` → {plan name (file stem without ``test_``): absolute path}."""
    from pathlib import Path

    from hil.commands.run import plan_modules

    plans: dict[str, str] = {}
    for text in files:
        path = Path(text)
        if path.suffix != ".py" or not path.is_file():
            raise InputError(f"--plan {text}: not a Python file")
        name = "own:" + path.stem.removeprefix("test_")
        if name in plans or path.stem.removeprefix("test_") in plan_modules():
            raise InputError(f"--plan {text}: a plan named {name} is already offered")
        plans[name] = str(path.resolve())
    return plans


def selections(texts: list[str], plans: list[str]) -> dict[str, list[str]]:
    """``--selection NAME=PLAN,PLAN`` → {name: plans}, every plan one the station offers."""
    out: dict[str, list[str]] = {}
    for text in texts:
        name, _, listed = text.partition("=")
        chosen = [item.strip() for item in listed.split(",") if item.strip()]
        unknown = [item for item in chosen if item not in plans]
        if not name.strip() or not chosen or unknown:
            raise InputError(f"--selection {text!r}: give NAME=PLAN[,PLAN…] with plans among "
                             f"{', '.join(plans)}" + (f"; unknown: {', '.join(unknown)}"
                                                      if unknown else ""))
        out[name.strip()] = chosen
    return out


def selection_requirements(texts: list[str], saved: dict[str, list[str]]
                           ) -> dict[frozenset, str]:
    """``--selection-requirements NAME=SPEC.toml`` → {plans of that selection: file}, each file
    loaded once here (a bad one: one line before serving)."""
    from pathlib import Path

    from hil.requirements import load_requirements

    out: dict[frozenset, str] = {}
    for text in texts:
        name, _, path = text.partition("=")
        if name.strip() not in saved or not path.strip():
            raise InputError(f"--selection-requirements {text!r}: give NAME=SPEC.toml with NAME "
                             f"a --selection ({', '.join(saved) or 'none given'})")
        load_requirements(path.strip())
        plans = frozenset(saved[name.strip()])
        if plans in out:
            raise InputError(f"--selection-requirements {text!r}: another selection with the "
                             f"same plans already has requirements")
        out[plans] = str(Path(path.strip()).resolve())
    return out


def run(args) -> int:
    import uvicorn

    from hil.station.app import Station, create_app
    from hil.station.plans import available_plans, collect_totals
    from hil.station.plots import warm_up
    from hil.station.runs import RunManager

    if not 0 < args.port < 65536:
        raise InputError(f"--port {args.port}: allowed 1…65535")
    token = args.token
    if not is_loopback(args.host):
        token = token or secrets.token_urlsafe(18)
    if token is not None and len(token) < 16:
        raise InputError("--token: at least 16 characters")
    if is_wildcard(args.host) and not args.allow_host:
        raise InputError(f"--host {args.host} serves every address: name the ones the "
                         f"operators' browsers use with --allow-host (any other Host is refused)")
    if args.bench:
        from hil.config import load_bench

        load_bench(args.bench)          # a bad bench file: one line, before serving
    own = own_plans(args.plan)
    offered = available_plans() + list(own)
    saved = selections(args.selection, offered)
    requirements = None
    if args.requirements:
        from pathlib import Path

        from hil.requirements import load_requirements

        load_requirements(args.requirements)     # a bad file: one line, before serving
        requirements = str(Path(args.requirements).resolve())
    listening = bind(args.host, args.port)        # a port in use: refused before any URL
    manager = RunManager(args.bench, args.record_dir, own_plans=own, requirements=requirements,
                         results_db=args.results_db,
                         selection_requirements=selection_requirements(
                             args.selection_requirements, saved))
    station = Station(manager, offered, f"bench: {args.bench or 'simulated (in-process)'}",
                      totals_loader=lambda: collect_totals(args.bench), warm_up=warm_up,
                      selections=saved)
    shown = args.host if not is_wildcard(args.host) else args.allow_host[0]
    shown = f"[{shown}]" if ":" in shown else shown
    url = f"http://{shown}:{args.port}/" + (f"?token={token}" if token else "")
    print(f"hil station: {url} (records in {manager.record_root}; Ctrl-C to stop serving)",
          flush=True)
    app = create_app(station, token, address=(args.host, args.port),
                     allow_hosts=tuple(args.allow_host))
    config = uvicorn.Config(app, log_level="warning", lifespan="on",
                            timeout_graceful_shutdown=5)
    server = uvicorn.Server(config)
    station.shutting_down = lambda: server.should_exit
    server.run(sockets=[listening])
    return 0 if server.started else 2


def is_wildcard(host: str) -> bool:
    """``0.0.0.0`` / ``::``: every address of the machine."""
    try:
        return ipaddress.ip_address(host).is_unspecified
    except ValueError:
        return False


def bind(host: str, port: int) -> socket.socket:
    """The listening socket, bound before the URL is printed: a port in use (or an address this
    machine does not have) is bad input, exit 2, and no URL is shown."""
    try:
        family = socket.AF_INET6 if ipaddress.ip_address(host).version == 6 else socket.AF_INET
    except ValueError:
        family = socket.AF_INET
    listening = socket.socket(family, socket.SOCK_STREAM)
    listening.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        listening.bind((host, port))
    except OSError as exc:
        listening.close()
        if exc.errno == errno.EADDRINUSE:
            raise InputError(f"--port {port}: the port is in use on {host} (another station or "
                             f"program is serving there); choose another --port") from None
        raise InputError(f"--host {host} --port {port}: cannot serve there: "
                         f"{exc.strerror or exc}") from None
    return listening                 # not inheritable: the runs' child processes never hold it
