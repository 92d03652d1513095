"""The drive twin the DAQ and transducer tests share: the real ``hil.sim.DriveTwin``."""

from __future__ import annotations

from hil.sim import DriveTwin

SPEED_RPM = 1000.0
CURRENT_A = 10.0


def make_twin(seed: int = 0) -> DriveTwin:
    """A twin at the tests' operating point: 1000 rpm on the dyno, 10 A commanded, enabled."""
    twin = DriveTwin(seed=seed)
    with twin.lock:
        twin.speed_rpm = SPEED_RPM
        twin.current_command_a = CURRENT_A
        twin.enable()
    return twin
