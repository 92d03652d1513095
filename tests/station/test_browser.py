"""The station in a real browser (Debian's chromium driven by selenium through chromedriver).

One ``hil station`` process on the in-process simulated bench, on 127.0.0.1 and a free port:

1. a unit is started from the page; the live plot updates as points are analysed; a second
   browser sees the same run and is refused a second Start with the reason; the first browser
   closes and the run goes on; Stop from the second browser stops it mid-sweep: the record is
   ``interrupted``, its final safe state complete (drive quick stop and disable, nothing failed),
   and the page states page 1's overall statement;
2. another unit runs to its end: the page states the record's overall statement exactly as
   page 1 does, links the PDF, and the history lists both units.

Needs ``/usr/bin/chromium`` and ``/usr/bin/chromedriver`` (``.ci/setup-services``).
``HIL_STATION_SCREENSHOTS=DIR`` saves ``station-running.png`` and ``station-finished.png``.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

import pytest

CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(not (os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)),
                       reason="needs Debian's chromium and chromium-driver (.ci/setup-services)"),
]
webdriver = pytest.importorskip("selenium.webdriver")
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402

from hil.record import load_record, verify_record  # noqa: E402
from ripple_hil_reports.statement import overall_statement  # noqa: E402

#: Plans of the run stopped mid-sweep: long enough (≈ 25 points) that Stop lands inside it.
SWEEP = ["dc_offset", "ripple_map", "diagnosis"]
#: Longest wait for one step of a run on a loaded 2-core CI machine, in s.
STEP_TIMEOUT_S = 120


#: A plan of the lab's own (``hil station --plan``) that asks the operator twice.
PROMPT_PLAN = """
import pytest

pytestmark = pytest.mark.ripple_source("coupling")


def test_coupled_and_supply_entered(operator_prompts):
    operator_prompts.confirm("couple", "Couple the transducer, then Continue")
    assert operator_prompts.ask("supply_v", "Enter the supply voltage in V") == "47.5"
