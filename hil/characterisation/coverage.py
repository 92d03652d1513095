"""Identification coverage (issue 29): random simulated drives whose physics
(``[simulation.actual]``) is away from their bench file, characterised through the simulated
instruments exactly as ``hil run`` does (Modbus DAQ quantisation and timing included), each
identified value compared with the simulated truth: covered when |identified − truth| ≤ U (k = 2).

Used by ``studies/characterisation_coverage.py`` (the study) and a reduced test.
"""

from __future__ import annotations

import tempfile

import numpy as np

from hil.characterisation.stage import characterise
from hil.config import default_sim_bench

#: Ranges of the issue's deviation axis (multiples of the bench file's Table I values).
RANGES = {"phase_resistance_ohm": (0.85, 1.45), "phase_inductance_h": (0.7, 1.15),
          "ke_v_s_per_rad": (0.92, 1.04), "current_loop_bandwidth_hz": (0.8, 1.25),
          "bandwidth_hz": (0.7, 1.4)}


def draw_drive(rng) -> dict:
    """One random drive: ``actual`` ([simulation.actual]), ``operating_point``, and the truth of
    each identified parameter at that point (L at the operating current: saturated)."""
    stated = default_sim_bench()
    motor, drive = stated.motor, stated.drive
    scale = {key: float(rng.uniform(*bounds)) for key, bounds in RANGES.items()}
    current_a = float(rng.uniform(10.0, 25.0))
    speed_rpm = float(rng.uniform(300.0, 1000.0))
    inductance = motor.phase_inductance_h * scale["phase_inductance_h"]   # at current_a
    actual = {"phase_resistance_ohm": motor.phase_resistance_ohm * scale["phase_resistance_ohm"],
              "ke_v_s_per_rad": motor.ke_v_s_per_rad * scale["ke_v_s_per_rad"],
              "current_loop_bandwidth_hz": drive.current_loop_bandwidth_hz
              * scale["current_loop_bandwidth_hz"],
              "bandwidth_hz": stated.torque.bandwidth_hz * scale["bandwidth_hz"]}
    if rng.uniform() < 0.5:                   # saturating: L(i) = L0/(1 + (i/i_sat)²)
        i_sat = float(rng.uniform(30.0, 80.0))
        actual |= {"saturation_current_a": i_sat,
                   "phase_inductance_h": inductance * (1.0 + (current_a / i_sat) ** 2)}
    else:
        actual["phase_inductance_h"] = inductance
    truth = {"phase_resistance_ohm": actual["phase_resistance_ohm"],
             "phase_inductance_h": inductance, "ke_v_s_per_rad": actual["ke_v_s_per_rad"],
             "current_loop_gain_pu": scale["current_loop_bandwidth_hz"],
             "bandwidth_hz": actual["bandwidth_hz"]}
    return {"actual": actual, "truth": truth,
            "operating_point": {"speed_rpm": speed_rpm, "current_a": current_a}}


#: Attempts to open a simulated bench (a connect timeout under load is retried, nothing else).
OPEN_ATTEMPTS = 3


def characterise_drive(drive: dict, seed: int = 0):
    """Characterise one drawn drive on a simulated bench; its ``Characterisation``. A bench that
    does not open or an instrument that times out (a loaded machine) is retried afresh, up to
    ``OPEN_ATTEMPTS`` times; nothing else is."""
    from ripple_hil_drivers.errors import InstrumentTimeout

    from hil.bench import Bench, BenchOpenError, SafeStateError
    from hil.record import RunRecord

    config = default_sim_bench().with_overrides({"simulation": {"actual": drive["actual"]},
                                                 "operating_point": drive["operating_point"]})
    for attempt in range(OPEN_ATTEMPTS):
        try:
            bench = Bench.open(config, seed=seed)
            try:
                with tempfile.TemporaryDirectory() as folder:
                    record = RunRecord.create(folder, config, bench.identities())
                    return characterise(bench, record)
            finally:
                bench.close()
        except (BenchOpenError, InstrumentTimeout, SafeStateError):
            if attempt == OPEN_ATTEMPTS - 1:
                raise


def coverage(count: int, seed: int = 0) -> list[dict]:
    """Per drive and identified parameter: truth, value, U, |error|/U."""
    rng = np.random.default_rng(seed)
    rows = []
    for index in range(count):
        drive = draw_drive(rng)
        result = characterise_drive(drive, seed=seed + index)
        for name, truth in drive["truth"].items():
            item = result.get(name)
            if item is None:
                rows.append({"drive": index, "name": name, "truth": truth, "value": None,
                             "U": None, "ratio": float("inf"), **drive["operating_point"],
                             "not_identified": result.not_identified.get(name)})
                continue
            rows.append({"drive": index, "name": name, "truth": truth, "value": item.value,
                         "U": item.expanded, "ratio": abs(item.value - truth) / item.expanded,
                         **drive["operating_point"]})
    return rows


def summary(rows: list[dict]) -> dict:
    """Per parameter: cases, share within U and 3U, worst |error|/U, median U/value."""
    out = {}
    for name in sorted({row["name"] for row in rows}):
        mine = [row for row in rows if row["name"] == name]
        ratios = np.array([row["ratio"] for row in mine])
        out[name] = {"cases": len(mine), "within_U": float(np.mean(ratios <= 1.0)),
                     "worst_ratio": float(ratios.max()),
                     "within_3U": float(np.mean(ratios <= 3.0)),
                     "median_rel_U": float(np.median([row["U"] / row["value"] for row in mine
                                                      if row["value"]] or [np.nan]))}
    return out
