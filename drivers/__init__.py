"""Instrument drivers (CANopen CiA 402 drive, Modbus DAQ, serial torque transducer).

``ripple_hil_drivers.simulated`` holds their protocol-level twins, backed by ``hil.sim.DriveTwin``.
"""
