"""The plugin's options are all named ``--hil-*``: an unrelated project whose conftest adds its
own ``--bench`` or ``--requirements`` option runs beside the installed plugin."""

import subprocess
import sys
import textwrap


def test_an_unrelated_conftest_may_define_bench_and_requirements_options(tmp_path):
    (tmp_path / "conftest.py").write_text(textwrap.dedent('''
        def pytest_addoption(parser):
            parser.addoption("--bench", default="mine")
            parser.addoption("--requirements", default="theirs")
    '''))
    (tmp_path / "test_x.py").write_text(textwrap.dedent('''
        def test_x(request):
            assert request.config.getoption("--bench") == "mine"
    '''))
    done = subprocess.run([sys.executable, "-m", "pytest", "test_x.py", "-q",
                           "-p", "no:cacheprovider"], capture_output=True, text=True,
                          timeout=120, cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert not (tmp_path / "records").exists()


def test_no_generic_top_level_package_is_installed(tmp_path):
    """drivers/, fixtures/, testplans/ and reports/ install as ripple_hil_drivers,
    ripple_hil_fixtures, ripple_hil_testplans and ripple_hil_reports: outside the source tree
    the generic names are not importable."""
    import importlib.metadata

    (plugin,) = [ep for ep in importlib.metadata.entry_points(group="pytest11")
                 if ep.name == "ripple_hil"]
    assert plugin.value == "ripple_hil_fixtures.plugin"
    code = ("import importlib.util as u; "
            "print([n for n in ('drivers', 'fixtures', 'testplans', 'reports') if u.find_spec(n)], "
            "[n for n in ('ripple_hil_drivers', 'ripple_hil_fixtures', 'ripple_hil_testplans', "
            "'ripple_hil_reports') if u.find_spec(n)])")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=60, cwd=tmp_path)
    assert done.stdout.strip() == ("[] ['ripple_hil_drivers', 'ripple_hil_fixtures', "
                                   "'ripple_hil_testplans', 'ripple_hil_reports']"), \
        done.stdout + done.stderr
