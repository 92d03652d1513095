"""The migrations' head read from the files (no alembic import) is alembic's own head."""

from __future__ import annotations

import shutil
import subprocess
import sys

import pytest
from alembic.script import ScriptDirectory

import hil.results.db as db


def test_head_revision_is_alembics_head():
    assert db.head_revision() == ScriptDirectory(str(db.MIGRATIONS)).get_current_head()


def test_a_migration_added_on_top_becomes_the_head(tmp_path, monkeypatch):
    copy = tmp_path / "migrations"
    shutil.copytree(db.MIGRATIONS, copy, ignore=shutil.ignore_patterns("__pycache__"))
    head = db.head_revision()
    (copy / "versions" / "9999_next.py").write_text(
        f'"""next"""\nrevision = "9999"\ndown_revision = "{head}"\n'
        "def upgrade():\n    pass\n")
    monkeypatch.setattr(db, "MIGRATIONS", copy)
    assert db.head_revision() == "9999" == ScriptDirectory(str(copy)).get_current_head()


def test_annotated_assignments_and_editor_files(tmp_path, monkeypatch):
    copy = tmp_path / "migrations"
    shutil.copytree(db.MIGRATIONS, copy, ignore=shutil.ignore_patterns("__pycache__"))
    head = db.head_revision()
    (copy / "versions" / "9999_next.py").write_text(
        f'"""next"""\nrevision: str = "9999"\ndown_revision: str | None = "{head}"\n')
    (copy / "versions" / ".#9999_next.py").symlink_to(tmp_path / "no-such-file")
    monkeypatch.setattr(db, "MIGRATIONS", copy)
    assert db.head_revision() == "9999" == ScriptDirectory(str(copy)).get_current_head()
    (copy / "versions" / "9998_broken.py").write_text('"""no id"""\nrevision = make_id()\n')
    with pytest.raises(ValueError):
        db.head_revision()


def test_two_heads_are_refused(tmp_path, monkeypatch):
    copy = tmp_path / "migrations"
    shutil.copytree(db.MIGRATIONS, copy, ignore=shutil.ignore_patterns("__pycache__"))
    (copy / "versions" / "9998_branch.py").write_text(
        '"""branch"""\nrevision = "9998"\ndown_revision = "0001"\n')
    monkeypatch.setattr(db, "MIGRATIONS", copy)
    with pytest.raises(RuntimeError, match="2 heads"):
        db.head_revision()


def test_indexing_a_database_at_head_does_not_import_alembic(tmp_path):
    url = f"sqlite:///{tmp_path / 'r.db'}"
    code = ("import sys; from hil.results.db import engine_for, dispose_all; "
            f"engine_for({url!r}); dispose_all(); first = 'alembic' in sys.modules; "
            "[sys.modules.pop(m) for m in list(sys.modules) if m.startswith('alembic')]; "
            f"import hil.results.db as d; d._ENGINES.clear(); d.engine_for({url!r}); "
            "print(first, 'alembic' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["True", "False"]   # migrating a new file needs alembic; a file at head does not
