"""``hil diagnose CAPTURE…``: which controller faults cause the measured ripple (issue 15).

Each capture's operating point is what is stated for it (``FILE@CURRENT_A[,ANGLE_DEG]`` or a
``--manifest`` entry, hil.diagnosis.manifest), else the run record it sits in
(``<record>/captures/``), else its meta (simulated captures), else ``--current-a``; the speed is
measured from the capture. Foreign files (CSV, ``.npz`` of arrays, MDF4, TDMS) are imported
with :mod:`hil.capture_import`. The drive's current loop, the transducer's bandwidth and accuracy
class come from the record's bench as its run characterised it (or ``--bench FILE``; captures of
runs whose characterised benches differ are refused), then the manifest's [drive]/[motor], then
the options. Each capture's angle reference (hil/diagnosis/README.md) is stated
(``--emf-a-zero-elec-deg``, the manifest), recorded (the capture's meta), measured from its phase
currents, or unknown (no signed calibration then).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from hil.diagnosis.manifest import ADDITION_KEYS
from hil.errors import InputError


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "diagnose", help="attribute the measured ripple to its sources (offsets, gains, dead "
                         "time, encoder, motor) and suggest the calibration",
        description="Fit the forward models of every ripple source to the captures' order "
                    "spectra; print the attribution table, the calibration and what the captures "
                    "cannot separate.")
    parser.add_argument("captures", nargs="*", metavar="CAPTURE[@CURRENT_A[,ANGLE_DEG]]",
                        help="capture files of the same drive (one or more operating points); "
                             "FILE@20 or FILE@20,15 states a capture's peak phase current (A) "
                             "and current angle (degrees)")
    parser.add_argument("--manifest", metavar="FILE.toml",
                        help="captures with their operating points, the drive and the motor "
                             "(hil/diagnosis/manifest.py)")
    parser.add_argument("--emf-a-zero-elec-deg", type=float, default=None, metavar="DEG",
                        help="the captures' angle reference: their electrical angle (degrees) "
                             "at which phase a's back EMF crosses zero going positive")
    parser.add_argument("--pole-pairs", type=int, default=None, metavar="P",
                        help="pole pairs of imported captures (default: the manifest, else the "
                             "bench's motor)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--bench", metavar="FILE", help="bench file (default: the record's bench)")
    parser.add_argument("--current-a", type=float, default=None, metavar="A",
                        help="peak phase current of captures whose operating point is not "
                             "recorded")
    parser.add_argument("--current-angle-deg", type=float, default=None, metavar="DEG",
                        help="current angle φ of such captures (default 0)")
    parser.add_argument("--loop-bandwidth-hz", type=float, default=None, metavar="HZ",
                        help="current-loop bandwidth (overrides the bench)")
    parser.add_argument("--loop-delay-s", type=float, default=None, metavar="S",
                        help="current-loop delay (overrides the bench)")
    parser.add_argument("--transducer-bandwidth-hz", type=float, default=None, metavar="HZ",
                        help="torque transducer's first-order bandwidth (overrides the bench)")
    parser.add_argument("--pwm-frequency-hz", type=float, default=None, metavar="HZ",
                        help="PWM frequency (default 20000)")
    parser.add_argument("--current-channel-u-a", type=float, default=None, metavar="A",
                        help="standard uncertainty of the DAQ current channels' dc; when given, "
                             "the captures' phase-current dc is fitted too (separates a sensor "
                             "offset from a torque fixed in the rotor angle)")
    parser.add_argument("--dead-time-bound-s", type=float, default=None, metavar="S",
                        help="upper bound of the inverter's effective dead time (drive data); "
                             "with a coarse encoder it sizes the offsets' dwell term (default: "
                             "the fitted nuisance dead time × 3, which reads low)")
    parser.add_argument("--max-mech-order", type=int, default=128, metavar="M",
                        help="highest mechanical order analysed (default 128)")
    parser.set_defaults(func=run)


def _bench_dict(args, records: list[dict | None]) -> dict:
    """The bench the captures were taken on: ``--bench FILE``, else the record's bench *as
    characterised* (:func:`as_characterised`), else the default simulated bench's motor."""
    if args.bench:
        from hil.config import load_bench

        return load_bench(args.bench).to_dict()
    benches = [as_characterised(record["bench"]["loaded"], record.get("characterisation"))
               for record in records if record and isinstance(record.get("bench"), dict)
               and record["bench"].get("loaded")]
    if benches:
        if any(bench != benches[0] for bench in benches[1:]):
            raise InputError("the captures come from runs whose benches, as characterised, "
                             "differ (motor, loop or transducer): diagnose one run's captures, "
                             "or state the bench with --bench FILE")
        return benches[0]
    from hil.config import default_sim_bench

    return {"motor": default_sim_bench().to_dict()["motor"]}


