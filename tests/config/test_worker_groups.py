"""``make test`` runs the suite on pytest-xdist workers grouped by tests/conftest.py: every folder
whose conftest builds a session-scoped fixture must be listed there, or two workers build it."""

import importlib.util
import re
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]


def shared_session_folders() -> tuple[str, ...]:
    """tests/conftest.py's list (loaded by path: every folder has a module named conftest)."""
    spec = importlib.util.spec_from_file_location("tests_top_conftest", TESTS / "conftest.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.SHARED_SESSION_FOLDERS


def test_every_folder_with_session_fixtures_runs_on_one_worker():
    found = {f"tests/{path.parent.relative_to(TESTS).as_posix()}"
             for path in TESTS.rglob("conftest.py")
             if re.search(r"scope\s*=\s*[\"']session[\"']", path.read_text())}
    assert found == set(shared_session_folders())
