"""The station's web application without a browser: access token off loopback, JSON-only
commands, record files only from the station's own record folder, and the CLI's address rules."""

from __future__ import annotations

import asyncio
import json
import re

import pytest

from hil.commands.station import is_loopback, run as station_command, selections
from hil.errors import InputError
from hil.station.app import Station, create_app
from hil.station.runs import RunManager


#: The address the stations of these tests serve, and the Host header naming it.
ADDRESS = ("127.0.0.1", 8725)
HOST = "127.0.0.1:8725"


def call(app, method: str, path: str, body: bytes = b"", headers=(), query: str = ""):
    """One HTTP request straight into the ASGI app: (status, headers, body); ``Host`` is the
    station's own unless ``headers`` name one."""
    if not any(key.lower() == "host" for key, _ in headers):
        headers = [("Host", HOST), *headers]
    sent, requests = [], [{"type": "http.request", "body": body, "more_body": False}]

    async def receive():          # the request once, then a client that stays connected
        if requests:
            return requests.pop()
        await asyncio.Event().wait()

    async def send(message):
        sent.append(message)

    scope = {"type": "http", "method": method, "path": path, "raw_path": path.encode(),
             "query_string": query.encode(), "root_path": "", "scheme": "http",
             "server": ("127.0.0.1", 1), "client": ("127.0.0.1", 2), "http_version": "1.1",
             "headers": [(k.lower().encode(), v.encode()) for k, v in headers]}
    asyncio.run(app(scope, receive, send))
    start = next(m for m in sent if m["type"] == "http.response.start")
    content = b"".join(m.get("body", b"") for m in sent if m["type"] == "http.response.body")
    return start["status"], dict((k.decode(), v.decode()) for k, v in start["headers"]), content


def own_page(app, content_type: str = "application/json") -> list[tuple[str, str]]:
    """The headers of a command sent by the station's own page: its Origin and the token the
    page was served with."""
    page = call(app, "GET", "/")[2].decode()
    token = re.search(r'<meta name="hil-csrf" content="([^"]+)">', page).group(1)
    return [("Origin", f"http://{HOST}"), ("X-HIL-CSRF", token), ("Content-Type", content_type)]


@pytest.fixture
def station(tmp_path):
    manager = RunManager(None, tmp_path / "records")
    yield Station(manager, ["baseline", "self_check"], "bench: test")
    manager.close()


def test_token_is_required_and_then_kept_in_a_cookie(station):
    app = create_app(station, token="s3cret-token-0123456789", address=ADDRESS)
    assert call(app, "GET", "/api/state")[0] == 401
    assert call(app, "GET", "/api/state", query="token=wrong")[0] == 401
    status, headers, _ = call(app, "GET", "/api/state", query="token=s3cret-token-0123456789")
    assert status == 200 and "hil_station_token=s3cret-token-0123456789" in headers["set-cookie"]
    assert call(app, "GET", "/api/state",
                headers=[("Cookie", "hil_station_token=s3cret-token-0123456789")])[0] == 200
    assert call(app, "GET", "/api/state",
                headers=[("Authorization", "Bearer s3cret-token-0123456789")])[0] == 200


def test_commands_need_json_and_valid_input(station):
    app = create_app(station, address=ADDRESS)
    status, _, body = call(app, "POST", "/api/start", b"unit=SN-1&plans=baseline",
                           headers=own_page(app, "application/x-www-form-urlencoded"))
    assert status == 415 and station.manager.run is None      # a form cannot start
    status, _, body = call(app, "POST", "/api/start", json.dumps(
        {"unit": "SN 1; rm -rf", "plans": ["baseline"]}).encode(), headers=own_page(app))
    assert status == 409 and "serial number" in json.loads(body)["refused"]
    status, _, body = call(app, "POST", "/api/start", json.dumps(
        {"unit": "SN-1", "plans": ["no_such_plan"]}).encode(), headers=own_page(app))
    assert status == 409 and "no_such_plan" in json.loads(body)["refused"]
    status, _, body = call(app, "POST", "/api/stop", b"{}", headers=own_page(app))
    assert status == 409 and json.loads(body)["refused"] == "no run is going on"
    assert station.manager.run is None


