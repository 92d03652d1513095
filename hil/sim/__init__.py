"""Time-domain digital twin of the drive under test: PMSM, PWM inverter with dead time,
fixed-point FOC firmware, sensors, dyno and torque transducer (see design.md, section 5).

Each controller limitation of the paper produces its torque ripple here from physics and
firmware, never from the paper's closed forms (this package must not import ``hil.model``).
"""

from hil.sim.config import (DriveConfig, DynoModel, FirmwareModel, InverterModel, MotorModel,
                            SensorModel, TransducerModel)
from hil.sim.defects import DriveDefects
from hil.sim.engine import simulate, simulate_batch
from hil.sim.injection import Injection, KnobRange
from hil.sim.results import STANDARD_CHANNELS, SimResult
from hil.sim.twin import DriveTwin

__all__ = ["DriveConfig", "DriveDefects", "DriveTwin", "DynoModel", "FirmwareModel", "Injection",
           "InverterModel", "KnobRange", "MotorModel", "STANDARD_CHANNELS", "SensorModel",
           "SimResult", "TransducerModel", "simulate", "simulate_batch"]
