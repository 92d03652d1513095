// ripple-hil station page: renders the state the server pushes (server-sent events) and sends
// Start / Stop / answers as JSON POSTs. No library, no build step; plots are PNGs from the server.
"use strict";
const $ = (id) => document.getElementById(id);
window.stationState = null;
window.plotLoads = {};          // plot URL -> Date.now() when the browser finished loading it
window.plotInfo = {};           // plot URL -> the state's plot entry (timing of the point)

function text(tag, content, cls) {
  const node = document.createElement(tag);
  node.textContent = content == null ? "" : String(content);
  if (cls) node.className = cls;
  return node;
}

function row(cells) {
  const tr = document.createElement("tr");
  for (const cell of cells) {
    const td = document.createElement("td");
    if (cell instanceof Node) td.appendChild(cell); else td.textContent = cell == null ? "" : String(cell);
    tr.appendChild(td);
  }
  return tr;
}

function link(href, label) {
  const a = text("a", label); a.href = href; a.target = "_blank"; return a;
}

async function post(path, body) {
  const token = document.querySelector('meta[name="hil-csrf"]');   // this page's token
  const response = await fetch(path, {method: "POST", body: JSON.stringify(body || {}),
                                      headers: {"Content-Type": "application/json",
                                                "X-HIL-CSRF": token ? token.content : ""}});
  const answer = await response.json().catch(() => ({}));
  $("message").textContent = response.ok ? "" : (answer.refused || ("refused: HTTP " + response.status));
  // a refusal holds for the bench as it was then: the next change of run clears it (issue 32)
  window.refusedFor = response.ok ? null : runKey(window.stationState);
  return response.ok;
}

function runKey(state) {
  const run = state && state.run;
  return run ? [run.phase, run.record, run.unit].join("|") : "";
}

function renderPlans(state) {
  const box = $("plans");
  if (box.dataset.filled) return;
  for (const name of state.plans) {
    const label = document.createElement("label");
    const box1 = document.createElement("input");
    box1.type = "checkbox"; box1.name = "plan"; box1.value = name; box1.id = "plan-" + name;
    label.appendChild(box1); label.appendChild(document.createTextNode(" " + name));
    box.appendChild(label);
  }
  for (const [name, chosen] of Object.entries(state.selections || {})) {
    const button = text("button", name); button.type = "button"; button.className = "selection";
    button.onclick = () => {
      for (const item of document.querySelectorAll("input[name=plan]")) item.checked = chosen.includes(item.value);
    };
    box.appendChild(button);
  }
  box.dataset.filled = "1";
}

