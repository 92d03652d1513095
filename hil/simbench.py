"""The simulated bench: the three simulated instruments around one plant (``hil.plants``: the
``hil.sim.DriveTwin`` by default, or the plant the bench file's ``[simulation] plant`` names).

Used in-process by the pytest plugin (CAN on a private python-can ``virtual`` channel) and as its
own process by ``hil sim-bench`` (CAN served over TCP loopback with python-can-remote, so another
process reaches it with only bench-file settings). Every server binds 127.0.0.1 and stops with
``stop()``; their threads are daemons, so a crashed run never leaves a port open.
"""

from __future__ import annotations

import math
import os
import uuid

from hil.config import BenchConfig
from hil.errors import InputError


#: the twin's PWM frequency before any injection (its loop bandwidth scales with the PWM knob)
TWIN_PWM_HZ = 20_000.0


def twin_config(bench: BenchConfig):
    """The ``hil.sim.DriveConfig`` of the drive a simulated bench file describes: its
    ``[motor]`` nameplate, its ``[drive]`` current loop and its ``[torque]`` transducer
    bandwidth (the twin's defaults otherwise).

    ``current_loop_bandwidth_hz`` is the bandwidth at the twin's default 20 kHz PWM; a stated
    ``current_loop_delay_s`` must equal the twin's (``current_loop_delay_periods`` + 0.5) PWM
    periods, since the plans predict with it: InputError naming both keys otherwise.

    ``[simulation.actual]`` (``hil.actual``) replaces what the file states by the physics the
    twin runs: the motor's R, L (with saturation), Ke and warming winding, the loop's bandwidth
    and delay (its gains still set from the ``[motor]`` nameplate, as a drive configured from
    it) and the transducer's bandwidth.
    """
    from hil.sim import DriveConfig, FirmwareModel, MotorModel, TransducerModel
    from hil.sim.config import LOOP_DESIGNS

    drive = bench.drive
    if drive.current_loop_design not in LOOP_DESIGNS:
        raise InputError(f"{bench.source}: drive.current_loop_design = "
                         f"{drive.current_loop_design!r} is not a loop the ripple-hil twin runs "
                         f"(it runs {', '.join(LOOP_DESIGNS)}); a 2-DOF complex-vector loop runs "
                         f"on [simulation] plant = \"motulator\"")
    loop = {"design": drive.current_loop_design, "decoupling": drive.current_loop_decoupling,
            "emf_feedforward": drive.current_loop_emf_feedforward,
            "delay_periods": drive.current_loop_delay_periods,
            "angle_compensation": drive.current_loop_angle_compensation}
    if drive.current_loop_bandwidth_hz is not None:
        loop["bandwidth_per_pwm"] = drive.current_loop_bandwidth_hz / TWIN_PWM_HZ
    try:
        firmware = FirmwareModel(**loop)
    except ValueError:
        raise InputError(f"{bench.source}: drive.current_loop_bandwidth_hz = "
                         f"{drive.current_loop_bandwidth_hz:g} is outside what the simulated "
                         f"drive runs; allowed {0.005 * TWIN_PWM_HZ:g}..{0.15 * TWIN_PWM_HZ:g} Hz"
                         ) from None
    delay_s = firmware.total_delay_s(TWIN_PWM_HZ)
    if drive.current_loop_delay_s is not None \
            and not math.isclose(drive.current_loop_delay_s, delay_s, rel_tol=1e-6):
        raise InputError(f"{bench.source}: drive.current_loop_delay_s = "
                         f"{drive.current_loop_delay_s:g} s disagrees with "
                         f"current_loop_delay_periods = {drive.current_loop_delay_periods:g}: the "
                         f"simulated drive's loop delay is ({drive.current_loop_delay_periods:g} "
                         f"+ 0.5) / {TWIN_PWM_HZ:g} Hz = {delay_s:g} s")
    transducer = TransducerModel()
    if bench.torque.bandwidth_hz is not None:
        transducer = TransducerModel(bandwidth_hz=bench.torque.bandwidth_hz)
    config = DriveConfig(motor=MotorModel(parameters=bench.motor), firmware=firmware,
                         transducer=transducer)
    if bench.sim_actual:
        from hil.actual import ActualPlant, actual_twin

        config = actual_twin(config, ActualPlant.from_dict(bench.sim_actual), bench.motor)
    return config


