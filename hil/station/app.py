"""The station's web application (Starlette, served by uvicorn; design.md §10).

Why Starlette + uvicorn: both are small, widely used and maintained ASGI packages (Starlette is
what FastAPI is built on); Starlette's ``StreamingResponse`` carries server-sent events without a
further package, and its routing, static files and file responses replace every hand-written
server part. Server-sent events rather than WebSockets because the page only *receives* state
(one-way, plain HTTP, reconnects by itself after a network blip); its few commands are ordinary
JSON POSTs. Plots are rendered on the server (:mod:`hil.station.plots`), so the page needs no
JavaScript library and no build step.

Every browser sees the same state: one ticker polls the run (:class:`RunManager.refresh`, which
tails the record's journal) every :data:`TICK_S` and, when anything changed, renders the newest
point's plot once and wakes every open event stream. A browser that closes changes nothing; one
that opens gets the current state at once.

Every request passes :mod:`hil.station.guard` first: a ``Host`` that is not the station's
address, a command whose ``Origin``/``Referer`` is not the station's own page, or one without
the page's token is 403 (design.md §6). POSTs also need ``Content-Type: application/json``.
On any address other than loopback an access token is required, on loopback it is allowed
(``?token=`` once, then a cookie; or ``Authorization: Bearer``).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import re
import secrets
import threading
import time
from pathlib import Path

from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import (FileResponse, JSONResponse, PlainTextResponse, Response,
                                 StreamingResponse)
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from hil.station import view
from hil.station.guard import CSRF_META, PageTokens, StationGuard, allowed_hosts
from hil.station.history import History
from hil.station.journal import read_record
from hil.station.plots import point_svg
from hil.station.runs import Refused, RunManager

#: How often the run is polled, in s (journal lines are visible to the page within this).
TICK_S = 0.1
#: An event stream sends a comment this often when nothing changes, in s (keeps proxies open).
KEEPALIVE_S = 15.0
STATIC = Path(__file__).parent / "static"
RECORD_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,160}$")
TOKEN_COOKIE = "hil_station_token"


class Station:
    """The state every page shows, and the one ticker that keeps it current."""

    def __init__(self, manager: RunManager, plans: list[str], bench_label: str,
                 totals_loader=None, warm_up=None,
                 selections: dict[str, list[str]] | None = None) -> None:
        self.manager = manager
        self.plans = plans
        #: Saved selections of plans (name → plans), one button each on the page.
        self.selections = dict(selections or {})
        self.bench_label = bench_label
        self.history = History(manager.record_root)
        self.totals: dict[str, int] = {}
        self.version = 0
        self.state: dict = {}
        self.plot_cache: dict[tuple[str, int], bytes] = {}
        self.plot_key: tuple[str, int] | None = None
        self.plot_ready_s: dict[str, float] = {}
        self._last_cache: dict[str, dict] = {}
        self._changed: asyncio.Event | None = None
        self._dirty = True
        #: True once the server is stopping (set by ``hil station``: uvicorn's should_exit).
        self.shutting_down = lambda: False
        self._lock = threading.Lock()
        #: False until the plotting and analysis start-up costs were paid (``warm_up``).
        self.warm = warm_up is None
        if warm_up is not None:
            threading.Thread(target=self._warm_up, args=(warm_up,), daemon=True,
                             name="station-warm-up").start()
        if totals_loader is not None:
            threading.Thread(target=self._load_totals, args=(totals_loader,), daemon=True,
                             name="station-plan-totals").start()

    def _load_totals(self, loader) -> None:
        self.totals = loader() or {}
        self.touch()

    def _warm_up(self, warm_up) -> None:
        try:
            warm_up()
        finally:
            self.warm = True
            self.touch()

    def touch(self) -> None:
        """Mark the state as changed (the next tick rebuilds it and wakes the streams)."""
        with self._lock:
            self._dirty = True

    # ------------------------------------------------------------------ ticking
    async def run_ticker(self) -> None:
        self._changed = asyncio.Event()
        self._dirty = True
        while True:
            try:
                changed = await asyncio.to_thread(self.manager.refresh)
                with self._lock:
                    changed, self._dirty = changed or self._dirty, False
                if changed:
                    self._publish(await asyncio.to_thread(self.build_state))
            except Exception as exc:             # a sink never stops: show it, keep ticking
                error = f"{type(exc).__name__}: {exc}"
                if self.state.get("station_error") != error:
                    self._publish(dict(self.state, station_error=error))
            await asyncio.sleep(TICK_S)

    def _publish(self, state: dict) -> None:
        """Make ``state`` current and wake every event stream."""
        self.version += 1
        self.state = state | {"version": self.version}
        event, self._changed = self._changed, asyncio.Event()
        event.set()

    async def wait_change(self, version: int, timeout_s: float) -> bool:
        if self.version != version:
            return True
        event = self._changed
        if event is None:
            await asyncio.sleep(TICK_S)
            return False
        try:
            await asyncio.wait_for(event.wait(), timeout_s)
            return True
        except asyncio.TimeoutError:
            return False

    def build_state(self) -> dict:
        run = self.manager.run
        state = {"bench": self.bench_label, "plans": self.plans, "totals": self.totals,
                 "selections": self.selections, "warm": self.warm, "run": None,
                 "history": self.history.rows()}
        if run is None:                       # a station (re)started: the last unit stays
            state["run"] = self._last_unit(state["history"])
            return state
        for row in state["history"]:          # a running record's unit is still in its journal
            if run.record_dir is not None and row["record"] == run.record_dir.name:
                row["unit"] = row["unit"] or run.unit_serial
        record = run.follower.data if run.follower is not None else None
        phase = ("starting" if run.alive and record is None else
                 "stopping" if run.alive and run.stop_requested_s is not None else
                 "running" if run.alive else "finished")
        out = self._empty_run(run.unit_serial, run.sources, phase) | {
            "exit_status": run.exit_status}
        if record is not None:
            out.update(self._record_view(record, run.record_dir, run.alive,
                                         run.follower.events))
        elif not run.alive and run.stop_requested_s is not None:
            out["alerts"] = [{"kind": "stopped-before-start",
                              "text": "Stopped before the run began: nothing was sent to the "
                                      "drive and no record was made.", "detail": ""}]
        elif not run.alive:
            out["alerts"] = [{"kind": "not-started",
                              "text": "The run did not start: nothing was sent to the drive. "
                                      "Call the bench engineer with this message.",
                              "detail": " / ".join(self.manager.log_tail())}]
        state["run"] = out
        return state

    @staticmethod
    def _empty_run(unit: str | None, plans: list[str], phase: str) -> dict:
        return {"unit": unit, "plans": plans, "phase": phase, "exit_status": None,
                "record": None, "status": None, "status_text": None, "progress": [],
                "verdicts": [], "alerts": [], "prompts": [], "plot": None, "final": None,
                "links": None}

    def _last_unit(self, history: list[dict]) -> dict | None:
        """The newest finished record under the record root, shown as the last unit."""
        row = next((r for r in history if r.get("overall") is not None), None)
        if row is None:
            return None
        cached = self._last_cache.get(row["record"])
        if cached is None:
            folder = self.manager.record_root / row["record"]
            record = read_record(folder)
            if record is None:
                return None
            cached = self._empty_run(row["unit"], row["plans"], "finished") | \
                self._record_view(record, folder, False, [])
            self._last_cache = {row["record"]: cached}
        return cached | {"links": {"record": f"/records/{row['record']}/record.json",
                                   "pdf": f"/records/{row['record']}/report.pdf"
                                   if row["report"] else None}}

    def _record_view(self, record: dict, folder: Path, alive: bool, events: list[dict]) -> dict:
        """What the page shows of one record (running or finished)."""
        totals = {name: self.totals.get(name) for name in
                  ((record.get("run") or {}).get("selection") or {}).get("sources", [])} \
            if self.totals else None
        out = {"record": folder.name, "record_id": record.get("record_id"),
               "status": record.get("status"),
               "status_text": view.OPERATOR_STATUS.get(record.get("status")),
               "drive": view.drive_identity(record),
               "progress": view.progress(record, totals), "verdicts": view.verdicts(record),
               "alerts": view.alerts(record),
               "prompts": view.prompts(record) if alive else []}
        index = view.latest_plot_index(record)
        if index is not None:
            key = (folder.name, index)
            if key not in self.plot_cache:
                self.plot_cache = {key: point_svg(record["tests"][index], folder)}
                self.plot_ready_s[f"{folder.name}/{index}"] = time.time()
            test_id = record["tests"][index]["test_id"]
            seen = next((e["seen_s"] for e in events if e.get("event") == "test"
                         and e["entry"]["test_id"] == test_id), None)
            out["plot"] = {"url": f"/plot/{folder.name}/{index}.svg",
                           "test": view.short_name(test_id), "index": index,
                           "capture": (record["tests"][index].get("capture") or {}).get("file"),
                           "entry_seen_s": seen,
                           "rendered_s": self.plot_ready_s.get(f"{folder.name}/{index}")}
        if record.get("status") != "running" and not alive:
            out["final"] = view.final_statement(record, folder)
        out["links"] = {"record": f"/records/{folder.name}/record.json",
                        "pdf": f"/records/{folder.name}/report.pdf"
                        if (folder / "report.pdf").exists() else None}
        return out


def create_app(station: Station, token: str | None = None, *, address: tuple[str, int],
               allow_hosts: tuple[str, ...] = ()) -> StationGuard:
    """The ASGI application of one station served at ``address`` (host, port) behind its
    guard (``hil.station.guard``; ``allow_hosts``: further names of that address); ``token``:
    the access token, required on every request when set."""
    page_tokens = PageTokens()
    index_html = (STATIC / "index.html").read_text(encoding="utf-8")

    async def page(request: Request) -> Response:
        meta = f'<meta name="{CSRF_META}" content="{page_tokens.issue()}">'
        return Response(index_html.replace("<head>", "<head>\n" + meta, 1),
                        media_type="text/html", headers={"Cache-Control": "no-store"})

    async def state(request: Request) -> Response:
        return JSONResponse(station.state)

    async def events(request: Request) -> Response:
        async def stream():
            version, quiet_s = -1, 0.0
            while not station.shutting_down():     # ends so the server can stop at once
                if await station.wait_change(version, 1.0):
                    version, quiet_s = station.version, 0.0
                    yield f"data: {json.dumps(station.state)}\n\n"
                else:
                    quiet_s += 1.0
                    if quiet_s >= KEEPALIVE_S:
                        quiet_s = 0.0
                        yield ": keep-alive\n\n"
        return StreamingResponse(stream(), media_type="text/event-stream",
                                 headers={"Cache-Control": "no-store"})

    async def start(request: Request) -> Response:
        body = await _json_body(request)
        if isinstance(body, Response):
            return body
        try:
            await asyncio.to_thread(
                station.manager.start, str(body.get("unit") or ""),
                [str(name) for name in body.get("plans") or []], station.plans,
                (str(body["operator"]).strip() or None) if body.get("operator") else None)
        except Refused as exc:
            return JSONResponse({"refused": str(exc)}, status_code=409)
        station.touch()
        return JSONResponse({"started": True})

    async def stop(request: Request) -> Response:
        body = await _json_body(request)
        if isinstance(body, Response):
            return body
        try:
            await asyncio.to_thread(station.manager.stop)
        except Refused as exc:
            return JSONResponse({"refused": str(exc)}, status_code=409)
        station.touch()
        return JSONResponse({"stopping": True})

    async def answer(request: Request) -> Response:
        body = await _json_body(request)
        if isinstance(body, Response):
            return body
        try:
            station.manager.answer(str(body.get("key") or ""), body.get("answer"))
        except Refused as exc:
            return JSONResponse({"refused": str(exc)}, status_code=409)
        station.touch()
        return JSONResponse({"answered": True})

    async def plot(request: Request) -> Response:
        key = (request.path_params["record"], int(request.path_params["index"]))
        data = station.plot_cache.get(key)
        if data is None:
            folder = _record_folder(station, key[0])
            record = view_record(folder)
            if record is None or not 0 <= key[1] < len(record["tests"]):
                return PlainTextResponse("no such point", status_code=404)
            data = await asyncio.to_thread(point_svg, record["tests"][key[1]], folder)
        return Response(data, media_type="image/svg+xml",
                        headers={"Cache-Control": "private, max-age=3600"})

    async def record_file(request: Request) -> Response:
        folder = _record_folder(station, request.path_params["record"])
        name = request.path_params["file"]
        if folder is None or name not in ("record.json", "report.pdf") \
                or not (folder / name).is_file():
            return PlainTextResponse("not found", status_code=404)
        return FileResponse(folder / name, media_type="application/pdf"
                            if name.endswith(".pdf") else "application/json")

    @contextlib.asynccontextmanager
    async def lifespan(app):
        task = asyncio.create_task(station.run_ticker())
        try:
            yield
        finally:
            task.cancel()
            await asyncio.to_thread(station.manager.close)

    routes = [Route("/", page), Route("/api/state", state), Route("/api/events", events),
              Route("/api/start", start, methods=["POST"]),
              Route("/api/stop", stop, methods=["POST"]),
              Route("/api/answer", answer, methods=["POST"]),
              Route("/plot/{record}/{index:int}.svg", plot),
              Route("/records/{record}/{file}", record_file),
              Mount("/static", StaticFiles(directory=STATIC), name="static")]
    app = Starlette(routes=routes, lifespan=lifespan)
    return StationGuard(TokenGate(app, token) if token else app,
                        allowed_hosts(*address, allow_hosts), page_tokens)


def view_record(folder: Path | None) -> dict | None:
    return read_record(folder) if folder is not None else None


def _record_folder(station: Station, name: str) -> Path | None:
    """A record folder directly under the station's record root, else None (no ``..``)."""
    if not RECORD_NAME.match(name or ""):
        return None
    folder = station.manager.record_root / name
    return folder if folder.is_dir() else None


