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