#: the addresses a simulated DAQ may be told to serve on (every server here binds loopback)
LOOPBACK_HOSTS = (None, "127.0.0.1", "localhost")


def check_fixed_addresses(config: BenchConfig) -> None:
    """Refuse, in one line, an address the simulated instruments cannot honour (issue 22.8: it
    was silently ignored). A fixed TCP ``daq.port`` is honoured (the DAQ binds 127.0.0.1 on it);
    a non-loopback ``daq.host``, a ``daq.serial_port`` (the pty path is the system's choice),
    a ``drive.channel`` or a ``torque.serial_port`` without the full set of addresses (with all
    of them, ``hil run`` connects to instruments served elsewhere and starts none) are refused;
    so is a ``[simulation.actual] daq_voltage_gain`` on a bench that does not acquire with the
    Modbus DAQ (the simulated scope would silently not apply it).
    """
    daq = config.daq
    where = f"{config.source}: " if getattr(config, "source", None) else ""
    if config.sim_actual.get("daq_voltage_gain") is not None \
            and config.acquisition.kind != "modbus-daq":
        raise InputError(f"{where}simulation.actual.daq_voltage_gain is the Modbus DAQ's voltage "
                         f"channel; this bench acquires with [acquisition] kind = "
                         f"{config.acquisition.kind!r}, which the simulated scope does not skew")
    if daq.transport == "tcp" and daq.host not in LOOPBACK_HOSTS:
        raise InputError(f"{where}daq.host = {daq.host!r}: the simulated DAQ serves only on "
                         f"127.0.0.1; leave daq.host out (daq.port may be fixed)")
    fixed = [(name, value) for name, value in (
        ("daq.serial_port", daq.serial_port if daq.transport == "rtu" else None),
        ("drive.channel", config.drive.channel), ("torque.serial_port", config.torque.serial_port))
        if value]
    if len(fixed) == 3 or (fixed and daq.transport == "tcp" and len(fixed) == 2
                           and daq.port is not None):
        raise InputError(f"{where}names instruments served elsewhere (e.g. written by `hil "
                         f"sim-bench`); simulated instruments are started only from a file "
                         f"without their addresses")
    if fixed:
        name, value = fixed[0]
        raise InputError(f"{where}{name} = {value!r} in a simulated bench file without the "
                         f"other instruments' addresses: the simulated instruments started "
                         f"here choose their own (only daq.port can be fixed); give every "
                         f"address (a bench served by `hil sim-bench`) or none")