def test_a_request_without_a_host_header_is_refused(station):
    app = create_app(station, address=ADDRESS)
    scope_without_host = [("X-Nothing", "1")]
    status, _, body = call(app, "GET", "/api/state", headers=[("Host", "")] + scope_without_host)
    assert status == 403 and b"not this station's address" in body


def test_record_files_only_from_the_record_folder(station, tmp_path):
    app = create_app(station, address=ADDRESS)
    (tmp_path / "records" / "r1").mkdir()
    (tmp_path / "records" / "r1" / "record.json").write_text("{}")
    (tmp_path / "secret.json").write_text("{}")
    assert call(app, "GET", "/records/r1/record.json")[0] == 200
    assert call(app, "GET", "/records/r1/other.txt")[0] == 404
    assert call(app, "GET", "/records/../secret.json")[0] == 404
    assert call(app, "GET", "/records/..%2Fsecret.json/record.json")[0] == 404


def test_cli_address_rules():
    assert is_loopback("127.0.0.1") and is_loopback("::1") and is_loopback("localhost")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.168.1.5")

    class Args:
        bench = None
        port = 8725
        host = "127.0.0.1"
        token = "short"
        record_dir = "records"
        plan = []
        allow_host = []

    with pytest.raises(InputError, match="at least 16"):       # a token is allowed on loopback
        station_command(Args)
    Args.host = "0.0.0.0"
    with pytest.raises(InputError, match="at least 16"):
        station_command(Args)
    Args.token = "a-token-that-is-long-enough"
    with pytest.raises(InputError, match="--allow-host"):      # every address: name the Host
        station_command(Args)


def test_saved_selections_name_only_offered_plans():
    assert selections(["end of line = self_check, baseline"], ["baseline", "self_check"]) == \
        {"end of line": ["self_check", "baseline"]}
    with pytest.raises(InputError, match="unknown: nope"):
        selections(["x=baseline,nope"], ["baseline"])
    with pytest.raises(InputError, match="NAME=PLAN"):
        selections(["=baseline"], ["baseline"])


def test_a_display_error_is_shown_and_the_ticker_goes_on(station):
    calls = []

    def broken_refresh():
        calls.append(1)
        raise ValueError("odd record")

    station.manager.refresh = broken_refresh

    async def tick_a_while():
        task = asyncio.create_task(station.run_ticker())
        await asyncio.sleep(0.5)
        task.cancel()

    asyncio.run(tick_a_while())
    assert station.state["station_error"] == "ValueError: odd record"
    assert station.version == 1 and len(calls) >= 3        # published once, still polling


def test_a_restarted_station_shows_the_last_unit(station, tmp_path):
    from hil.config import default_sim_bench
    from hil.record import RunRecord

    record = RunRecord.create(tmp_path / "records", default_sim_bench(), [],
                              sections={"run": {"selection": {"sources": ["baseline"]}}})
    record.set_section("unit", {"serial_number": "SN-LAST"})
    record.add_test({"test_id": "plans::test_baseline", "source": "baseline",
                     "outcome": "failed", "message": "boom"})
    record.finish("complete")
    state = station.build_state()
    assert state["run"]["unit"] == "SN-LAST" and state["run"]["phase"] == "finished"
    from hil.record import load_record, verify_record
    from ripple_hil_reports.statement import overall_statement

    data = load_record(record.path)
    assert state["run"]["final"]["overall"] == \
        overall_statement(data, verify_record(record.path, data)).overall == "FAIL"
    assert state["run"]["verdicts"][0]["outcome"] == "failed"
    assert state["history"][0]["unit"] == "SN-LAST"
