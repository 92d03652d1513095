"""``hil analyze`` and ``hil diagnose`` on ASAM MDF4 and NI TDMS files written by asammdf and
npTDMS themselves (issue 31 item 4): channel names and units come from the file, and the figures
equal those of the CSV of the same data."""

import json
import math

import numpy as np
import pytest
from asammdf import MDF, Signal
from nptdms import ChannelObject, GroupObject, TdmsWriter

from hil.cli import main

POLE_PAIRS = 2
RATE_HZ = 20_000.0


def signals(speed_rpm=600.0, revolutions=6):
    """Time, torque (1 N·m, order-2 and order-6 ripple), mechanical angle (wrapped)."""
    time_s = np.arange(int(revolutions * 60.0 / speed_rpm * RATE_HZ)) / RATE_HZ
    mech = 2 * math.pi * speed_rpm / 60.0 * time_s
    elec = POLE_PAIRS * mech
    torque = 1.0 + 0.01 * np.sin(2 * elec + 0.3) + 0.004 * np.cos(6 * elec)
    return time_s, torque, np.mod(mech, 2 * math.pi)


def cli_json(capsys, *argv):
    code = main([*argv, "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    return json.loads(out)


def write_csv(path, time_s, torque, mech, *, si=False):
    """The CSV a scope exports: ms, mN·m, degrees (``si``: s, N·m, rad), named by the
    operator."""
    rows = np.column_stack([time_s, torque, mech] if si else
                           [1e3 * time_s, 1e3 * torque, np.degrees(mech)])
    np.savetxt(path, rows, delimiter=";", header="Zeit;Drehmoment;Winkel", comments="",
               fmt="%.17g")
    return path


def write_mdf4(path, time_s, torque, mech, *, torque_unit="mN·m", groups=1, si=False):
    """An MDF4 file as asammdf writes it: master ``time`` [s], torque in mN·m, angle in °
    (``si``: N·m and rad)."""
    mdf = MDF(version="4.10")
    torque_signal = (Signal(torque, time_s, name="Drehmoment", unit="N·m") if si else
                     Signal(1e3 * torque, time_s, name="Drehmoment", unit=torque_unit))
    angle_signal = (Signal(mech, time_s, name="Winkel", unit="rad") if si else
                    Signal(np.degrees(mech), time_s, name="Winkel", unit="°"))
    if groups == 1:
        mdf.append([torque_signal, angle_signal])
    else:        # the angle recorded in a second raster (its own channel group)
        mdf.append([torque_signal])
        mdf.append([angle_signal])
    mdf.save(str(path), overwrite=True)
    mdf.close()
    return path


def write_tdms(path, time_s, torque, mech, *, time_channel=False, start_offset=True):
    """A TDMS file as npTDMS writes it: waveform channels (wf_increment) with LabVIEW's
    ``unit_string``; names the import finds by themselves (torque, theta_m)."""
    waveform = {"wf_increment": 1.0 / RATE_HZ}
    if start_offset:
        waveform["wf_start_offset"] = 0.0
    channels = [ChannelObject("Messung", "torque", torque, properties={"unit_string": "N·m",
                                                                       **waveform}),
                ChannelObject("Messung", "theta_m", mech, properties={"unit_string": "rad",
                                                                      **waveform})]
    if time_channel:
        channels.append(ChannelObject("Messung", "time_s", time_s,
                                      properties={"unit_string": "s"}))
    with TdmsWriter(str(path)) as writer:
        writer.write_segment([GroupObject("Messung"), *channels])
    return path


def same_figures(a, b):
    for key in ("pk_pk_pu", "mean_torque_nm", "named_amplitude_nm", "rms_ac_nm", "revolutions"):
        assert a[key] == pytest.approx(b[key], rel=1e-9), key


def test_analyze_mdf4_and_tdms_like_the_csv(tmp_path, capsys):
    data = signals()
    csv = cli_json(capsys, "analyze", str(write_csv(tmp_path / "m.csv", *data)),
                   "--time-col", "Zeit", "--time-unit", "ms", "--torque-col", "Drehmoment",
                   "--torque-unit", "mnm", "--angle-col", "Winkel", "--angle-unit", "deg",
                   "--pole-pairs", "2", "--order", "2")
    # MDF4: the units (mN·m, °, s) are the file's; only the names are given
    mdf = cli_json(capsys, "analyze", str(write_mdf4(tmp_path / "m.mf4", *data)),
                   "--time-col", "time", "--torque-col", "Drehmoment", "--angle-col", "Winkel",
                   "--pole-pairs", "2", "--order", "2")
    # TDMS: names found by themselves, time from the waveform's wf_increment
    tdms = cli_json(capsys, "analyze", str(write_tdms(tmp_path / "m.tdms", *data)),
                    "--pole-pairs", "2", "--order", "2")
    same_figures(mdf, csv)
    same_figures(tdms, csv)
    # a waveform without wf_start_offset (0 by NI's definition; npTDMS's time_track raised
    # KeyError and hil analyze crashed with a traceback — review after the merge)
    bare = cli_json(capsys, "analyze", str(write_tdms(tmp_path / "b.tdms", *data,
                                                      start_offset=False)),
                    "--pole-pairs", "2", "--order", "2")
    same_figures(bare, csv)
    assert csv["mean_torque_nm"] == pytest.approx(1.0, rel=1e-3)      # mN·m read as mN·m
    assert csv["named_amplitude_nm"] == pytest.approx(0.01, rel=1e-2)


def test_a_unit_option_that_contradicts_the_file_is_refused(tmp_path, capsys):
    path = write_mdf4(tmp_path / "m.mf4", *signals())
    assert main(["analyze", str(path), "--time-col", "time", "--torque-col", "Drehmoment",
                 "--angle-col", "Winkel", "--torque-unit", "nm", "--pole-pairs", "2"]) == 2
    err = capsys.readouterr().err
    assert "'nm'" in err and "'mN·m'" in err and "Drehmoment" in err


def test_an_unknown_unit_in_the_file_is_named(tmp_path, capsys):
    path = write_mdf4(tmp_path / "m.mf4", *signals(), torque_unit="kN·m·s")
    assert main(["analyze", str(path), "--time-col", "time", "--torque-col", "Drehmoment",
                 "--angle-col", "Winkel", "--pole-pairs", "2"]) == 2
    assert "'kN·m·s'" in capsys.readouterr().err


def test_columns_of_two_channel_groups_are_refused(tmp_path, capsys):
    path = write_mdf4(tmp_path / "m.mf4", *signals(), groups=2)
    assert main(["analyze", str(path), "--time-col", "time", "--torque-col", "Drehmoment",
                 "--angle-col", "Winkel", "--pole-pairs", "2"]) == 2
    assert "different channel groups" in capsys.readouterr().err


def _close(a, b, path="$"):
    """Recursive comparison: floats to 1e-9 relative, everything else equal."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for key in a:
            _close(a[key], b[key], f"{path}.{key}")
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for index, (x, y) in enumerate(zip(a, b)):
            _close(x, y, f"{path}[{index}]")
    elif isinstance(a, float):
        assert a == pytest.approx(b, rel=1e-9, abs=1e-12), path
    else:
        assert a == b, path


def test_diagnose_mdf4_and_tdms_like_the_csv(tmp_path, capsys):
    """The same samples (SI units here: the fit's correlations are sensitive to the last bits
    a ms/mN·m/° round trip changes) diagnose alike from all three files."""
    data = signals()
    folders = {kind: tmp_path / kind for kind in ("csv", "mdf", "tdms")}
    for folder in folders.values():
        folder.mkdir()
    paths = {"csv": write_csv(folders["csv"] / "point.csv", *data, si=True),
             "mdf": write_mdf4(folders["mdf"] / "point.mf4", *data, si=True),
             "tdms": write_tdms(folders["tdms"] / "point.tdms", *data, time_channel=True)}
    manifests = {
        "csv": 'time_column = "Zeit"\ntorque_column = "Drehmoment"\nangle_column = "Winkel"\n',
        "mdf": 'time_column = "time"\ntorque_column = "Drehmoment"\nangle_column = "Winkel"\n',
        "tdms": ""}
    results = {}
    for kind, path in paths.items():
        manifest = folders[kind] / "m.toml"
        manifest.write_text(f'[drive]\npole_pairs = 2\n[[capture]]\nfile = "{path.name}"\n'
                            f'current_a = 20.0\n{manifests[kind]}')
        results[kind] = cli_json(capsys, "diagnose", "--manifest", str(manifest))
    _close(results["mdf"], results["csv"])
    _close(results["tdms"], results["csv"])