#: The characterisation's parameters (``stated_vs_measured`` names) and where each sits in a bench
#: dict: the same values the run's plans read (``Characterisation.measured_config``).
CHARACTERISED_KEYS = {"ke_v_s_per_rad": "motor", "phase_resistance_ohm": "motor",
                      "phase_inductance_h": "motor", "current_loop_bandwidth_hz": "drive",
                      "bandwidth_hz": "torque"}


def as_characterised(bench: dict, characterisation) -> dict:
    """``bench`` (a record's ``bench.loaded``, the file as stated) with the values its run's
    characterisation stage gave the plans (``predictions_use`` "measured"), and the stated
    motor the drive's PI gains came from as ``loop_tuning`` where the motor changed: a diagnosis
    of that run's captures then models the bench the plans judged, not its nameplate."""
    rows = (characterisation or {}).get("stated_vs_measured") or []
    used = {row["name"]: row["measured"] for row in rows
            if row.get("predictions_use") == "measured" and row.get("name") in CHARACTERISED_KEYS}
    if not used:
        return bench
    bench = {**bench, **{table: dict(bench.get(table) or {})
                         for table in set(CHARACTERISED_KEYS.values())}}
    if any(CHARACTERISED_KEYS[name] == "motor" for name in used):
        bench["loop_tuning"] = dict(bench["motor"])
    for name, value in used.items():
        bench[CHARACTERISED_KEYS[name]][name] = value
    return bench


def run(args) -> int:
    from hil.diagnosis import diagnose, spectra_from_captures
    from hil.diagnosis.bench_setup import check_setup_known, setup_from_bench_dict

    if not 8 <= args.max_mech_order <= 4096:
        raise InputError(f"--max-mech-order {args.max_mech_order} must be in 8..4096")
    entries, manifest = _entries(args)
    loaded = [_load(entry, args, manifest) for entry in entries]
    records = [record for _, record, _ in loaded]
    bench = _with_manifest(_bench_dict(args, records), manifest)
    setup_keys, unused = _setup_keys(bench, manifest)
    options = {"current_loop_bandwidth_hz": args.loop_bandwidth_hz,
               "current_loop_delay_s": args.loop_delay_s,
               "transducer_bandwidth_hz": args.transducer_bandwidth_hz,
               "pwm_frequency_hz": args.pwm_frequency_hz,
               "current_channel_u_a": args.current_channel_u_a,
               "dead_time_bound_s": args.dead_time_bound_s}
    setup_keys.update({k: v for k, v in options.items() if v is not None})  # options win
    setup, class_pct = setup_from_bench_dict(bench, **setup_keys)
    pairs = []
    for (capture, record, op), entry in zip(loaded, entries):
        _set_angle_reference(capture, op, args, manifest, setup)
        pairs.append((capture, op))
    _check_one_drive_state([str(e.path) for e in entries], pairs)
    spectra = spectra_from_captures(pairs, max_mech_order=args.max_mech_order)
    if any(op.get(key) for _, op in pairs for key in ADDITION_KEYS):
        try:
            from hil.diagnosis import additions
        except ImportError:
            raise InputError("captures with known additions (addition_* keys) need "
                             "hil.diagnosis.additions, which this build does not have") from None
        base = [s for s, (_, op) in zip(spectra, pairs)
                if not any(op.get(key) for key in ADDITION_KEYS)]
        spectra = [additions.with_addition(s, op) for s, (_, op) in zip(spectra, pairs)]
        result = additions.diagnose_by_additions(spectra, setup=setup)
        # the forward-model fit of the base captures beside it: it states what the additions
        # could not (e.g. a dead time whose two additions were not linear), and the two routes
        # are compared where both state a parameter (as the diagnosis plan does)
        fit = diagnose(base, setup=setup, transducer_class_pct=class_pct) if base else None
    else:
        result = diagnose(spectra, setup=setup, transducer_class_pct=class_pct)
        fit = None
    result.notes.extend(check_setup_known(setup))
    result.notes.extend(unused)
    if args.json:
        out = result.to_dict()
        if fit is not None:
            out["fit"] = fit.to_dict()
            out["versus_fit"] = additions.compare_with_fit(result, fit)
        json.dump(out, sys.stdout, indent=1, allow_nan=False)
        print()
    else:
        text = result.table()
        print(text)
        for note in result.notes:
            if note not in text:            # (the additions path's table lists its own notes)
                print(f"note: {note}")
        if fit is not None:
            print("\nforward-model fit of the base captures (no additions):")
            print(fit.table())
            for row in additions.compare_with_fit(result, fit):
                print(f"additions vs fit: {row['statement']}")
    return 0


