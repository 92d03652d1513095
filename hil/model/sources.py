"""The registry of closed-form sources and ``predict``, the one entry point test plans call."""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import inspect
import threading
from typing import Any, Callable, Iterator

from hil.errors import InputError
from hil.model.core import OperatingPoint, Prediction
from hil.model.dc_offset import predict_dc_offset
from hil.model.dead_time import predict_dead_time
from hil.model.encoder import predict_encoder
from hil.model.gain_mismatch import predict_gain_mismatch
from hil.model.pwm_resolution import predict_pwm_resolution
from hil.model.pwm_switching import predict_pwm_switching
from hil.model.word_length import predict_word_length

#: Source name → prediction function ``f(op, **params) -> Prediction``.
SOURCES: dict[str, Callable[..., Prediction]] = {
    "encoder": predict_encoder,
    "word_length": predict_word_length,
    "dc_offset": predict_dc_offset,
    "gain_mismatch": predict_gain_mismatch,
    "pwm_resolution": predict_pwm_resolution,
    "pwm_switching": predict_pwm_switching,
    "dead_time": predict_dead_time,
}

#: The fault-injection knobs of the contract: passed to ``predict`` they are used by the sources
#: that need them and ignored by the others, so an injection dict can go straight through.
INJECTION_KNOBS = frozenset({
    "ia_offset_a", "ib_offset_a", "ia_gain_error_pu", "ib_gain_error_pu", "encoder_decimation",
    "hall_mode", "word_length_bits", "pwm_period_counts", "pwm_frequency_hz", "dead_time_s",
    "current_angle_rad"})


def source_parameters(source: str) -> list[str]:
    """Keyword parameters a source accepts (besides the operating point)."""
    return [name for name in inspect.signature(SOURCES[source]).parameters if name != "op"]


_memo_lock = threading.Lock()
_memo: dict | None = None
_memo_users = 0


@contextlib.contextmanager
def remembered_predictions() -> Iterator[None]:
    """Within this block :func:`predict` hands back (a deep copy of) the prediction it already
    made for the same source, operating point and parameters instead of computing it again.
    A run's pre-flight, its validity checks and its points ask the same prediction up to three
    times (issue 33: 147 calls, 48 distinct, in the default run); the ``hil run`` plugin holds
    this open for its session. Blocks may overlap in any order (the memory lasts while one is
    open). Outside them nothing is kept, so a test that changes a model's constants between two
    calls sees the change."""
    global _memo, _memo_users
    with _memo_lock:
        _memo_users += 1
        if _memo is None:
            _memo = {}
    try:
        yield
    finally:
        with _memo_lock:
            _memo_users -= 1
            if _memo_users == 0:
                _memo = None


def _memo_key(source: str, op: OperatingPoint, params: dict) -> tuple | None:
    """A hashable key of the call, or None (a parameter that cannot be hashed: not kept)."""
    key = (source, op, tuple(sorted(params.items())))
    try:
        hash(key)
    except TypeError:
        return None
    return key


def predict(source: str, op: OperatingPoint, **params: Any) -> Prediction:
    """Closed-form prediction of ``source`` at ``op``.

    ``params`` use the contract's knob names; knobs another source needs are ignored, other
    unknown names raise InputError. ``current_angle_rad`` among them replaces the one of ``op``.
    """
    memo = _memo
    key = _memo_key(source, op, params) if memo is not None else None
    if key is not None and key in memo:
        return copy.deepcopy(memo[key])
    prediction = _predict(source, op, **params)
    if key is not None:
        memo[key] = copy.deepcopy(prediction)
    return prediction


def _predict(source: str, op: OperatingPoint, **params: Any) -> Prediction:
    if source not in SOURCES:
        raise InputError(f"unknown source {source!r} (allowed: {', '.join(SOURCES)})")
    if not isinstance(op, OperatingPoint):
        raise InputError(f"op must be an OperatingPoint, got {type(op).__name__}")
    if "current_angle_rad" in params:
        op = dataclasses.replace(op, current_angle_rad=params.pop("current_angle_rad"))
    accepted = source_parameters(source)
    unknown = sorted(set(params) - set(accepted) - INJECTION_KNOBS)
    if unknown:
        raise InputError(f"{source}: unknown parameter(s) {', '.join(unknown)} "
                         f"(allowed: {', '.join(accepted)})")
    signature = inspect.signature(SOURCES[source]).parameters
    missing = [name for name in accepted if signature[name].default is inspect.Parameter.empty
               and name not in params]
    if missing:
        raise InputError(f"{source}: missing parameter(s) {', '.join(missing)} "
                         f"(allowed: {', '.join(accepted)})")
    return SOURCES[source](op, **{k: v for k, v in params.items() if k in accepted})