async def _json_body(request: Request) -> dict | Response:
    if request.headers.get("content-type", "").split(";")[0].strip() != "application/json":
        return JSONResponse({"refused": "requests must be application/json"}, status_code=415)
    try:
        body = await request.json()
    except (json.JSONDecodeError, UnicodeDecodeError):
        return JSONResponse({"refused": "the request is not valid JSON"}, status_code=400)
    if not isinstance(body, dict):
        return JSONResponse({"refused": "the request must be a JSON object"}, status_code=400)
    return body


class TokenGate:
    """ASGI middleware: every HTTP request needs the station's access token (query ``token``,
    then a cookie, or ``Authorization: Bearer``)."""

    def __init__(self, app, token: str) -> None:
        self.app, self.token = app, token

    async def __call__(self, scope, receive, send) -> None:
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        request = Request(scope)
        given = (request.query_params.get("token") or request.cookies.get(TOKEN_COOKIE)
                 or request.headers.get("authorization", "").removeprefix("Bearer ").strip())
        if not given or not secrets.compare_digest(given, self.token):
            response = PlainTextResponse("hil station: access token required (open the URL "
                                         "the station printed)", status_code=401)
            return await response(scope, receive, send)
        if request.query_params.get("token"):
            async def send_with_cookie(message):
                if message["type"] == "http.response.start":
                    message.setdefault("headers", [])
                    message["headers"] = list(message["headers"]) + [
                        (b"set-cookie", f"{TOKEN_COOKIE}={self.token}; HttpOnly; "
                                        f"SameSite=Strict; Path=/".encode())]
                await send(message)
            return await self.app(scope, receive, send_with_cookie)
        return await self.app(scope, receive, send)
