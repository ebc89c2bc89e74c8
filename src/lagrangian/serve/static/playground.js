// The playground page: edit a model file, see its equations, analysis and motion. Every number and
// every formula comes from the server's API (the same library functions as the CLI).
"use strict";

const $ = (id) => document.getElementById(id);
const CHECK_DELAY = 350;     // ms after the last keystroke before the model is checked
const RUN_DELAY = 200;       // ms after the last slider move before the simulation runs again

const state = {
  name: "model",
  derived: null,        // the JSON of `derive --json` of the last good model
  analysis: null,       // /api/analysis of the last good model
  goodText: null,       // the text of the last good model
  simulation: null,     // the last trajectory (JSON)
  lastRequest: null,    // the body of the last simulation request
  values: {},           // slider values by name, kept across edits
  given: new Set(),     // the initial values sent: the model file's and those the user set; the
                        // simulation completes the others (0, or from the constraints)
  checkSeq: 0, simSeq: 0, eqSeq: 0,
  playing: true, playStart: 0, playFrom: 0,
  busy: new Map(),      // what is running -> start time
  signals: {},          // input name -> a measured signal read from the user's CSV in the browser:
                        // {t, values, interpolation, label}, sent as data (the server reads no file)
};

// ------------------------------------------------------------------ status line
function setBusy(key, text) {
  state.busy.set(key, { text, start: performance.now() });
  showStatus();
}
function setDone(key) { state.busy.delete(key); showStatus(); }
function showStatus(failure) {
  const box = $("status"), label = $("status-text");
  if (failure) { box.className = "failed"; label.textContent = failure; return; }
  if (state.busy.size === 0) { box.className = ""; label.textContent = "Ready"; return; }
  box.className = "busy";
  const now = performance.now();
  label.textContent = [...state.busy.values()].map((b) => {
    const s = (now - b.start) / 1000;
    return s >= 1 ? `${b.text} ${s.toFixed(0)} s` : b.text;
  }).join(" · ");
}
setInterval(() => { if (state.busy.size) showStatus(); }, 500);

// ------------------------------------------------------------------ API
// Every body is JSON (the server refuses other content types from a page): a request object, or
// the model text as {"model": text} where the endpoint takes the text (json false).
async function api(path, body, json) {
  let response;
  try {
    response = await fetch(path, {
      method: "POST", body: JSON.stringify(json ? body : { model: body }),
      headers: { "Content-Type": "application/json" },
    });
  } catch (err) {
    return { status: 0, data: { errors: [{ line: null, message: `The server does not answer (${err.message}): is lagrangian serve still running?` }] } };
  }
  const type = response.headers.get("Content-Type") || "";
  const data = type.startsWith("application/json") ? await response.json() : await response.blob();
  return { status: response.status, data, warnings: response.headers.get("X-Lagrangian-Warnings") };
}

function errorText(data) {
  return (data && data.errors ? data.errors : [{ message: String(data) }]).map((e) => e.message).join("\n");
}

// ------------------------------------------------------------------ the editor and the check
const editor = new LgEditor($("source"), $("highlight"), $("gutter"), () => scheduleCheck());
let checkTimer = null;
function scheduleCheck() {
  $("check-state").textContent = "editing…";
  $("check-state").className = "check-state";
  clearTimeout(checkTimer);
  checkTimer = setTimeout(check, CHECK_DELAY);
}

function showErrors(errors) {
  editor.setErrors(errors);
  const list = $("errors");
  list.innerHTML = "";
  for (const e of errors) {
    const li = document.createElement("li");
    const where = e.line != null ? `line ${e.line}` + (e.key ? ` [${e.key}]` : "") : (e.key ? `[${e.key}]` : "");
    li.innerHTML = (where ? `<span class="where">${lgEscape(where)}:</span> ` : "") + lgEscape(e.message);
    li.dataset.line = e.line == null ? "" : String(e.line);
    if (e.line != null) li.addEventListener("click", () => editor.goToLine(e.line));
    list.appendChild(li);
  }
}

function markStale(stale) {
  for (const id of ["equations-math", "diagnosis-math", "derivation-math", "equilibria-math", "mechanism"]) {
    $(id).classList.toggle("stale", stale);
  }
}

