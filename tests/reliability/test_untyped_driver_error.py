"""An untyped transport error is attributed to the driver whose frame raised it, wherever the
drivers live: ``drivers/`` in the source tree, ``ripple_hil_drivers/`` once installed."""

from __future__ import annotations

import pytest

from ripple_hil_fixtures.session import _instrument_in_traceback


def _raised_in(filename: str) -> BaseException:
    """A ConnectionError whose innermost traceback frame is in ``filename``."""
    code = compile("def read():\n    raise ConnectionError('peer reset')\n", filename, "exec")
    namespace: dict = {}
    exec(code, namespace)                     # noqa: S102 - a frame with a chosen file name
    try:
        namespace["read"]()
    except ConnectionError as exc:
        return exc
    raise AssertionError("not raised")


@pytest.mark.parametrize("folder", ["/work/tree/drivers",
                                    "/venv/lib/python3.11/site-packages/ripple_hil_drivers"])
@pytest.mark.parametrize("module, instrument", [("modbus_daq.py", "daq"),
                                                ("cia402.py", "drive"),
                                                ("canopen_transport.py", "drive"),
                                                ("torque_transducer.py", "torque")])
def test_untyped_error_names_the_driver_in_either_layout(folder, module, instrument):
    assert _instrument_in_traceback(_raised_in(f"{folder}/{module}")) == instrument


def test_a_frame_of_no_driver_names_nothing():
    assert _instrument_in_traceback(_raised_in("/venv/lib/python3.11/site-packages/"
                                               "ripple_hil_fixtures/session.py")) is None