class SimulatedBench:
    """Start and stop the simulated drive, DAQ and torque transducer for ``config``.

    ``start()`` returns ``config`` with the instruments' addresses filled in (CAN channel, Modbus
    port, serial pty), ready for ``hil.bench.Bench.open``. ``cross_process=True`` serves CAN over
    TCP loopback (``interface = "remote"``) instead of an in-process virtual channel.
    """

    def __init__(self, config: BenchConfig, *, seed: int = 0, cross_process: bool = False) -> None:
        if not config.simulated:
            raise ValueError("SimulatedBench needs a bench file with simulated = true")
        from hil.plants import make_plant

        check_fixed_addresses(config)
        self.config = config
        self.cross_process = cross_process
        #: the plant behind the instruments (``hil.plants.Plant``; named ``twin`` for the
        #: ripple-hil twin it was first)
        self.twin = self.plant = make_plant(config, seed=seed)
        self._started: list = []
        self.drive = None
        self.daq = None
        self.torque = None

    def start(self) -> BenchConfig:
        from ripple_hil_drivers.simulated.modbus_daq_server import SimulatedDaq
        from ripple_hil_drivers.simulated.transducer_pty import SimulatedTransducer

        if getattr(self.plant, "prepare", None) is not None:
            self.plant.prepare()
        else:
            from hil.sim.warmup import prepare_twin_engine

            prepare_twin_engine()     # compile (if needed) before any instrument is served
        try:
            drive_table = self._start_drive()
            daq_table = self._start_daq(SimulatedDaq)
            self.torque = SimulatedTransducer(self.twin, dialect=self.config.torque.dialect)
            self.torque.start()
            self._started.append(self.torque)
            scope_table = self._start_scope()
        except BaseException:
            self.stop()
            raise
        return self.config.with_overrides({
            "drive": drive_table,
            "daq": daq_table,
            "torque": {"serial_port": self.torque.port},
            **({"acquisition": scope_table} if scope_table else {}),
        })

    def _start_scope(self) -> dict:
        """The simulated oscilloscope on the same twin, when the bench file captures with one
        (``[acquisition] kind = "scpi-scope"``) and names no resource."""
        acquisition = self.config.acquisition
        if acquisition.kind != "scpi-scope" or acquisition.resource:
            return {}
        from ripple_hil_drivers.simulated.scpi_scope_server import SimulatedScope

        self.scope = SimulatedScope(self.twin, channel_map=acquisition.channel_map).start()
        self._started.append(self.scope)
        return {"resource": self.scope.resource}

    def _start_drive(self) -> dict:
        node_id = self.config.drive.node_id
        bitrate = self.config.drive.bitrate
        if self.cross_process:
            from ripple_hil_drivers.simulated.can_remote_server import RemoteSimulatedDrive

            self.drive = RemoteSimulatedDrive(self.twin, node_id, bitrate=bitrate,
                                              identity=self.config.sim_drive_identity,
                                              software_version=self.software_version(),
                                              **self._drive_dictionary()).start()
            self._started.append(self.drive)
            return self.drive.bench_table()
        from ripple_hil_drivers.canopen_transport import CanBusSettings
        from ripple_hil_drivers.simulated.drive_node import SimulatedDrive

        channel = f"ripple-hil-{os.getpid()}-{uuid.uuid4().hex[:8]}"
        settings = CanBusSettings(interface="virtual", channel=channel, bitrate=bitrate)
        self.drive = SimulatedDrive(self.twin, settings, node_id,
                                    identity=self.config.sim_drive_identity,
                                    software_version=self.software_version(),
                                    **self._drive_dictionary()).start()
        self._started.append(self.drive)
        return {"interface": "virtual", "channel": channel}

    def _drive_dictionary(self) -> dict:
        """The EDS and drive profile the bench file names: the simulated drive serves them."""
        return {"eds_path": self.config.drive.eds, "profile": self.config.drive.profile}

    def software_version(self) -> str | None:
        """The simulated drive's 0x100A: the EDS default on the ripple-hil twin; with another
        plant, that default and the plant's identity, so the record's drive identity says
        which plant computed the samples."""
        from hil.plants import DEFAULT_PLANT, plant_identity

        if self.config.sim_plant == DEFAULT_PLANT:
            return None
        return f"ripple-hil-drive 0.1.0; plant: {plant_identity(self.plant)}"

    def _start_daq(self, simulated_daq_class) -> dict:
        daq = self.config.daq
        gain = self.config.sim_actual.get("daq_voltage_gain")
        gains = {"channel_gains": {"vab_v": gain}} if gain is not None else {}
        if daq.transport == "rtu":
            self.daq = simulated_daq_class.rtu(self.twin, unit_id=daq.unit_id, parity=daq.parity,
                                               stopbits=daq.stopbits,
                                               register_map=daq.register_map, **gains)
            self.daq.start()
            self._started.append(self.daq)
            return {"serial_port": self.daq.port, "baudrate": daq.baudrate or 115200}
        self.daq = simulated_daq_class(self.twin, host="127.0.0.1", port=daq.port or 0,
                                       unit_id=daq.unit_id, register_map=daq.register_map,
                                       **gains)
        self.daq.start()
        self._started.append(self.daq)
        host, port = self.daq.address
        return {"host": host, "port": port}

    def stop(self) -> None:
        """Stop every instrument started so far, newest first, then the plant (if it has a
        ``close``); never raises for one that fails."""
        while self._started:
            instrument = self._started.pop()
            try:
                instrument.stop()
            except Exception:  # noqa: BLE001 - stopping the rest matters more
                pass
        close = getattr(self.plant, "close", None)
        if close is not None:
            try:
                close()
            except Exception:  # noqa: BLE001
                pass

    def __enter__(self) -> BenchConfig:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