async function check() {
  const text = editor.text, seq = ++state.checkSeq;
  setBusy("check", "Deriving…");
  const r = await api("/api/derive", text, false);
  setDone("check");
  if (seq !== state.checkSeq) return;  // a newer edit is being checked
  if (r.status === 0) { showStatus(errorText(r.data)); return; }
  if (r.status !== 200) {
    const errors = r.data.errors || [{ line: null, message: String(r.data) }];
    showErrors(errors);
    const n = errors.length;
    $("check-state").textContent = `${n} problem${n === 1 ? "" : "s"}: the results below are of the last valid model`;
    $("check-state").className = "check-state bad";
    markStale(true);
    return;
  }
  showErrors([]);
  $("check-state").textContent = "valid";
  $("check-state").className = "check-state ok";
  markStale(false);
  state.derived = r.data;
  state.goodText = text;
  state.name = r.data.name;
  $("model-name").textContent = r.data.name;
  $("equations-text").textContent = r.data.equations.map((e, k) => `E${k + 1} = ${e} = 0`).join("\n");
  $("equations-text").dataset.equations = JSON.stringify(r.data.equations);
  await analyse(text, seq);
}

async function analyse(text, seq) {
  setBusy("analysis", "Writing the equations…");
  const r = await api("/api/analysis", text, false);
  setDone("analysis");
  if (seq !== state.checkSeq) return;
  if (r.status !== 200) { showStatus(errorText(r.data)); return; }
  state.analysis = r.data;
  const pick = (keys) => r.data.sections.filter((s) => keys.includes(s.key));
  renderSections($("equations-math"), pick(["energies", "lagrangian", "equations", "matrix-form"]));
  renderSections($("diagnosis-math"), pick(["singularities"]));
  renderSections($("derivation-math"), r.data.sections);
  buildControls(r.data);
  equilibria();
  if ($("auto-run").checked) simulate();
}

function renderSections(box, sections) {
  box.innerHTML = sections.map((s) => `<section data-key="${s.key}"><h2>${lgEscape(s.title)}</h2>${s.html}</section>`).join("");
}

// ------------------------------------------------------------------ sliders and fields
function sliderRange(value, kind) {
  const v = Number(value) || 0, a = Math.abs(v);
  if (kind === "param") return v > 0 ? [0, 2 * v] : v < 0 ? [2 * v, 0] : [-1, 1];
  const half = kind === "q" ? Math.max(Math.PI, 2 * a) : Math.max(5, 2 * a);
  return [-half, half];
}

function addSlider(box, name, value, kind) {
  const [lo, hi] = sliderRange(value, kind);
  const row = document.createElement("div");
  row.className = "slider";
  row.innerHTML = `<label for="slider-${name}" title="${lgEscape(name)}">${lgEscape(name)}</label>` +
    `<input type="range" id="slider-${name}" min="${lo}" max="${hi}" step="${(hi - lo) / 400}" value="${value}">` +
    `<input type="number" id="value-${name}" step="any" value="${value}" aria-label="${lgEscape(name)}">`;
  box.appendChild(row);
  const range = row.children[1], number = row.children[2];
  if (kind !== "param") row.classList.toggle("computed", !state.given.has(name));
  const set = (v, from) => {
    if (!isFinite(v)) return;
    state.values[name] = v;
    if (kind !== "param") { state.given.add(name); row.classList.remove("computed"); }
    if (from !== number) number.value = String(+v.toPrecision(6));
    if (from !== range) {
      if (v < Number(range.min)) range.min = String(v);
      if (v > Number(range.max)) range.max = String(v);
      range.value = String(v);
    }
    scheduleRun(kind === "param");
  };
  range.addEventListener("input", () => set(Number(range.value), range));
  number.addEventListener("change", () => set(Number(number.value), number));
}

// An initial value the simulation completed (not given): shown, not sent.
function showComputed(name, v) {
  const range = $(`slider-${name}`), number = $(`value-${name}`);
  if (!range || !isFinite(v)) return;
  state.values[name] = v;
  number.value = String(+v.toPrecision(6));
  if (v < Number(range.min)) range.min = String(v);
  if (v > Number(range.max)) range.max = String(v);
  range.value = String(v);
}

