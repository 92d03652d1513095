"""Issue 22.9: installed as a package, the first run says it is compiling the engine (and does
so before any instrument is served), and `hil run` gives pytest no reason for a warning."""

import io
import subprocess
import sys

from _pytest.assertion.rewrite import AssertionRewriter

from hil.sim import warmup


def test_a_cold_engine_prints_a_progress_line_and_the_time(monkeypatch):
    monkeypatch.setattr(warmup, "engine_cached", lambda: False)
    stream = io.StringIO()
    warmup.prepare_twin_engine(stream)
    lines = stream.getvalue().splitlines()
    assert lines[0] == warmup.COMPILING and "python -m hil.sim.warmup" in lines[0]
    assert lines[1].startswith("ripple-hil: simulation engine compiled in ")


def test_a_cached_engine_is_silent():
    warmup.prepare_twin_engine(io.StringIO())          # compiled or loaded now
    assert warmup.engine_cached() is True
    stream = io.StringIO()
    warmup.prepare_twin_engine(stream)
    assert stream.getvalue() == ""


def test_the_simulated_bench_prepares_the_engine_before_serving(monkeypatch):
    from hil.config import default_sim_bench
    from hil.simbench import SimulatedBench

    order = []
    monkeypatch.setattr(warmup, "prepare_twin_engine", lambda: order.append("engine"))
    bench = SimulatedBench(default_sim_bench())
    monkeypatch.setattr(bench, "_start_drive", lambda: order.append("drive") or 1 / 0)
    try:
        bench.start()
    except ZeroDivisionError:
        pass
    assert order == ["engine", "drive"]


def test_hil_run_locates_the_plans_without_importing_them():
    """pytest cannot rewrite the asserts of a plugin's package imported before it starts
    (PytestAssertRewriteWarning on every installed-package run)."""
    code = ("import sys; from hil.commands.run import plan_modules; "
            "assert 'self_check' in plan_modules(); "
            "print('ripple_hil_testplans' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "False"


def test_the_hil_package_declares_itself_not_for_rewriting():
    """`hil run` is inside ``hil``, which is imported before pytest marks it for rewriting."""
    import hil

    assert AssertionRewriter.is_rewrite_disabled(hil.__doc__)
