"""Property-based tests (hypothesis) of the input parsers: the serial dialects' answer parsers,
the driver's line assembly, and the bench-file loader. Whatever arrives, the result is a value
or the parser's own typed error — never another exception, never a silently wrong number."""

from __future__ import annotations

import datetime as dt
import math
import string
import tomllib

import pytest
import tomli_w
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from ripple_hil_drivers.torque_transducer import SerialSettings, TorqueTransducer
from ripple_hil_drivers.transducer_dialects import (LBF_IN_NM, DeviceReportedError, DialectError,
                                         HimmelsteinDialect, MagtrolDialect, float_to_hex,
                                         hex_to_float, hex_to_int16)
from hil.config import BenchConfig, example_bench_path, load_bench
from hil.errors import InputError

PROPERTY = settings(max_examples=150, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])
printable_line = st.text(alphabet=string.printable.strip() + " ", max_size=60)
any_text = st.text(max_size=60)


# ------------------------------------------------------------------------------ dialects
@PROPERTY
@given(line=st.one_of(any_text, printable_line,
                      st.from_regex(r"S\d{1,6}T-?\d{1,4}\.\d{0,6}[RLAX]?", fullmatch=True)))
def test_magtrol_parser_gives_a_reading_or_a_dialect_error(line):
    try:
        reading = MagtrolDialect().parse_reading(line)
    except (DialectError, DeviceReportedError):
        return
    assert math.isfinite(reading.torque_nm) and math.isfinite(reading.speed_rpm)
    assert reading.time_s is None


@PROPERTY
@given(speed=st.integers(0, 99_999), torque=st.floats(-9999, 9999, allow_nan=False),
       direction=st.sampled_from("RL"), noise=st.text(alphabet="~?%#@ ", max_size=5))
def test_magtrol_answer_round_trip(speed, torque, direction, noise):
    """What the instrument prints (4 decimals, after any printable line noise) is read back."""
    text = f"{torque:.4f}"
    reading = MagtrolDialect().parse_reading(f"{noise}S{speed}T{text}{direction}")
    assert reading.torque_nm == float(text)
    assert reading.speed_rpm == (speed if direction == "R" else -speed)


def himmelstein() -> HimmelsteinDialect:
    dialect = HimmelsteinDialect(timestamped=True)   # the YC time-stamp mode (assumed layout)
    dialect.scale_pos_lbf_in = dialect.scale_neg_lbf_in = 5.0 / LBF_IN_NM / 30000
    return dialect


@PROPERTY
@given(line=st.one_of(any_text, printable_line,
                      st.from_regex(r"[0-9A-Fa-fG ]{6,10},[0-9A-Fa-fG ]{2,6}", fullmatch=True)))
def test_himmelstein_parser_gives_a_reading_or_a_dialect_error(line):
    try:
        reading = himmelstein().parse_reading(line)
    except DialectError:
        return
    assert math.isfinite(reading.torque_nm) and abs(reading.torque_nm) <= 5.0 * 32768 / 30000
    assert reading.speed_rpm is None and reading.time_s >= 0


@PROPERTY
@given(ticks=st.lists(st.integers(0, 2**32 - 1), min_size=1, max_size=8),
       counts=st.integers(-32768, 32767))
def test_himmelstein_time_stamps_never_run_backwards(ticks, counts):
    """The 32-bit tick counter may wrap; the time stamps it gives stay non-decreasing."""
    dialect = himmelstein()
    times = [dialect.parse_reading(f"{t:08X},{counts & 0xFFFF:04X}").time_s for t in ticks]
    assert all(b >= a for a, b in zip(times, times[1:]))
    reading = dialect.parse_reading(f"{ticks[-1]:08X},{counts & 0xFFFF:04X}")
    assert reading.torque_nm == pytest.approx(counts * 5.0 / 30000, abs=1e-12)


@PROPERTY
@given(text=st.text(max_size=10))
def test_hex_helpers_refuse_anything_but_their_digits(text):
    for parse, width in ((hex_to_int16, 4), (hex_to_float, 8)):
        try:
            value = parse(text)
        except DialectError:
            continue
        assert len(text) == width and all(c in string.hexdigits for c in text)
        assert isinstance(value, (int, float))


@PROPERTY
@given(value=st.floats(width=32, allow_nan=False, allow_infinity=False))
def test_ieee_float_hex_round_trip(value):
    assert hex_to_float(float_to_hex(value)) == value


class EndOfData(Exception):
    """The stand-in serial line has handed out every chunk."""


class ChunkedSerial:
    """A stand-in for pyserial (unit test): hands out the given chunks, then EndOfData."""

    def __init__(self, chunks: list[bytes]) -> None:
        self.chunks = [c for c in chunks if c]
        self.timeout = 0.05

    @property
    def in_waiting(self) -> int:
        return len(self.chunks[0]) if self.chunks else 0

    def read(self, size: int) -> bytes:
        if not self.chunks:
            raise EndOfData
        return self.chunks.pop(0)