function buildControls(a) {
  const box = $("sliders");
  const sim = a.simulation || {};
  const key = JSON.stringify([a.name, a.coordinates, Object.keys(a.parameters), a.inputs]);
  if (box.dataset.key === key) return;  // the same names: keep what the user set
  box.dataset.key = key;
  box.innerHTML = "";
  state.values = {};
  state.given = new Set(a.given);
  if (sim.t_end != null) $("t-end").value = sim.t_end;
  $("dt").value = sim.dt != null ? sim.dt : 0.01;
  const group = (text) => {
    const div = document.createElement("div"), h = document.createElement("h3");
    h.textContent = text; div.appendChild(h); box.appendChild(div);
    return div;
  };
  const params = Object.entries(a.parameters);
  const pbox = params.length ? group("Parameters") : null;
  for (const [name, value] of params) { state.values[name] = value; addSlider(pbox, name, value, "param"); }
  const ibox = group("Initial values");
  const hint = document.createElement("p");
  hint.className = "note";
  hint.textContent = "Grey: not given, completed by the simulation (0, or from the constraints); move one to give it.";
  ibox.appendChild(hint);
  const initial = sim.initial || {};
  for (const name of [...a.coordinates, ...a.velocities]) {
    const v = initial[name] || 0;
    state.values[name] = v;
    addSlider(ibox, name, v, a.coordinates.includes(name) ? "q" : "qdot");
  }
  state.signals = {};
  if (a.inputs.length) {
    const ubox = group("Inputs (expressions of t, feedback laws of the state, or a measured signal from a CSV)");
    for (const name of a.inputs) {
      const value = (sim.inputs || {})[name];
      const row = document.createElement("div");
      row.className = "slider input-row";
      row.innerHTML = `<label for="input-${name}">${lgEscape(name)}</label><input type="text" id="input-${name}" value="${lgEscape(value == null ? "0" : String(value))}">`
        + `<label class="signal-file" title="a CSV: a header row, time in the column t (or time, or the first), the values in the column ${lgEscape(name)} (or the second)">CSV…<input type="file" accept=".csv,text/csv" id="signal-${name}" hidden></label>`;
      ubox.appendChild(row);
      row.children[1].addEventListener("change", () => { delete state.signals[name]; scheduleRun(false); });
      $(`signal-${name}`).addEventListener("change", (e) => readSignal(name, e.target.files[0]));
    }
  }
}

// A measured signal: the user's CSV read here, in the browser, and sent as numbers.
function parseSignalCsv(text, name) {
  const lines = text.split(/\r?\n/).map((l) => l.trim()).filter((l) => l && !l.startsWith("#"));
  if (lines.length < 3) throw new Error("expected a header row and at least two rows of numbers");
  const header = lines[0].split(",").map((h) => h.trim());
  let ti = header.findIndex((h) => h === "t" || h.toLowerCase() === "time");
  if (ti < 0) ti = 0;
  let vi = header.indexOf(name);
  if (vi < 0) vi = header.findIndex((h, k) => k !== ti);
  if (vi < 0) throw new Error(`no column of values beside the time column '${header[ti]}'`);
  const t = [], values = [];
  for (let k = 1; k < lines.length; k++) {
    const cells = lines[k].split(",");
    const a = Number(cells[ti]), b = Number(cells[vi]);
    if (cells.length !== header.length || !Number.isFinite(a) || !Number.isFinite(b)) {
      throw new Error(`row ${k + 1}: expected ${header.length} numbers, got '${lines[k].slice(0, 60)}'`);
    }
    t.push(a); values.push(b);
  }
  return { t, values, column: header[vi] };
}

function readSignal(name, file) {
  if (!file) return;
  const box = $(`input-${name}`);
  file.text().then((text) => {
    try {
      const sig = parseSignalCsv(text, name);
      state.signals[name] = { t: sig.t, values: sig.values, interpolation: "linear" };
      box.value = `@${file.name}:${sig.column} (${sig.t.length} samples, linear)`;
      box.classList.add("signal");
      scheduleRun(false);
    } catch (err) {
      $("sim-info").textContent = `${file.name}: ${err.message}`;
      $("sim-info").className = "note bad";
    }
  });
}

function simulationRequest() {
  const a = state.analysis, v = state.values;
  const pick = (names) => Object.fromEntries(names.filter((n) => n in v).map((n) => [n, v[n]]));
  const inputs = {};
  for (const name of a.inputs) inputs[name] = state.signals[name] || $(`input-${name}`).value.trim() || "0";
  return {
    model: state.goodText,
    t_end: Number($("t-end").value),
    dt: Number($("dt").value),
    initial: pick([...a.coordinates, ...a.velocities].filter((n) => state.given.has(n))),
    params: pick(Object.keys(a.parameters)),
    inputs,
  };
}

let runTimer = null, eqTimer = null;
function scheduleRun(paramsChanged) {
  if ($("auto-run").checked) { clearTimeout(runTimer); runTimer = setTimeout(simulate, RUN_DELAY); }
  if (paramsChanged) { clearTimeout(eqTimer); eqTimer = setTimeout(equilibria, 600); }
}