def _entries(args):
    from hil.diagnosis.manifest import check_distinct, load_manifest, parse_capture_argument

    manifest = load_manifest(args.manifest) if args.manifest else None
    entries = list(manifest.captures) if manifest else []
    entries += [parse_capture_argument(name) for name in args.captures]
    if not entries:
        raise InputError("no captures: give capture files (FILE or FILE@CURRENT_A[,ANGLE_DEG]) "
                         "or --manifest FILE.toml")
    check_distinct(entries)
    return entries, manifest


def _pole_pairs(args, manifest) -> int | None:
    if args.pole_pairs is not None:
        return args.pole_pairs
    if manifest and manifest.pole_pairs:
        return manifest.pole_pairs
    if args.bench:
        from hil.config import load_bench

        return load_bench(args.bench).motor.pole_pairs
    return None


def _load(entry, args, manifest):
    """(capture, record, operating point) of one entry; errors name what is missing."""
    from hil.capture import Capture
    from hil.capture_import import check_torque, import_with_defaults, is_ripple_hil_capture
    from hil.diagnosis.bench_setup import find_record, operating_point_of

    path, name = entry.path, str(entry.path)
    if is_ripple_hil_capture(path):
        capture = Capture.load(path)
        record = find_record(path)
        op = operating_point_of(path, capture, record)
    elif not path.is_file():
        raise InputError(f"capture file {name!r} " + ("is a directory, not a capture"
                                                       if path.is_dir() else "does not exist"))
    else:
        pole_pairs = _pole_pairs(args, manifest)
        if pole_pairs is None:
            raise InputError(f"{name}: an imported capture needs the motor's pole pairs: "
                             "--pole-pairs P, a manifest's [drive] pole_pairs, or --bench FILE")
        capture = import_with_defaults(path, pole_pairs=pole_pairs, **entry.import_options)
        if manifest and manifest.drive.get("encoder_counts_per_rev"):
            capture.meta["encoder_counts_per_rev"] = manifest.drive["encoder_counts_per_rev"]
        record, op = None, {"label": path.stem}
    check_torque(capture, name)
    if not any(c in capture for c in ("rotor_angle_mech_rad", "encoder_counts", "speed_rpm")):
        raise InputError(f"{name}: no rotor-angle channel (channels: "
                         f"{', '.join(sorted(capture.channels))}); the diagnosis refers the "
                         "torque's phase to the rotor angle")
    op = {**op, **entry.operating_point}      # what is stated for the capture wins
    op.setdefault("label", path.stem)
    if "current_a" not in op:
        if args.current_a is None:
            raise InputError(_no_operating_point(name, path, capture))
        op["current_a"] = args.current_a
    if args.current_angle_deg is not None and "current_angle_rad" not in entry.operating_point:
        op["current_angle_rad"] = math.radians(args.current_angle_deg)
    op.pop("speed_rpm", None)      # measured from the capture itself (signed)
    return capture, record, op


def _no_operating_point(name: str, path: Path, capture) -> str:
    how = (f"state it: {name}@CURRENT_A[,ANGLE_DEG] (peak phase current in A, current angle in "
           "electrical degrees), a --manifest entry (current_a = ...), or --current-a for all "
           "such captures")
    if "imported" in capture.meta:
        return f"{name}: an imported capture carries no operating point; {how}"
    if capture.meta.get("test_id") or capture.meta.get("source"):
        return (f"{name}: a ripple-hil capture copied out of its record (no record.json in "
                f"{str(path.resolve().parent.parent)!r}, where <record>/captures/ would have "
                f"one), so its operating point (peak phase current) is not known; keep it in "
                f"its record folder or {how}")
    return f"{name}: no record.json beside it and no operating point in its meta; {how}"