function renderRun(run, totals) {
  $("run").hidden = !run;
  // Start stays pressable while a run goes on: the station refuses it and the page says why.
  $("stop").disabled = !(run && (run.phase === "running" || run.phase === "starting"));
  if (!run) return;
  $("run-unit").textContent = run.unit;
  $("drive").textContent = run.drive ? "on the bench: " + run.drive : "";
  $("phase").textContent = run.status_text && run.status_text !== run.phase
    ? run.phase + " (" + run.status_text + ")" : run.phase;
  const alerts = $("alerts"); alerts.replaceChildren();
  for (const alert of run.alerts) {
    const div = text("div", alert.text, "alert"); div.dataset.kind = alert.kind;
    if (alert.detail) div.appendChild(text("small", alert.detail));
    alerts.appendChild(div);
  }
  renderPrompts(run.prompts);
  const body = $("progress").tBodies[0]; body.replaceChildren();
  for (const p of run.progress) {
    body.appendChild(row([p.source, p.done + " / " + (p.total == null ? "?" : p.total), p.passed, p.bad, p.not_run]));
  }
  if (run.plot) {
    $("plot-box").hidden = false;
    const url = run.plot.url;
    if ($("plot").dataset.url !== url) {
      $("plot").dataset.url = url;
      window.plotInfo[url] = run.plot;
      $("plot").onload = () => { window.plotLoads[url] = Date.now(); };
      $("plot").src = url;
      $("plot-caption").textContent = "last analysed point: " + run.plot.test;
    }
  }
  const verdicts = $("verdicts").tBodies[0]; verdicts.replaceChildren();
  for (const v of run.verdicts.slice().reverse()) {
    verdicts.appendChild(row([v.test, text("span", v.outcome, "outcome-" + v.outcome),
                             v.decision || "—", v.detail + (v.requirements.length ? " | " + v.requirements.join(", ") : "")]));
  }
  $("final").hidden = !run.final;
  if (run.final) {
    // the banner is conformity to the requirements; page 1's overall line is in the table
    const banner = run.final.banner || {text: run.final.overall_line, tone: run.final.overall};
    $("overall").textContent = banner.text;
    $("overall").className = banner.tone;
    const table = $("statements"); table.replaceChildren();
    table.appendChild(row(["Overall (page 1)", run.final.overall_line]));
    for (const [key, value] of run.final.lines) table.appendChild(row([key, value]));
  }
  const links = $("links"); links.replaceChildren();
  if (run.links) {
    links.appendChild(link(run.links.record, "record (record.json)"));
    if (run.links.pdf) { links.appendChild(document.createTextNode(" · ")); links.appendChild(link(run.links.pdf, "PDF report")); }
    else if (run.final) links.appendChild(document.createTextNode(" · PDF report being written…"));
  }
}

function renderPrompts(prompts) {
  const box = $("prompts");
  const keys = prompts.map((p) => p.key).join(",");
  if (box.dataset.keys === keys) return;          // keep what the operator is typing
  box.dataset.keys = keys; box.replaceChildren();
  for (const p of prompts) {
    const div = text("div", p.text + " ", "prompt"); div.dataset.key = p.key;
    let input = null;
    if (p.kind === "ask") {
      input = document.createElement("input"); input.id = "answer-" + p.key;
      if (p.default != null) input.value = p.default;
      div.appendChild(input);
    }
    const button = text("button", p.kind === "ask" ? "Send" : "Continue");
    button.id = "answer-button-" + p.key;
    button.onclick = () => post("/api/answer", {key: p.key, answer: input ? input.value : "continue"});
    div.appendChild(button);
    box.appendChild(div);
  }
}

function renderHistory(rows) {
  const body = $("history").tBodies[0]; body.replaceChildren();
  for (const h of rows) {
    const files = document.createElement("span");
    files.appendChild(link("/records/" + h.record + "/record.json", "record"));
    if (h.report) { files.appendChild(document.createTextNode(" · ")); files.appendChild(link("/records/" + h.record + "/report.pdf", "PDF")); }
    body.appendChild(row([h.started_utc, h.unit || "—", h.plans.join(", "), h.status_text, h.overall || "—", files]));
  }
}

function render(state) {
  if (window.refusedFor != null && runKey(state) !== window.refusedFor) {
    $("message").textContent = ""; window.refusedFor = null;
  }
  window.stationState = state;
  $("bench").textContent = state.bench;
  $("station-error").hidden = !state.station_error;
  $("station-error").textContent = state.station_error ? "Station display problem (the run is not affected): " + state.station_error : "";
  renderPlans(state);
  renderRun(state.run, state.totals);
  renderHistory(state.history);
}

$("start").onclick = () => {
  const plans = [...document.querySelectorAll("input[name=plan]:checked")].map((b) => b.value);
  post("/api/start", {unit: $("unit").value, plans: plans, operator: $("operator").value});
};
$("stop").onclick = () => post("/api/stop", {});
$("unit").addEventListener("keydown", (e) => { if (e.key === "Enter") $("start").focus(); });

function connect() {
  const source = new EventSource("/api/events");
  source.onopen = () => { $("connection").textContent = "live"; };
  source.onmessage = (e) => render(JSON.parse(e.data));
  source.onerror = () => { $("connection").textContent = "reconnecting…"; };
}
connect();
