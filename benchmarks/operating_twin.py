"""The simulated drive the instrument benchmarks read from: enabled, 1000 rpm, 10 A."""

from hil.sim import DriveTwin


def operating_twin() -> DriveTwin:
    """A running twin whose compiled engine is already loaded (outside any timed part)."""
    twin = DriveTwin(seed=0)
    twin.speed_rpm = 1000.0
    twin.current_command_a = 10.0
    twin.enable()
    twin.advance(0.02, 1000.0)
    return twin
