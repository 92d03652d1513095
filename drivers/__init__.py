"""Instrument drivers (CANopen CiA 402 drive, Modbus DAQ, serial torque transducer).

``ripple_hil_drivers.simulated`` holds their protocol-level twins, backed by ``hil.sim.DriveTwin``.
"""

from ripple_hil_drivers.python_can import install as _install_python_can_hook

_install_python_can_hook()