"""


#: Fresh chromium profile folders made by :func:`browser`, removed when the station stops.
PROFILES: list[str] = []


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.fixture(scope="module")
def station(tmp_path_factory):
    """A ``hil station`` child process; stopped (SIGINT, as Ctrl-C) at the end of the module."""
    root = tmp_path_factory.mktemp("station")
    port = free_port()
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    (root / "test_coupling.py").write_text(PROMPT_PLAN)
    log = open(root / "station.log", "wb")         # a file: a pipe nobody reads could fill
    process = subprocess.Popen([sys.executable, "-m", "hil", "station", "--port", str(port),
                                "--record-dir", str(root / "records"),
                                "--plan", str(root / "test_coupling.py"),
                                "--selection", "quick check=baseline"],
                               stdout=log, stderr=subprocess.STDOUT, env=env, cwd=root)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while True:
        try:
            urllib.request.urlopen(url + "/api/state", timeout=2).read()
            break
        except OSError:
            if process.poll() is not None or time.monotonic() > deadline:
                process.kill()
                pytest.fail(f"station did not start: "
                            f"{(root / 'station.log').read_text(errors='replace')[-2000:]}")
            time.sleep(0.2)
    while not json.loads(urllib.request.urlopen(url + "/api/state", timeout=5).read())["warm"]:
        if time.monotonic() > deadline + 60:        # the station says when it has warmed up
            break
        time.sleep(0.2)
    yield {"url": url, "records": root / "records", "process": process}
    process.send_signal(signal.SIGINT)
    try:
        process.wait(timeout=60)
    except subprocess.TimeoutExpired:
        process.kill()
    log.close()
    for profile in PROFILES:
        shutil.rmtree(profile, ignore_errors=True)


def browser(*extra_flags: str):
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--window-size=1200,1900",
                 *extra_flags):
        options.add_argument(flag)
    PROFILES.append(tempfile.mkdtemp(prefix="hil-station-chromium-"))
    options.add_argument(f"--user-data-dir={PROFILES[-1]}")
    service = webdriver.ChromeService(executable_path=CHROMEDRIVER)
    os.environ.setdefault("SE_OFFLINE", "true")        # selenium manager: never download
    return webdriver.Chrome(options=options, service=service)


def page_state(driver) -> dict | None:
    return driver.execute_script("return window.stationState")


def wait_until(driver, predicate, what: str, timeout_s: float = STEP_TIMEOUT_S):
    return WebDriverWait(driver, timeout_s, poll_frequency=0.05).until(
        lambda d: predicate(d), message=f"page never showed: {what}")


def start_unit(driver, serial: str, plans: list[str]) -> None:
    wait_until(driver, lambda d: d.find_elements(By.ID, "plan-baseline"), "the plan list")
    driver.find_element(By.ID, "unit").send_keys(serial)
    for name in plans:
        driver.find_element(By.ID, f"plan-{name}").click()
    driver.find_element(By.ID, "start").click()


def expected_statement(folder: Path) -> str:
    record = load_record(folder)
    statement = overall_statement(record, verify_record(folder, record))
    return f"Overall: {statement.overall}" + (f" ({statement.reason})" if statement.reason
                                              else "")


def screenshot(driver, name: str) -> None:
    folder = os.environ.get("HIL_STATION_SCREENSHOTS")
    if folder:
        driver.save_screenshot(str(Path(folder) / name))


def test_live_plot_second_browser_close_and_stop_mid_sweep(station):
    first, second = browser(), browser()
    try:
        first.get(station["url"])
        second.get(station["url"])
        start_unit(first, "SN-STOP-1", SWEEP)
        # live plot: the plot on the page changes as points are analysed (self-check, then
        # the first dc-offset point)
        wait_until(first, lambda d: len(d.execute_script("return window.plotLoads")) >= 2,
                   "two successive plots loaded")
        loads = first.execute_script("return [window.plotLoads, window.plotInfo]")
        state = page_state(first)
        assert state["run"]["unit"] == "SN-STOP-1" and state["run"]["phase"] == "running"

        wait_until(second, lambda d: (page_state(d) or {}).get("run")
                   and page_state(d)["run"]["unit"] == "SN-STOP-1", "the same run")
        start_unit(second, "SN-OTHER", ["baseline"])
        wait_until(second, lambda d: "already going" in d.find_element(By.ID, "message").text,
                   "the second Start refused with its reason")
        screenshot(second, "station-running.png")

        first.quit()                     # closing a browser does not stop the run
        first = None
        second.find_element(By.ID, "stop").click()
        wait_until(second, lambda d: page_state(d)["run"]["phase"] == "finished",
                   "the run stopped")
        run = page_state(second)["run"]
        # the refusal held while that run went on; it does not outlive it (issue 32)
        wait_until(second, lambda d: d.find_element(By.ID, "message").text == "",
                   "the stale refusal cleared")
        alerts = [e.text for e in second.find_elements(By.CSS_SELECTOR, "#alerts .alert")]
        assert any("press Start again" in text for text in alerts), alerts
    finally:
        for driver in (first, second):
            if driver is not None:
                driver.quit()
    folder = station["records"] / run["record"]
    record = load_record(folder)
    assert record["status"] == "interrupted" and run["status"] == "interrupted"
    assert record["unit"]["serial_number"] == "SN-STOP-1"
    safe = record["run"]["final_safe_state"]
    assert "drive quick stop" in safe["steps"] and not safe["failures"], safe
    not_run = [t for t in record["tests"] if t["outcome"] == "not run"]
    assert not_run, "Stop came after the last point: not mid-sweep"
    assert run["final"]["overall_line"] == expected_statement(folder)
    # latency: a point's capture saved → its plot loaded in the browser; the station's own part
    # (the analysed point's journal line read → plot loaded)
    plot_loads, plot_info = loads
    for url, loaded_ms in plot_loads.items():
        info = plot_info[url]
        capture = folder / info["capture"]
        from_capture = loaded_ms / 1000 - capture.stat().st_mtime
        from_entry = loaded_ms / 1000 - info["entry_seen_s"]
        print(f"station latency {info['test']}: capture saved → plot on page "
              f"{from_capture:.2f} s; journal entry read → plot on page {from_entry:.2f} s "
              f"(of which drawing {info['rendered_s'] - info['entry_seen_s']:.2f} s)")
        assert from_entry <= 1.0, f"{info['test']}: plot on the page {from_entry:.2f} s after " \
                                  f"its journal entry"


def test_finished_unit_verdict_pdf_and_history(station):
    driver = browser()
    try:
        driver.get(station["url"])
        wait_until(driver, lambda d: page_state(d) and page_state(d)["run"]
                   and page_state(d)["run"]["phase"] == "finished", "the last unit kept")
        wait_until(driver, lambda d: d.find_elements(By.CSS_SELECTOR, "button.selection"),
                   "the saved selection")
        driver.find_element(By.CSS_SELECTOR, "button.selection").click()   # "quick check"
        start_unit(driver, "SN-OK-2", [])
        wait_until(driver, lambda d: page_state(d)["run"]["unit"] == "SN-OK-2"
                   and page_state(d)["run"]["phase"] == "finished"
                   and page_state(d)["run"]["links"]["pdf"], "the finished unit with its PDF")
        run = page_state(driver)["run"]
        overall = driver.find_element(By.ID, "overall").text
        statements = driver.find_element(By.ID, "statements").text
        history = [row.text for row in
                   driver.find_elements(By.CSS_SELECTOR, "#history tbody tr")]
        screenshot(driver, "station-finished.png")
        pdf = urllib.request.urlopen(station["url"] + run["links"]["pdf"], timeout=10).read()
    finally:
        driver.quit()
    folder = station["records"] / run["record"]
    # the banner is conformity to requirements: none given, said plainly, never a green PASS
    assert overall.startswith("No requirements were given") and "NOT stated" in overall
    assert expected_statement(folder) in statements          # page 1's overall line, below
    assert pdf.startswith(b"%PDF")
    record = load_record(folder)
    assert record["status"] == "complete" and record["unit"]["serial_number"] == "SN-OK-2"
    assert record["run"]["selection"]["sources"] == ["baseline", "self_check"]
    assert len(history) == 2 and "SN-OK-2" in history[0] and "SN-STOP-1" in history[1]
    assert expected_statement(folder).split()[1] in history[0]
    state = json.loads(urllib.request.urlopen(station["url"] + "/api/state").read())
    assert [row["unit"] for row in state["history"]] == ["SN-OK-2", "SN-STOP-1"]


def test_operator_prompts_on_the_page(station):
    driver = browser()
    try:
        driver.get(station["url"])
        start_unit(driver, "SN-ASK-3", ["own:coupling"])
        wait_until(driver, lambda d: d.find_elements(By.ID, "answer-button-couple"),
                   "the first question")
        assert "Couple the transducer" in driver.find_element(By.ID, "prompts").text
        driver.find_element(By.ID, "answer-button-couple").click()
        field = wait_until(driver, lambda d: d.find_elements(By.ID, "answer-supply_v"),
                           "the second question")[0]
        field.send_keys("47.5")
        driver.find_element(By.ID, "answer-button-supply_v").click()
        wait_until(driver, lambda d: page_state(d)["run"]["unit"] == "SN-ASK-3"
                   and page_state(d)["run"]["phase"] == "finished", "the finished unit")
        run = page_state(driver)["run"]
        assert not driver.find_element(By.ID, "prompts").text      # nothing left to answer
    finally:
        driver.quit()
    record = load_record(station["records"] / run["record"])
    assert record["status"] == "complete"
    outcomes = {t["test_id"].rsplit("::", 1)[-1]: t["outcome"] for t in record["tests"]}
    assert outcomes == {"test_bench_self_check": "passed", "test_transducer_dynamics": "passed",
                        "test_transducer_dynamics-reference": "passed",
                        "test_transducer_bandwidth_as_stated": "passed",
                        "test_angle_reference": "passed",
                        "test_coupled_and_supply_entered": "passed"}
    asked = {p["key"]: (p["answer"], p["by"]) for p in record["operator_prompts"]["prompts"]}
    assert asked == {"couple": ("continue", "station operator"),
                     "supply_v": ("47.5", "station operator")}


#: In the page: POST the issue's JSON to ``arguments[0]`` and hand back the HTTP status (or the
#: error text when the browser itself blocks the request).
POST_START = """
const done = arguments[arguments.length - 1];
fetch(arguments[0], {method: "POST", headers: {"Content-Type": "application/json"},
                     body: JSON.stringify({unit: "X1", plans: ["baseline"]})})
  .then((r) => done(r.status)).catch((e) => done(String(e)));