// ------------------------------------------------------------------ equilibria and modes
async function equilibria() {
  if (!state.analysis) return;
  const seq = ++state.eqSeq;
  const a = state.analysis;
  const params = Object.fromEntries(Object.keys(a.parameters).filter((n) => n in state.values).map((n) => [n, state.values[n]]));
  setBusy("equilibria", "Finding the equilibria…");
  const r = await api("/api/equilibria", { model: state.goodText, params }, true);
  setDone("equilibria");
  if (seq !== state.eqSeq) return;
  const box = $("equilibria-math");
  box.innerHTML = r.status === 200 ? `<section data-key="equilibria">${r.data.html}</section>`
    : `<p class="note bad">${lgEscape(errorText(r.data))}</p>`;
}

// ------------------------------------------------------------------ simulation
async function simulate() {
  if (!state.analysis || !state.goodText) return;
  const body = simulationRequest(), seq = ++state.simSeq;
  const first = state.simulation === null;
  setBusy("simulate", first ? "Simulating (a new model is compiled first: about a second; the very first run on this machine compiles the integrators, about 10 s)…" : "Simulating…");
  $("run").disabled = true;
  const r = await api("/api/simulate", body, true);
  setDone("simulate");
  $("run").disabled = false;
  if (seq !== state.simSeq) return;
  if (r.status !== 200) {
    $("sim-info").textContent = errorText(r.data);
    $("sim-info").className = "note bad";
    $("mechanism").classList.add("stale");
    return;
  }
  state.simulation = r.data;
  state.lastRequest = body;
  const s = r.data;
  for (const name of [...state.analysis.coordinates, ...state.analysis.velocities]) {
    if (!(name in body.initial) && s.columns[name]) showComputed(name, s.columns[name][0]);
  }
  const drift = s.energy_drift != null && s.conservative ? `; ${s.energy_name} drift ${s.energy_drift.toExponential(2)}` : "";
  $("sim-info").textContent = `${s.columns.t.length} samples, t = 0 … ${s.columns.t[s.columns.t.length - 1]} s (${s.stats.method}, ${s.stats.backend}, ${s.stats.nfev} evaluations)${drift}`;
  $("sim-info").className = "note";
  $("mechanism").classList.remove("stale");
  showTrajectory(s);
}

const mechanism = new LgMechanism($("mechanism"));
const plots = { q: new LgPlot($("plot-q")), qdot: new LgPlot($("plot-qdot")), energy: new LgPlot($("plot-energy")) };

function showTrajectory(s) {
  const t = s.columns.t, n = s.state_names.length / 2;
  const series = (names) => names.map((name) => ({ name, values: s.columns[name] }));
  plots.q.set(t, series(s.state_names.slice(0, n)), "coordinates");
  plots.qdot.set(t, series(s.state_names.slice(n)), "velocities");
  if (s.energy_name) {
    const title = (s.energy_name === "energy" ? "energy T* + V" : "Jacobi integral h") +
      (s.conservative && s.energy_drift != null ? ` (drift ${s.energy_drift.toExponential(1)})` : "");
    plots.energy.set(t, series([s.energy_name]), title, 0.02);
  }
  else plots.energy.clear("No energy: L depends explicitly on t.");
  const note = $("not-drawable");
  if (s.geometry) {
    note.hidden = true;
    $("mechanism").hidden = false;
    mechanism.set(s.geometry);
    state.playFrom = 0;
    state.playStart = performance.now();
    $("scrub").max = String(s.geometry.t.length - 1);
    drawFrame(0);
  } else {
    mechanism.geometry = null;
    $("mechanism").hidden = true;
    note.hidden = false;
    note.textContent = s.not_drawable;
    $("scrub").max = "0";
  }
}

function drawFrame(k) {
  const g = mechanism.geometry;
  if (!g) return;
  mechanism.draw(k);
  $("scrub").value = String(k);
  $("time-label").textContent = `t = ${g.t[k].toFixed(2)} s`;
  for (const p of Object.values(plots)) p.draw(g.t[k]);
}

function tick(now) {
  const g = mechanism.geometry;
  if (g && state.playing && g.t.length > 1) {
    const speed = Number($("speed").value), end = g.t[g.t.length - 1];
    let t = state.playFrom + (now - state.playStart) / 1000 * speed;
    if (t > end + 0.5 * speed) { state.playFrom = 0; state.playStart = now; t = 0; }  // loop, after a short rest
    drawFrame(mechanism.frameAt(Math.min(t, end)));
  }
  requestAnimationFrame(tick);
}
requestAnimationFrame(tick);

