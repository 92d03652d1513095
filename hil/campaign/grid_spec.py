"""A regression grid (``hil campaign GRID.toml``): bench-file variations × plan selections.

The grid file names a base bench file and axes of variations; every variation is a table of
bench-file overrides with dotted keys, so any table of the bench file can vary (``[motor]``,
``[operating_point]``, ``[simulation.defects]``, ``[simulation.actual]``, ``[drive]`` …)::

    bench = "sim-bench"        # a shipped example's name, or a path relative to this file
    seed = 0                   # hil run --seed of every run
    plans = [["baseline"], ["dc_offset", "dead_time"]]   # plan selections (hil run --source);
                                                          # [] = every plan
    [axes.motor]               # one axis; its variants, each a table of overrides
    table_i = {}
    p8_48v = {"motor.pole_count" = 8, "motor.dc_bus_v" = 48.0}
    [axes.defect]
    none = {}
    offset = {"simulation.defects.ia_offset_a" = 0.5}

The runs are the product of the axes (in file order) and the plan selections. Each run's bench
file is the base with its overrides applied and validated (:class:`hil.config.BenchConfig`
names a wrong key); its identity is :func:`run_key`, the SHA-256 of the resolved bench, the
plan selection and the seed — a rerun of the grid skips the runs whose key is done, whatever
their order or the other runs. A base bench with relative paths in it must be given with
absolute ones (a run's bench file is written on the worker).
"""

from __future__ import annotations

import hashlib
import itertools
import json
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hil.errors import InputError

_TOP_KEYS = {"bench", "seed", "plans", "axes", "timeout_s"}
#: A run's own time limit unless the grid file says (s).
DEFAULT_TIMEOUT_S = 1800.0


@dataclass(frozen=True)
class GridRun:
    """One whole ``hil run`` of the grid."""

    #: Axis name → variant name (the run's coordinates in the grid).
    labels: dict[str, str]
    #: The resolved bench file (base + overrides) as a TOML table.
    bench: dict[str, Any]
    #: ``hil run --source`` names; empty: every plan.
    sources: tuple[str, ...] = ()
    seed: int = 0
    timeout_s: float = DEFAULT_TIMEOUT_S
    key: str = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "key", run_key(self.bench, self.sources, self.seed))

    @property
    def name(self) -> str:
        coords = [f"{axis}={variant}" for axis, variant in self.labels.items()]
        return ", ".join(coords + [f"plans={'+'.join(self.sources) or 'all'}"])


def run_key(bench: dict, sources: tuple[str, ...], seed: int) -> str:
    """SHA-256 (hex, first 16 digits) of the resolved bench, the plan selection and the seed."""
    text = json.dumps({"bench": bench, "sources": sorted(sources), "seed": seed},
                      sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def apply_overrides(base: dict, overrides: dict[str, Any], where: str) -> dict:
    """A copy of ``base`` with each ``"table.sub.key" = value`` set (tables made as needed)."""
    result = json.loads(json.dumps(base))
    for dotted, value in overrides.items():
        parts = dotted.split(".")
        if len(parts) < 2 or not all(parts):
            raise InputError(f"{where}: override {dotted!r} must be a dotted key "
                             "'table.key' (e.g. 'motor.dc_bus_v')")
        table = result
        for part in parts[:-1]:
            table = table.setdefault(part, {})
            if not isinstance(table, dict):
                raise InputError(f"{where}: override {dotted!r}: {part!r} is not a table")
        table[parts[-1]] = value
    return result


def check_bench(bench: dict, where: str) -> None:
    """Validate a run's bench file (the key and allowed range named on a problem)."""
    from hil.config import BenchConfig

    BenchConfig.from_dict(bench, source=where)


def load_grid(path: str | Path) -> list[GridRun]:
    """The runs of a grid file (module docstring), each bench validated."""
    path = Path(path)
    try:
        table = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(f"grid file {str(path)!r} cannot be read: {exc.strerror}") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"grid file {str(path)!r} is not valid TOML: {exc}") from None
    unknown = sorted(set(table) - _TOP_KEYS)
    if unknown:
        raise InputError(f"{path}: unknown key(s) {', '.join(unknown)} "
                         f"(allowed: {', '.join(sorted(_TOP_KEYS))})")
    base = _base_bench(table.get("bench", "sim-bench"), path)
    seed = table.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"{path}: seed = {seed!r} must be an integer >= 0")
    timeout_s = table.get("timeout_s", DEFAULT_TIMEOUT_S)
    if isinstance(timeout_s, bool) or not isinstance(timeout_s, (int, float)) or timeout_s <= 0:
        raise InputError(f"{path}: timeout_s = {timeout_s!r} must be a number > 0")
    plans = table.get("plans", [[]])
    if not isinstance(plans, list) or not plans or not all(
            isinstance(p, list) and all(isinstance(s, str) for s in p) for p in plans):
        raise InputError(f"{path}: plans must be a list of plan selections, each a list of "
                         "plan names (e.g. [[\"baseline\"], []]; [] = every plan)")
    axes = table.get("axes", {})
    if not isinstance(axes, dict) or not all(isinstance(v, dict) and v for v in axes.values()):
        raise InputError(f"{path}: [axes.NAME] tables must each hold at least one variant")
    names = list(axes)
    runs = []
    for combo in itertools.product(*(list(axes[a].items()) for a in names)):
        overrides: dict[str, Any] = {}
        for axis, (variant, changes) in zip(names, combo):
            if not isinstance(changes, dict):
                raise InputError(f"{path}: axes.{axis}.{variant} must be a table of overrides")
            overrides |= _flatten(changes)
        labels = {axis: variant for axis, (variant, _) in zip(names, combo)}
        where = f"{path} ({', '.join(f'{a}={v}' for a, v in labels.items()) or 'base'})"
        bench = apply_overrides(base, overrides, where)
        check_bench(bench, where)
        runs += [GridRun(labels, bench, tuple(p), seed, float(timeout_s)) for p in plans]
    keys = [run.key for run in runs]
    if len(set(keys)) != len(keys):
        raise InputError(f"{path}: two runs of the grid are the same run (same bench, plans "
                         "and seed); make the variants differ")
    return runs


def _flatten(changes: dict, prefix: str = "") -> dict[str, Any]:
    """``{"motor": {"dc_bus_v": 48}}`` or ``{"motor.dc_bus_v": 48}`` → dotted keys (TOML
    parses an unquoted dotted key as nested tables; a quoted one stays one key)."""
    flat = {}
    for key, value in changes.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict) and value:
            flat |= _flatten(value, f"{name}.")
        else:
            flat[name] = value
    return flat


def _base_bench(name: str, grid_path: Path) -> dict:
    from hil.config import example_bench_path

    candidate = (grid_path.parent / name)
    path = candidate if candidate.suffix == ".toml" else example_bench_path(name)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(f"{grid_path}: bench {name!r} cannot be read: {exc.strerror}") from None
