"""Security: simulated servers listen on loopback only; nothing in a bench file, record or
capture file is ever run as code; record, capture and report paths stay inside their folders.
"""

from __future__ import annotations

import ast
import json
import pickle
import shutil
import string
from pathlib import Path

import numpy as np
import pypdf
import pytest
import tomli_w
import tomllib
from hypothesis import given, settings
from hypothesis import strategies as st

from hil.capture import Capture
from hil.cli import main as hil_main
from hil.config import default_sim_bench, example_bench_path, load_bench
from hil.errors import InputError
from hil.record import CAPTURE_DIR, RunRecord, capture_path, safe_test_name, verify_captures
from hil.simbench import SimulatedBench

from .faults import copy_record

REPO = Path(__file__).resolve().parents[2]
PRODUCT_PACKAGES = ("hil", "drivers", "fixtures", "reports", "testplans", "benchmarks")


# ------------------------------------------------------------------------------ loopback
def listening_hosts(port: int) -> set[str]:
    """Local addresses with a TCP socket listening on ``port`` (from /proc/net/tcp{,6})."""
    hosts = set()
    for name, width in (("tcp", 8), ("tcp6", 32)):
        table = Path("/proc/net") / name
        if not table.exists():
            continue
        for line in table.read_text().splitlines()[1:]:
            fields = line.split()
            address, port_hex = fields[1].split(":")
            if int(port_hex, 16) == port and fields[3] == "0A":       # 0A = LISTEN
                hosts.add(address if len(address) == width else "?")
    return hosts


LOOPBACK = {"0100007F", "00000000000000000000000001000000"}     # 127.0.0.1 and ::1, as in /proc


@pytest.mark.integration
@pytest.mark.parametrize("cross_process", [False, True], ids=["in-process", "sim-bench"])
def test_simulated_servers_listen_on_loopback_only(cross_process):
    simulated = SimulatedBench(default_sim_bench(), cross_process=cross_process)
    config = simulated.start()
    try:
        assert config.daq.host == "127.0.0.1"
        ports = [config.daq.port]
        if cross_process:
            assert config.drive.channel.startswith("ws://127.0.0.1:")
            ports.append(int(config.drive.channel.rsplit(":", 1)[1].split("/")[0]))
        else:
            assert config.drive.interface == "virtual"   # in-process only: no socket at all
        for port in ports:
            hosts = listening_hosts(port)
            assert hosts and hosts <= LOOPBACK, (port, hosts)
        assert Path(config.torque.serial_port).is_char_device()   # a local pty, not a socket
    finally:
        simulated.stop()


def test_no_server_default_binds_all_interfaces():
    """No product module names the IPv4 wildcard, and every ``host`` parameter defaults to a
    loopback address (or has no default)."""
    offenders, hosts_checked = [], 0
    for path in product_sources():
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Constant) and node.value == "0.0.0.0":
                offenders.append(f"{path.relative_to(REPO)}:{node.lineno} '0.0.0.0'")
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                arguments = node.args.posonlyargs + node.args.args
                pairs = list(zip(arguments[len(arguments) - len(node.args.defaults):],
                                 node.args.defaults))
                pairs += list(zip(node.args.kwonlyargs, node.args.kw_defaults))
                for argument, default in pairs:
                    hosts_checked += argument.arg == "host"
                    if argument.arg == "host" and isinstance(default, ast.Constant) and \
                            default.value not in ("127.0.0.1", "localhost", "::1", None):
                        offenders.append(f"{path.relative_to(REPO)}:{node.lineno} "
                                         f"host={default.value!r}")
    assert offenders == []
    assert hosts_checked >= 4          # the simulated DAQ, CAN bus server, remote drive, ...


# ------------------------------------------------------------------------------ no code evaluated
def product_sources() -> list[Path]:
    return sorted(p for package in PRODUCT_PACKAGES for p in (REPO / package).rglob("*.py"))


FORBIDDEN_CALLS = {"eval", "exec", "compile", "__import__", "execfile"}
FORBIDDEN_MODULES = {"pickle", "cPickle", "marshal", "shelve", "dill", "yaml"}
#: The one exemption, by file and module, with why: the motulator plant's worker is a child
#: process this process starts itself (sys.executable -m hil.plants.motulator_process); requests
#: and replies are pickled over that child's own stdin/stdout pipe only. No file, socket, record,
#: bench file or other input from outside is ever unpickled. Any other pickle use still fails.
PICKLE_EXEMPT = {("hil/plants/motulator_process.py", "pickle")}


def test_product_code_never_evaluates_or_unpickles():
    """No eval/exec/compile/__import__, no pickle/marshal/shelve/yaml, no allow_pickle=True, no
    shell=True anywhere in the product (bench files are parsed by tomllib, records by json,
    captures by numpy with allow_pickle=False)."""
    offenders = []
    for path in product_sources():
        where = path.relative_to(REPO)
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Call):
                func = node.func
                name = func.id if isinstance(func, ast.Name) else \
                    func.attr if isinstance(func, ast.Attribute) else None
                if name in FORBIDDEN_CALLS and not (isinstance(func, ast.Attribute) and
                                                    name == "compile"):    # re.compile is fine
                    offenders.append(f"{where}:{node.lineno} {name}()")
                for keyword in node.keywords:
                    if keyword.arg in ("allow_pickle", "shell") and \
                            isinstance(keyword.value, ast.Constant) and keyword.value.value:
                        offenders.append(f"{where}:{node.lineno} {keyword.arg}=True")
            elif isinstance(node, (ast.Import, ast.ImportFrom)):
                names = [a.name for a in node.names] if isinstance(node, ast.Import) \
                    else [node.module or ""]
                offenders += [f"{where}:{node.lineno} import {n}" for n in names
                              if n.split(".")[0] in FORBIDDEN_MODULES
                              and (str(where), n) not in PICKLE_EXEMPT]
    assert offenders == []


