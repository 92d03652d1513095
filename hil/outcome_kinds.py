"""Words shared by the plans, the record and every sink for tests that give no verdict (design.md §9).

- A point outside its plan's declared validity region, or a check whose result cannot be judged
  (e.g. its interval is wider than its tolerance and still overlaps it), is **not determinable
  here**: never a pass, never a fail. A plan says so with ``pytest.skip(not_determinable(reason))``;
  the record keeps the outcome ``NOT_DETERMINABLE`` with the reason, and the source's statement is
  NOT DETERMINED.
- A test that measures and records but judges nothing (diagnosis points, ripple-map points,
  references) is **measured, no verdict**: outcome ``MEASURED``, never counted as a pass.
"""

from __future__ import annotations

#: Record outcome of a point refused by its plan's validity region or a check not resolved.
NOT_DETERMINABLE = "not determinable"
#: Record outcome of a test that measured and judged nothing.
MEASURED = "measured, no verdict"
#: How a skip message marks a not-determinable point (the reason follows).
NOT_DETERMINABLE_PREFIX = "not determinable here: "


def not_determinable(reason: str) -> str:
    """The skip message of a point that cannot be judged here, with its reason."""
    return f"{NOT_DETERMINABLE_PREFIX}{reason}"


def is_not_determinable(message: str | None) -> bool:
    """True when a skip message marks a not-determinable point."""
    return bool(message) and message.startswith(NOT_DETERMINABLE_PREFIX)
