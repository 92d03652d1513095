"""The user's own twin (design.md §11): a simulated bench file of *this* drive, as measured.

The twin states what the bench file states — the ``[motor]`` nameplate and the documented
``[drive]`` loop the drive was configured from — and runs, in ``[simulation.actual]``
(``hil.actual``), the physics the characterisation measured: R, L, Ke, the loop bandwidth and
the transducer's bandwidth of the bench as measured (``Characterisation.measured_config``: the measured value where it
disagrees with the file beyond U, the stated one where the measurement confirms it). That is
the bench's own shape (what the user believes, plus the physics), so:

- the twin's firmware sets its PI gains from the same nameplate as the drive did
  (``hil.actual.actual_twin``: ``tuning`` = the stated motor), at the measured bandwidth;
- its plans predict, normalise (per unit of the nameplate torque) and check validity from the
  same stated file, and its own characterisation stage finds the same bench as measured, so its
  run is like for like with the bench's under ``hil compare``.

Writing the measured motor into ``[motor]`` instead (the first twin) made the firmware tune its
gains on the measured R, L — another drive than the one on the bench — and moved every
per-unit base with the measured Ke.

Not carried over (the twin runs them as stated, and its header says so): what the
characterisation does not identify (the loop delay, the saturation curve L(|i|) away from the operating point's current, the winding's warming), the bench's own
``[simulation]`` table (its hidden physics and defects: the twin knows only what was measured)
and the instruments' addresses.
"""

from __future__ import annotations

from hil.characterisation.result import MOTOR_KEYS, Characterisation

#: What the twin runs as stated because the characterisation does not identify it.
NOT_CARRIED_OVER = (
    "current_loop_delay_s (the documented delay is held by the loop fit)",
    "the saturation curve L(|i|): the twin's L is the one measured at the operating point's "
    "current, at every current",
    "the winding's warming: the twin's R is the one measured by the characterisation",
    "the acquiring instrument's gain error: the twin's channels read true (the measured values "
    "carry that gain; their U covers it where the instrument's accuracy class is stated)")

#: Bench-file keys of the tables the simulated instruments choose themselves.
_ADDRESS_KEYS = ("channel", "host", "port", "serial_port", "interface")


def twin_physics(stated, result: Characterisation) -> dict:
    """``[simulation.actual]`` of the twin: the bench as measured where it differs from
    ``stated`` (a ``hil.config.BenchConfig``), in ``hil.actual``'s key names and units."""
    measured = result.measured_config(stated)
    physics = {name: getattr(measured.motor, name) for name in MOTOR_KEYS
               if getattr(measured.motor, name) != getattr(stated.motor, name)}
    bandwidth_hz = measured.drive.current_loop_bandwidth_hz
    if bandwidth_hz != stated.drive.current_loop_bandwidth_hz:
        physics["current_loop_bandwidth_hz"] = bandwidth_hz
    if measured.torque.bandwidth_hz != stated.torque.bandwidth_hz:
        physics["bandwidth_hz"] = measured.torque.bandwidth_hz
    return physics


def twin_table(stated, result: Characterisation) -> dict:
    """The twin bench file as a TOML table: ``stated`` as loaded, ``simulated = true``, no
    addresses, no ``[simulation]`` of its own but the measured physics (:func:`twin_physics`)."""
    table = stated.to_dict()
    table["simulated"] = True
    table.pop("simulation", None)
    for section in ("drive", "daq", "torque"):
        for key in _ADDRESS_KEYS:
            table[section].pop(key, None)
    physics = twin_physics(stated, result)
    if physics:
        table["simulation"] = {"actual": physics}
    return table


def twin_text(stated, result: Characterisation) -> str:
    """TOML of the twin (:func:`twin_table`) with a header: per measured parameter its value,
    U (k = 2), the stated value and which of the two the twin runs; what it runs as stated."""
    from hil.commands.sim_bench import bench_file_text

    physics = twin_physics(stated, result)
    rows = result.to_dict(stated)["stated_vs_measured"]
    header = ["# Written by `hil characterize --write-twin`: a simulated bench of the drive",
              f"# characterised on {stated.source}. [motor] and [drive] are that file's (the",
              "# nameplate and documented loop the drive was configured from: the twin's firmware",
              "# sets its gains from them, as the drive did); [simulation.actual] is the physics",
              "# as measured (U at k = 2):"]
    header += [f"#   {row['name']} = {row['measured']:.6g} ± {row['U_k2']:.2g} {row['unit']} "
               f"(stated {row['stated']:.6g}): the twin runs "
               + ("the measured value" if row["name"] in physics
                  else "the stated value (the measurement confirms it)") for row in rows]
    header += [f"#   not identified: {key}: {why}" for key, why in result.not_identified.items()]
    header += ["# run as stated (not carried over):"]
    header += [f"#   {item}" for item in NOT_CARRIED_OVER]
    return bench_file_text(twin_table(stated, result), header="\n".join(header) + "\n")