CODE = "__import__('pathlib').Path({canary!r}).write_text('pwned')"


def test_code_in_a_bench_file_is_only_text(tmp_path):
    canary = tmp_path / "canary"
    code = CODE.format(canary=str(canary))
    table = tomllib.loads(example_bench_path("sim-bench").read_text())
    table["motor"]["model"] = code
    table["lab"].update(name=code, operator="{{" + code + "}}", address=f"${{{code}}}")
    for entry in table["instrument"]:
        entry.update(model=code, serial_number=f"!!python/object:{code}", range=code)
    path = tmp_path / "bench.toml"
    path.write_text(tomli_w.dumps(table))
    bench = load_bench(path)
    assert bench.lab.name == code and bench.instruments[0].model == code
    assert bench.instruments[0].serial_number == f"!!python/object:{code}"
    assert not canary.exists()


def test_a_pickled_capture_is_refused_unopened(tmp_path, capsys):
    canary = tmp_path / "canary"

    class Payload:
        def __reduce__(self):
            return (Path.write_text, (canary, "pwned"))

    target = tmp_path / "evil.npz"
    np.savez(target, __header__=np.frombuffer(b'{"units": {}, "meta": {}}', dtype=np.uint8),
             ch_time_s=np.array([Payload()], dtype=object))
    raw = target.with_suffix(".npy")
    raw.write_bytes(pickle.dumps(Payload()))          # a bare pickle named like a capture
    for path in (target, raw):
        with pytest.raises(InputError, match="not a (readable )?ripple-hil capture"):
            Capture.load(path)
        assert hil_main(["analyze", str(path)]) == 2
    assert "pickled" in capsys.readouterr().err
    assert not canary.exists()


def test_code_in_a_record_is_only_text(small_record, tmp_path, capsys):
    canary = tmp_path / "canary"
    code = CODE.format(canary=str(canary))
    folder = copy_record(small_record, tmp_path)
    data = json.loads((folder / "record.json").read_text())
    data["bench"]["loaded"]["lab"]["name"] = code
    data["tests"][0]["notes"] = [code, "{" + code + "}", "%s%s%n"]
    data["tests"][0]["error"] = code
    (folder / "record.json").write_text(json.dumps(data))
    assert hil_main(["report", str(folder), "-o", str(tmp_path / "r.pdf")]) == 1  # seal broken
    assert not canary.exists()
    text = "".join(page.extract_text() for page in pypdf.PdfReader(tmp_path / "r.pdf").pages)
    assert "__import__" in text                       # shown as text, not run


# ------------------------------------------------------------------------------ paths
@settings(max_examples=200, deadline=None)
@given(test_id=st.text(min_size=1, max_size=200).filter(str.strip))
def test_capture_names_cannot_leave_the_captures_folder(test_id):
    name = safe_test_name(test_id)
    assert name and "/" not in name and "\\" not in name and not name.startswith(".")
    assert set(name) <= set(string.ascii_letters + string.digits + "._-")
    root = Path("/records/run") / CAPTURE_DIR
    assert (root / f"{name}.npz").resolve().parent == root


@settings(max_examples=30, deadline=None)
@given(a=st.text(min_size=1, max_size=30).filter(str.strip),
       b=st.text(min_size=1, max_size=30).filter(str.strip))
def test_different_test_ids_get_different_capture_files(a, b):
    if a != b:
        assert safe_test_name(a) != safe_test_name(b)


def test_record_and_capture_writes_stay_inside_the_record(tmp_path):
    root = tmp_path / "records"
    record = RunRecord.create(root, default_sim_bench(), [], name="../../outside")
    assert record.path.resolve().parent == root.resolve()
    capture = Capture({"time_s": np.arange(4.0)})
    for test_id in ("../../../escaped", "/etc/passwd", "..", "captures/../../x", "a\\..\\..\\b"):
        info = record.save_capture(test_id, capture)
        written = (record.path / info["file"]).resolve()
        assert written.parent == (record.path / CAPTURE_DIR).resolve(), info
    record.finish("complete")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["records"]
    assert sorted(p.name for p in root.iterdir()) == [record.path.name]


@pytest.mark.parametrize("relative", ["../record.json", "/etc/passwd", "captures/../../secret.npz",
                                      "captures", "captures/", "", None, 42])
def test_capture_entries_pointing_outside_are_not_followed(tmp_path, relative):
    assert capture_path(tmp_path, relative) is None


def test_report_never_reads_or_attaches_a_file_outside_the_record(small_record, tmp_path):
    folder = copy_record(small_record, tmp_path)
    secret = tmp_path / "secret.npz"
    Capture({"time_s": np.arange(3.0), "torque_nm": np.full(3, 1234.5678)},
            meta={"note": "SECRET-OUTSIDE-THE-RECORD"}).save(secret)
    data = json.loads((folder / "record.json").read_text())
    data["tests"][0]["capture"]["file"] = "../secret.npz"
    data["tests"][0]["measured"].pop("angle_grid_rad", None)
    (folder / "record.json").write_text(json.dumps(data))
    problems = verify_captures(folder)
    assert any("outside captures/" in p for p in problems), problems
    assert hil_main(["report", str(folder), "-o", str(tmp_path / "r.pdf")]) == 1  # seal broken
    reader = pypdf.PdfReader(tmp_path / "r.pdf")
    attached = reader.attachments
    assert "secret.npz" not in " ".join(attached)
    assert all(secret.read_bytes() not in blob for blobs in attached.values() for blob in blobs)
    shutil.rmtree(folder)