@PROPERTY
@given(data=st.binary(max_size=300), cuts=st.lists(st.integers(1, 40), max_size=20))
def test_line_assembly_from_arbitrary_bytes_in_arbitrary_pieces(data, cuts):
    """However the bytes are split, the driver returns the printable content of each
    CR/LF-terminated line in order (empty lines skipped) and keeps the unterminated rest."""
    chunks, rest = [], data
    for cut in cuts:
        chunks.append(rest[:cut])
        rest = rest[cut:]
    chunks.append(rest)
    driver = TorqueTransducer(SerialSettings("/dev/null"))
    driver._serial = ChunkedSerial(chunks)
    lines = []
    with pytest.raises(EndOfData):
        while True:
            lines.append(driver._read_line(deadline=float("inf")))
    printable = bytes(b for b in data if 0x20 <= b < 0x7F or b in b"\r\n").decode()
    parts = printable.replace("\r", "\n").split("\n")
    assert lines == [part.strip() for part in parts[:-1] if part.strip()]
    assert bytes(driver._pending) == data[len(data) - len(data.replace(b"\r", b"\n")
                                                         .split(b"\n")[-1]):]


# ------------------------------------------------------------------------------ bench loader
SHIPPED = tomllib.loads(example_bench_path("sim-bench").read_text())
toml_scalars = st.one_of(
    st.booleans(), st.integers(-2**63, 2**63 - 1), st.floats(), st.text(max_size=20),
    st.dates(min_value=dt.date(1900, 1, 1), max_value=dt.date(2200, 1, 1)),
    st.datetimes(min_value=dt.datetime(1900, 1, 1), max_value=dt.datetime(2200, 1, 1)),
    st.times())
toml_values = st.recursive(toml_scalars,
                           lambda inner: st.one_of(st.lists(inner, max_size=3),
                                                   st.dictionaries(st.text(max_size=8), inner,
                                                                   max_size=3)),
                           max_leaves=6)
KEYS = [(section, key) for section, table in SHIPPED.items() if isinstance(table, dict)
        for key in table] + [("instrument", "role"), ("instrument", "calibration_due"),
                             ("daq", "port"), ("drive", "channel"), ("drive", "eds"),
                             ("torque", "serial_port"), (None, "simulated"), (None, "extra")]


@PROPERTY
@given(edits=st.lists(st.tuples(st.sampled_from(KEYS), toml_values), min_size=1, max_size=4),
       simulated=st.booleans())
def test_bench_loader_accepts_or_names_the_problem(tmp_path_factory, edits, simulated):
    table = tomllib.loads(tomli_w.dumps(SHIPPED))
    table["simulated"] = simulated
    for (section, key), value in edits:
        if section is None:
            table[key] = value
        elif section == "instrument":
            table["instrument"][0][key] = value
        else:
            table[section][key] = value
    try:
        text = tomli_w.dumps(table)
    except (TypeError, ValueError):
        assume(False)               # not representable in TOML: not a bench file anyone can write
    path = tmp_path_factory.mktemp("bench") / "bench.toml"
    path.write_text(text)
    try:
        bench = load_bench(path)
    except InputError as exc:
        message = str(exc)
        assert message.startswith(str(path)) and "\n" not in message.strip()
        return
    # accepted: what was loaded round-trips, and the limits hold the operating point
    assert BenchConfig.from_dict(bench.to_dict(), base_dir=path.parent).to_dict() == bench.to_dict()
    assert abs(bench.operating_point.speed_rpm) <= bench.limits.speed_rpm
    assert 0 <= bench.operating_point.current_a <= bench.limits.current_a


@PROPERTY
@given(document=st.dictionaries(st.text(max_size=12), toml_values, max_size=5))
def test_bench_loader_on_arbitrary_documents(tmp_path_factory, document):
    try:
        text = tomli_w.dumps(document)
    except (TypeError, ValueError):
        assume(False)
    path = tmp_path_factory.mktemp("bench") / "bench.toml"
    path.write_text(text)
    try:
        load_bench(path)
    except InputError:
        pass


@PROPERTY
@given(current_a=st.floats(0.1, 100.0), speed_rpm=st.floats(1.0, 3000.0),
       torque_nm=st.floats(0.01, 10_000.0), op_current_a=st.floats(0.0, 100.0),
       op_speed_rpm=st.floats(-3000.0, 3000.0))
def test_limits_in_range_are_read_back_exactly(tmp_path_factory, current_a, speed_rpm, torque_nm,
                                               op_current_a, op_speed_rpm):
    """In-range limits load as written; an operating point outside them is refused by name."""
    table = tomllib.loads(tomli_w.dumps(SHIPPED))
    table["limits"].update(current_a=current_a, speed_rpm=speed_rpm, torque_nm=torque_nm)
    table["operating_point"].update(current_a=op_current_a, speed_rpm=op_speed_rpm)
    path = tmp_path_factory.mktemp("bench") / "bench.toml"
    path.write_text(tomli_w.dumps(table))
    inside = op_current_a <= current_a and abs(op_speed_rpm) <= speed_rpm
    if not inside:
        with pytest.raises(InputError, match=r"operating_point\.(current_a|speed_rpm) = .* "
                                             r"exceeds limits\."):
            load_bench(path)
        return
    limits = load_bench(path).limits
    assert (limits.current_a, limits.speed_rpm, limits.torque_nm) == (current_a, speed_rpm,
                                                                       torque_nm)
