"""The station's doors from a real HTTP client (http.client) against a real uvicorn on a free
port: a forged Host (DNS rebinding), a command from another origin, without the page's token or
with a stale one is 403 and starts nothing; the station's own page can command; an access token
works on loopback; a port in use is refused before any URL is printed (exit 2)."""

from __future__ import annotations

import http.client
import json
import re
import socket
import subprocess
import sys
import threading
import time

import pytest
import uvicorn

from hil.station.app import Station, create_app
from hil.station.runs import RunManager

START = json.dumps({"unit": "X1", "plans": ["baseline"]})


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def serve(tmp_path, token: str | None = None):
    """A station app under uvicorn in a thread: (station, port, stop)."""
    manager = RunManager(None, tmp_path / "records")
    station = Station(manager, ["baseline", "self_check"], "bench: test")
    port = free_port()
    server = uvicorn.Server(uvicorn.Config(
        create_app(station, token, address=("127.0.0.1", port)), host="127.0.0.1", port=port,
        log_level="warning", lifespan="on"))
    station.shutting_down = lambda: server.should_exit
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 20
    while not server.started:
        assert time.monotonic() < deadline and thread.is_alive(), "uvicorn did not start"
        time.sleep(0.02)

    def stop():
        server.should_exit = True
        thread.join(10)
        manager.close()
    return station, port, stop


@pytest.fixture
def served(tmp_path):
    station, port, stop = serve(tmp_path)
    yield station, port
    stop()


def request(port: int, method: str, path: str, headers: dict, body: str | None = None):
    """One request with exactly these headers (http.client sends no Host of its own)."""
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    try:
        connection.putrequest(method, path, skip_host=True, skip_accept_encoding=True)
        for key, value in headers.items():
            connection.putheader(key, value)
        data = body.encode() if body is not None else None
        if data is not None:
            connection.putheader("Content-Length", str(len(data)))
        connection.endheaders(data)
        response = connection.getresponse()
        return response.status, response.read().decode(errors="replace")
    finally:
        connection.close()


def page_token(port: int, host: str) -> str:
    status, page = request(port, "GET", "/", {"Host": host})
    assert status == 200
    return re.search(r'<meta name="hil-csrf" content="([^"]+)">', page).group(1)


def nothing_started(station, tmp_path) -> bool:
    folder = tmp_path / "records"
    return station.manager.run is None and not (folder.is_dir() and any(folder.iterdir()))


def test_a_forged_host_is_refused_and_starts_nothing(served, tmp_path):
    station, port = served
    # the curl, and the same from a DNS-rebinding page (evil.example → 127.0.0.1)
    for host, origin in (("evil.example", "http://evil.example"),
                         (f"evil.example:{port}", f"http://evil.example:{port}")):
        status, text = request(port, "POST", "/api/start",
                               {"Host": host, "Origin": origin,
                                "Content-Type": "application/json"}, START)
        assert status == 403 and "not this station's address" in text, (status, text)
        # the page (and its token) and the state are not served to that name either
        assert request(port, "GET", "/", {"Host": host})[0] == 403
        assert request(port, "GET", "/api/state", {"Host": host})[0] == 403
    # a forged Host carrying a token the real page issued is refused all the same
    token = page_token(port, f"127.0.0.1:{port}")
    status, _ = request(port, "POST", "/api/start",
                        {"Host": f"evil.example:{port}", "Origin": f"http://evil.example:{port}",
                         "X-HIL-CSRF": token, "Content-Type": "application/json"}, START)
    assert status == 403
    assert request(port, "GET", "/api/state", {})[0] == 400          # no Host: h11 refuses
    assert nothing_started(station, tmp_path)


def test_a_command_not_from_the_own_page_is_refused(served, tmp_path):
    station, port = served
    own = f"127.0.0.1:{port}"
    token = page_token(port, own)
    json_type = {"Host": own, "Content-Type": "application/json"}
    for headers in ({"Origin": "http://evil.example"},                    # another site
                    {"Origin": "null"},                                   # a sandboxed frame
                    {"Origin": f"http://127.0.0.1:{port + 1}"},           # another port
                    {"Referer": "http://evil.example/attack.html"},       # no Origin, Referer
                    {},                                                   # neither
                    {"Origin": "http://evil.example", "X-HIL-CSRF": token},
                    {"Origin": f"http://{own}"},                          # own, no token
                    {"Origin": f"http://{own}", "X-HIL-CSRF": "made-up-token"}):
        status, text = request(port, "POST", "/api/start", json_type | headers, START)
        assert status == 403, (headers, status, text)
        status, _ = request(port, "POST", "/api/stop", json_type | headers, "{}")
        assert status == 403, headers
    assert nothing_started(station, tmp_path)


def test_the_own_page_commands_and_localhost_names_it(served, tmp_path):
    station, port = served
    for host in (f"127.0.0.1:{port}", f"localhost:{port}"):
        token = page_token(port, host)
        assert token != page_token(port, host)                  # one token per page
        for origin_header in ({"Origin": f"http://{host}"},
                              {"Referer": f"http://{host}/"}):
            status, text = request(port, "POST", "/api/stop",
                                   {"Host": host, "Content-Type": "application/json",
                                    "X-HIL-CSRF": token} | origin_header, "{}")
            assert status == 409 and json.loads(text)["refused"] == "no run is going on"
        # past the doors, the application's own checks still apply
        status, text = request(port, "POST", "/api/start",
                               {"Host": host, "Origin": f"http://{host}",
                                "Content-Type": "application/json", "X-HIL-CSRF": token},
                               json.dumps({"unit": "X1", "plans": ["no_such_plan"]}))
        assert status == 409 and "no_such_plan" in text
    assert nothing_started(station, tmp_path)


def test_an_access_token_on_loopback_is_required_when_given(tmp_path):
    station, port, stop = serve(tmp_path, token="loopback-token-0123456789")
    try:
        host = {"Host": f"127.0.0.1:{port}"}
        assert request(port, "GET", "/api/state", host)[0] == 401
        assert request(port, "GET", "/api/state?token=loopback-token-0123456789", host)[0] == 200
        assert request(port, "GET", "/api/state?token=loopback-token-0123456789",
                       {"Host": "evil.example"})[0] == 403      # the token does not open Host
    finally:
        stop()


def test_a_port_in_use_is_refused_without_a_url(tmp_path):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        done = subprocess.run([sys.executable, "-m", "hil", "station", "--port", str(port),
                               "--record-dir", str(tmp_path / "records")],
                              capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert done.returncode == 2, (done.returncode, done.stdout, done.stderr)
    assert "http://" not in done.stdout + done.stderr
    assert f"--port {port}: the port is in use" in done.stderr