function setPlaying(on) {
  state.playing = on;
  $("play").textContent = on ? "pause" : "play";
  const g = mechanism.geometry;
  if (on && g) { state.playFrom = g.t[Number($("scrub").value)] || 0; state.playStart = performance.now(); }
}
$("play").addEventListener("click", () => setPlaying(!state.playing));
$("scrub").addEventListener("input", () => { setPlaying(false); drawFrame(Number($("scrub").value)); });
$("speed").addEventListener("change", () => setPlaying(state.playing));
$("run").addEventListener("click", simulate);
for (const id of ["t-end", "dt"]) $(id).addEventListener("change", () => scheduleRun(false));

// ------------------------------------------------------------------ tabs
for (const button of document.querySelectorAll(".tabs button")) {
  button.addEventListener("click", () => {
    for (const b of document.querySelectorAll(".tabs button")) b.classList.toggle("active", b === button);
    for (const tab of document.querySelectorAll(".tab")) tab.classList.toggle("active", tab.id === `tab-${button.dataset.tab}`);
    if (button.dataset.tab === "motion" && state.simulation) drawFrame(Number($("scrub").value));
  });
}

// ------------------------------------------------------------------ downloads
function save(blob, name) {
  const url = URL.createObjectURL(blob), a = document.createElement("a");
  a.href = url; a.download = name;
  document.body.appendChild(a); a.click(); a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
}

async function download(path, body, json, name, what) {
  setBusy("download", `Preparing the ${what}…`);
  const r = await api(path, body, json);
  setDone("download");
  if (r.status !== 200) { showStatus(errorText(r.data)); return; }
  save(r.data, name);
  if (r.warnings) showStatus(JSON.parse(r.warnings).join(" "));
}

$("download-model").addEventListener("click", () => save(new Blob([editor.text], { type: "application/toml" }), `${state.name}.toml`));
$("download-csv").addEventListener("click", () => {
  if (!state.lastRequest) { showStatus("Run a simulation first: the CSV is its trajectory."); return; }
  download("/api/simulate?format=csv", state.lastRequest, true, `${state.name}.csv`, "CSV");
});
for (const [id, fmt] of [["download-report", "html"], ["download-report-md", "md"], ["download-report-tex", "tex"]]) {
  $(id).addEventListener("click", () => {
    if (!state.goodText) return;
    download(`/api/report?format=${fmt}`, state.goodText, false, `${state.name}.${fmt}`, "report");
  });
}

$("download-fmu").addEventListener("click", () => {
  if (!state.goodText || !state.analysis) return;
  const r = simulationRequest();
  download("/api/fmu", { model: r.model, params: r.params, initial: r.initial }, true, `${state.name}.fmu`, "FMU");
});

// ------------------------------------------------------------------ examples and start
async function loadExample(name) {
  const response = await fetch(`/api/examples/${encodeURIComponent(name)}`);
  const data = await response.json();
  if (response.status !== 200) { showErrors(data.errors); return; }
  history.replaceState(null, "", `?example=${encodeURIComponent(name)}`);
  state.simulation = null;
  editor.text = data.text;
  check();
}

async function start() {
  const initial = JSON.parse($("initial").textContent);
  const select = $("examples");
  fetch("/api/examples").then((r) => r.json()).then((examples) => {
    for (const [name, description] of Object.entries(examples)) {
      const option = document.createElement("option");
      option.value = name; option.textContent = name; option.title = description;
      select.appendChild(option);
    }
    if (initial.name && examples[initial.name] !== undefined) select.value = initial.name;
  });
  select.addEventListener("change", () => {
    const name = select.value;
    $("chain-size").hidden = !name.endsWith("-<n>");
    if (!name) return;
    loadExample(name.endsWith("-<n>") ? name.replace("<n>", $("chain-n").value) : name);
  });
  $("chain-n").addEventListener("change", () => {
    if (select.value.endsWith("-<n>")) loadExample(select.value.replace("<n>", $("chain-n").value));
  });
  state.name = initial.name || "model";
  $("model-name").textContent = initial.file || initial.name || "";
  editor.text = initial.text || "";
  if (initial.error) { showErrors([{ line: null, message: initial.error }]); showStatus("Ready"); return; }
  check();
}
start();
window.lagrangianPlayground = { state, editor, mechanism };  // for the browser tests and the curious