def _with_manifest(bench: dict, manifest) -> dict:
    """The bench dict with the manifest's [motor] keys and [drive] loop keys over it."""
    if manifest is None:
        return bench
    bench = {**bench, "motor": dict(bench.get("motor") or {}),
             "drive": dict(bench.get("drive") or {})}
    bench["motor"].update(manifest.motor)
    if manifest.drive.get("pole_pairs"):
        bench["motor"]["pole_count"] = 2 * manifest.drive["pole_pairs"]
    for key in ("current_loop_bandwidth_hz", "current_loop_delay_s"):
        if key in manifest.drive:
            bench["drive"][key] = manifest.drive[key]
    if "transducer_bandwidth_hz" in manifest.drive:
        bench["torque"] = {**(bench.get("torque") or {}),
                           "bandwidth_hz": manifest.drive["transducer_bandwidth_hz"]}
    return bench


#: DriveSetup fields named like the bench file's [drive] loop keys (issue 23 item 2), passed
#: through when this version's DriveSetup has them.
LOOP_DESIGN_KEYS = ("current_loop_design", "current_loop_decoupling",
                    "current_loop_emf_feedforward", "current_loop_angle_compensation",
                    "current_loop_delay_periods")
SETUP_DRIVE_KEYS = ("pwm_frequency_hz", "dead_time_bound_s", "current_channel_u_a")


def _setup_keys(bench: dict, manifest) -> tuple[dict, list[str]]:
    """DriveSetup keyword arguments from the bench's [drive] and the manifest's [drive], and a
    note for each stated key this version's DriveSetup has no field for."""
    from dataclasses import fields

    from hil.diagnosis.signatures import DriveSetup

    have = {f.name for f in fields(DriveSetup)}
    stated = {k: v for k, v in (bench.get("drive") or {}).items() if k in LOOP_DESIGN_KEYS}
    if manifest:
        stated.update({k: v for k, v in manifest.drive.items()
                       if k in LOOP_DESIGN_KEYS + SETUP_DRIVE_KEYS})
    keys = {k: v for k, v in stated.items() if k in have}
    notes = [f"{k} = {v!r} stated but not used: this version's fit has no such loop option"
             for k, v in stated.items() if k not in have and v not in (False, None)
             and not (k == "current_loop_design" and v == "continuous")
             and not (k == "current_loop_delay_periods")]
    return keys, notes


def _set_angle_reference(capture, op, args, manifest, setup) -> None:
    """Write the capture's angle reference (stated > recorded > measured > unknown) into its meta,
    where hil.diagnosis.orders reads it."""
    from hil.diagnosis import angle_reference as ref

    stated = None
    if "emf_a_rising_zero_elec_deg" in op:
        stated = ref.AngleReference(op.pop("emf_a_rising_zero_elec_deg"),
                                    _stated_u(manifest), "stated in the manifest's capture entry")
    elif args.emf_a_zero_elec_deg is not None:
        stated = ref.AngleReference(args.emf_a_zero_elec_deg, 0.0,
                                    "stated with --emf-a-zero-elec-deg")
    elif manifest and manifest.emf_a_rising_zero_elec_deg is not None:
        stated = ref.AngleReference(manifest.emf_a_rising_zero_elec_deg, _stated_u(manifest),
                                    "stated in the manifest's [drive]")
    pole_pairs = capture.meta.get("pole_pairs") or setup.motor.pole_pairs
    reference = ref.resolve(capture, stated=stated, pole_pairs=int(pole_pairs),
                            current_angle_rad=op.get("current_angle_rad", 0.0))
    capture.meta.update(reference.to_meta())


def _stated_u(manifest) -> float:
    return float(manifest.drive.get("emf_a_rising_zero_u_elec_deg", 0.0)) if manifest else 0.0


#: The drive injection knob each known addition is made through (shared23.md).
ADDITION_KNOBS = {"addition_ia_offset_a": "ia_offset_a", "addition_ib_offset_a": "ib_offset_a",
                  "addition_gain_a_pu": "ia_gain_error_pu", "addition_dead_time_s": "dead_time_s"}


def _check_one_drive_state(names, pairs) -> None:
    """A diagnosis is of one drive as it is: captures recorded with different injections are
    different drives to the fit (their shares and calibration would be meaningless) — apart from
    a capture's stated known addition, made through its injection knob."""
    states = set()
    for capture, op in pairs:
        injection = dict(capture.meta.get("injection") or {})
        for key, knob in ADDITION_KNOBS.items():
            if op.get(key):
                injection.pop(knob, None)
        states.add(json.dumps(injection, sort_keys=True))
    if len(states) > 1:
        raise InputError(f"the {len(names)} captures were recorded with different injections "
                         f"({'; '.join(sorted(states))}); a diagnosis is of one drive state: "
                         "give captures with the same injection (hil run --source diagnosis "
                         "records such a set)")
