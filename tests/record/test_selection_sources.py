"""The record's selection lists the sources of the selected tests; a test without a
``ripple_source`` marker (a lab's own check, ``hil run -- extra_test.py``) has none and must not
break it (sorting None with the names raised TypeError and lost the run's selection)."""

from types import SimpleNamespace

from ripple_hil_fixtures.session import Selection


def item(source=None):
    marker = SimpleNamespace(args=(source,)) if source else None
    return SimpleNamespace(get_closest_marker=lambda name: marker)


def test_tests_without_a_source_do_not_break_the_selection():
    selection = Selection(collected=3, items=[item("encoder"), item(), item("baseline")])
    assert selection.to_dict()["sources"] == ["baseline", "encoder"]
