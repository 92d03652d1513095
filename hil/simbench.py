"""The simulated bench: the three simulated instruments around one ``hil.sim.DriveTwin``.

Used in-process by the pytest plugin (CAN on a private python-can ``virtual`` channel) and as its
own process by ``hil sim-bench`` (CAN served over TCP loopback with python-can-remote, so another
process reaches it with only bench-file settings). Every server binds 127.0.0.1 and stops with
``stop()``; their threads are daemons, so a crashed run never leaves a port open.
"""

from __future__ import annotations

import os
import uuid

from hil.config import BenchConfig


def twin_config(bench: BenchConfig):
    """The ``hil.sim.DriveConfig`` of the drive a simulated bench file describes: its
    ``[motor]`` nameplate (the twin's defaults otherwise)."""
    from hil.sim import DriveConfig, MotorModel

    return DriveConfig(motor=MotorModel(parameters=bench.motor))


class SimulatedBench:
    """Start and stop the simulated drive, DAQ and torque transducer for ``config``.

    ``start()`` returns ``config`` with the instruments' addresses filled in (CAN channel, Modbus
    port, serial pty), ready for ``hil.bench.Bench.open``. ``cross_process=True`` serves CAN over
    TCP loopback (``interface = "remote"``) instead of an in-process virtual channel.
    """

    def __init__(self, config: BenchConfig, *, seed: int = 0, cross_process: bool = False) -> None:
        if not config.simulated:
            raise ValueError("SimulatedBench needs a bench file with simulated = true")
        from hil.sim import DriveTwin
        from hil.sim.defects import DriveDefects

        self.config = config
        self.cross_process = cross_process
        self.twin = DriveTwin(twin_config(config), seed=seed,
                              defects=DriveDefects.from_dict(config.sim_defects))
        self._started: list = []
        self.drive = None
        self.daq = None
        self.torque = None

    def start(self) -> BenchConfig:
        from drivers.simulated.modbus_daq_server import SimulatedDaq
        from drivers.simulated.transducer_pty import SimulatedTransducer

        try:
            drive_table = self._start_drive()
            daq_table = self._start_daq(SimulatedDaq)
            self.torque = SimulatedTransducer(self.twin, dialect=self.config.torque.dialect)
            self.torque.start()
            self._started.append(self.torque)
        except BaseException:
            self.stop()
            raise
        return self.config.with_overrides({
            "drive": drive_table,
            "daq": daq_table,
            "torque": {"serial_port": self.torque.port},
        })

    def _start_drive(self) -> dict:
        node_id = self.config.drive.node_id
        bitrate = self.config.drive.bitrate
        if self.cross_process:
            from drivers.simulated.can_remote_server import RemoteSimulatedDrive

            self.drive = RemoteSimulatedDrive(self.twin, node_id, bitrate=bitrate).start()
            self._started.append(self.drive)
            return self.drive.bench_table()
        from drivers.canopen_transport import CanBusSettings
        from drivers.simulated.drive_node import SimulatedDrive

        channel = f"ripple-hil-{os.getpid()}-{uuid.uuid4().hex[:8]}"
        settings = CanBusSettings(interface="virtual", channel=channel, bitrate=bitrate)
        self.drive = SimulatedDrive(self.twin, settings, node_id).start()
        self._started.append(self.drive)
        return {"interface": "virtual", "channel": channel}

    def _start_daq(self, simulated_daq_class) -> dict:
        daq = self.config.daq
        if daq.transport == "rtu":
            self.daq = simulated_daq_class.rtu(self.twin, unit_id=daq.unit_id)
            self.daq.start()
            self._started.append(self.daq)
            return {"serial_port": self.daq.port, "baudrate": daq.baudrate or 115200}
        self.daq = simulated_daq_class(self.twin, host="127.0.0.1", port=0, unit_id=daq.unit_id)
        self.daq.start()
        self._started.append(self.daq)
        host, port = self.daq.address
        return {"host": host, "port": port}

    def stop(self) -> None:
        """Stop every instrument started so far, newest first; never raises for one that fails."""
        while self._started:
            instrument = self._started.pop()
            try:
                instrument.stop()
            except Exception:  # noqa: BLE001 - stopping the rest matters more
                pass

    def __enter__(self) -> BenchConfig:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