"""
#: In another origin's page: every way a page can send a command without CORS (a no-cors fetch,
#: a form posted into a frame), then a preflighted JSON fetch; resolves when all have ended.
CROSS_ORIGIN = """
const [url, done] = [arguments[0], arguments[arguments.length - 1]];
const body = JSON.stringify({unit: "X1", plans: ["baseline"]});
const frame = document.createElement("iframe"); frame.name = "sink";
document.body.appendChild(frame);
const form = document.createElement("form");
form.method = "POST"; form.action = url; form.enctype = "text/plain"; form.target = "sink";
const field = document.createElement("input"); field.name = body.slice(0, -2);
field.value = '"}'; form.appendChild(field); document.body.appendChild(form);
form.submit();
Promise.allSettled([
  fetch(url, {method: "POST", mode: "no-cors", headers: {"Content-Type": "text/plain"}, body}),
  fetch(url, {method: "POST", headers: {"Content-Type": "application/json"}, body}),
]).then((results) => setTimeout(() => done(results.map((r) => r.status)), 1500));
"""


def test_a_rebinding_page_and_another_origin_start_nothing(station, tmp_path):
    """A page of evil.example whose name resolves to 127.0.0.1 (DNS rebinding: same-origin to
    the browser) and a page of another origin each try to press Start: nothing starts."""
    import http.server
    import threading

    port = station["url"].rsplit(":", 1)[1]
    records = station["records"]
    before = sorted(p.name for p in records.iterdir()) if records.is_dir() else []
    run_before = json.loads(urllib.request.urlopen(station["url"] + "/api/state").read())["run"]
    (tmp_path / "attack.html").write_text("<!doctype html><title>another site</title><body>")
    handler = lambda *a: http.server.SimpleHTTPRequestHandler(*a, directory=str(tmp_path))  # noqa
    other = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=other.serve_forever, daemon=True).start()
    driver = browser("--host-resolver-rules=MAP evil.example 127.0.0.1")
    try:
        driver.get(f"http://evil.example:{port}/")          # the station under another name
        assert "not this station's address" in driver.page_source
        assert driver.execute_async_script(POST_START, "/api/start") == 403
        driver.get(f"http://127.0.0.1:{other.server_address[1]}/attack.html")
        settled = driver.execute_async_script(CROSS_ORIGIN, station["url"] + "/api/start")
        assert settled == ["fulfilled", "rejected"], settled   # no-cors sent; JSON preflight
    finally:                                                   # refused by the browser
        driver.quit()
        other.shutdown()
    time.sleep(0.5)
    after = sorted(p.name for p in records.iterdir()) if records.is_dir() else []
    state = json.loads(urllib.request.urlopen(station["url"] + "/api/state").read())
    assert after == before and state["run"] == run_before, "a foreign page started a run"
