"""The plans a station offers and how many points each has (for progress per plan).

Plans are ``hil run``'s sources (:func:`hil.commands.run.plan_modules`). Point counts come from
pytest's own collection of the plans with the station's bench file (``--collect-only``, once, in
a child process at station start-up), so they are the run's own test ids, not a second count.
"""

from __future__ import annotations

import subprocess
import sys
from collections import Counter
from pathlib import Path


def available_plans() -> list[str]:
    from hil.commands.run import plan_modules

    return list(plan_modules())


def collect_totals(bench_path: str | None, python: str = sys.executable,
                   timeout_s: float = 300) -> dict[str, int]:
    """Points per plan, as pytest collects them for this bench (``{}`` when collection fails:
    the page then shows points done without a total)."""
    from hil.commands.run import plan_modules, unrelated_plugins

    modules = plan_modules()
    command = [python, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider",
               *unrelated_plugins(), *[str(path) for path in modules.values()],
               "--rootdir", str(next(iter(modules.values())).parent.parent)]
    if bench_path:
        command += ["--hil-bench", bench_path]
    try:
        output = subprocess.run(command, capture_output=True, text=True, timeout=timeout_s,
                                stdin=subprocess.DEVNULL).stdout
    except (OSError, subprocess.TimeoutExpired):
        return {}
    by_file = {path.name: name for name, path in modules.items()}
    counts = Counter(by_file.get(Path(line.split("::", 1)[0]).name)
                     for line in output.splitlines() if "::" in line)
    counts.pop(None, None)
    return {name: counts.get(name, 0) for name in modules}
