// pencilbot studio: the page. It only sends the controls and buttons to the server and shows
// what the server says (server-sent events); nothing of the drawing or driving happens here.
"use strict";

const $ = (id) => document.getElementById(id);
const NUMBERS = ["margin", "pen_width", "line_length", "hatch_coverage", "time_budget"];
// The controls a style sets: each shows the chosen style's value until the person moves it (then
// it is "touched" and sent); an untouched one is sent as null, so the style's own value applies.
const STYLED = ["page", "orientation", "margin", "pen_width", "line_length", "hatch_coverage", "hatch", "face_lines", "time_budget"];
const CHECKS = ["hatch", "face_lines"];  // the styled controls that are check boxes
let state = null, choices = null, shown = {}, sendTimer = null, sending = 0;
let shownPlotMessage = null;  // the plot's message last shown (see showPlot)
let touched = new Set(), applied = "";

async function call(method, url, body, headers = {}) {
  const init = { method, headers: { "X-Studio": "1", ...headers } };
  if (body instanceof Blob) init.body = body;
  else if (body !== undefined) { init.body = JSON.stringify(body); init.headers["Content-Type"] = "application/json"; }
  const response = await fetch(url, init);
  const data = response.headers.get("content-type")?.includes("json") ? await response.json() : {};
  if (!response.ok) throw new Error(data.error || `${response.status} ${response.statusText}`);
  return data;
}

function fill(select, values, chosen, label = (v) => v) {
  for (const value of values) {
    const option = document.createElement("option");
    option.value = typeof value === "object" ? value.port : value;
    option.textContent = typeof value === "object" ? value.title : label(value);
    select.append(option);
  }
  if (chosen !== undefined && chosen !== null) select.value = chosen;
}

function options() {
  const form = $("controls"), values = {};
  for (const name of ["style", "pens", "profile"]) values[name] = form[name].value || null;
  for (const name of STYLED) {
    if (!touched.has(name)) values[name] = null;
    else if (CHECKS.includes(name)) values[name] = form[name].checked;
    else values[name] = NUMBERS.includes(name) ? Number(form[name].value) : form[name].value;
  }
  if (values.line_length !== null && values.line_length < 2) values.line_length = null;  // 0: from the image size
  if (values.page === "custom") values.page = `${Number(form.page_w.value) || 210}x${Number(form.page_h.value) || 297}`;
  return values;
}

function setControl(name, value) {
  const form = $("controls");
  if (CHECKS.includes(name)) form[name].checked = !!value;
  else if (name === "page") {
    const custom = /^([\d.]+)x([\d.]+)$/.exec(value || "");
    form.page.value = custom ? "custom" : value;
    if (custom) { form.page_w.value = custom[1]; form.page_h.value = custom[2]; }
    $("custom-size").hidden = !custom;
  } else form[name].value = name === "line_length" ? value || 0 : value;
}

function showStyleDefaults() {  // the untouched controls show the chosen style's values
  const defaults = choices.style_defaults[$("style").value] || {};
  for (const name of STYLED) if (!touched.has(name)) setControl(name, defaults[name]);
  showOutputs();
}

function applyOptions(values) {  // the server's settings: every tab shows the same ones
  const form = $("controls");
  form.style.value = values.style || choices.style;
  form.pens.value = values.pens || "";
  form.profile.value = values.profile || choices.profile;
  touched = new Set(STYLED.filter((name) => values[name] !== null && values[name] !== undefined && values[name] !== ""));
  for (const name of touched) setControl(name, values[name]);
  showStyleDefaults();
  applied = JSON.stringify(values);
}

function showOutputs() {
  for (const name of NUMBERS) {
    const input = $(name), out = input.parentElement.querySelector("output");
    out.textContent = name === "line_length" && Number(input.value) < 2 ? "auto" : input.value;
  }
}

function controlsChanged(event) {
  let name = event && event.target && event.target.name;
  if (name === "page_w" || name === "page_h") name = "page";
  if (STYLED.includes(name)) touched.add(name);
  if (name === "page") $("custom-size").hidden = $("page").value !== "custom";
  if (event && event.type === "change" && typeof settingsChanged === "function") settingsChanged();
  if (name === "style") showStyleDefaults();
  showOutputs();
  clearTimeout(sendTimer);
  sendTimer = setTimeout(async () => {
    sendTimer = null;
    sending++;
    try { $("plan-error").textContent = ""; await call("POST", "/api/drawing", options()); }
    catch (err) { $("plan-error").textContent = err.message; }
    finally { sending--; }
  }, 30);
}

async function upload(file) {
  $("photo-error").textContent = "";
  $("photo-name").textContent = `uploading ${file.name}…`;
  try {
    await call("PUT", "/api/photo", file, { "X-Filename": file.name });  // the server has the settings already
  } catch (err) {  // the photo in use stays, and says so
    const old = state && state.photo;
    $("photo-error").textContent = `${file.name} was not used: ${err.message}.` +
      (old ? ` The drawing still uses ${old.name || "the earlier photo"}.` : "");
  }
  showPhoto(true);
}

function showPhoto(force = false) {  // the photo in use, as the server says
  const photo = state && state.photo;
  $("photo-name").textContent = !photo ? "" : photo.svg ? `${photo.name || "drawing"}: an SVG drawing of ${photo.width} × ${photo.height} mm`
    : `${photo.name || "photo"}: ${photo.width} × ${photo.height} px`;
  $("photo-name").classList.toggle("kept", !!(photo && $("photo-error").textContent));
  if (photo && (force || shown.photo !== photo.number)) {
    shown.photo = photo.number;
    $("photo").src = `/api/picture/photo.png?n=${photo.number}`;
  }
  $("photo").closest("figure").hidden = !photo || !!photo.svg;
}

function duration(seconds) {
  if (seconds === undefined || seconds === null) return "–";
  const s = Math.round(seconds), h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60);
  return `${h}:${String(m).padStart(2, "0")}:${String(s % 60).padStart(2, "0")}`;
}

function showDrawing() {
  const stages = state.stages, current = state.generation;
  const full = stages.full && stages.full.generation === current ? stages.full : null;
  const coarse = stages.coarse && stages.coarse.generation === current ? stages.coarse : null;
  const best = full || coarse;
  const error = (full && full.error) || (coarse && coarse.error);
  $("plan-error").textContent = error || "";
  const tag = best ? `${best === full ? "full" : "coarse"}-${best.generation}` : "";
  if (best && !error && shown.preview !== tag) {
    const stage = best === full ? "full" : "coarse";
    shown.preview = tag;
    $("preview").src = `/api/picture/${stage}-preview.png?g=${best.generation}`;
    $("sketch").src = `/api/picture/${stage}-sketch.png?g=${best.generation}`;
  }
  const label = $("preview-stage");
  label.className = "stage " + (full ? "full" : coarse ? "coarse" : "");
  label.textContent = !state.photo ? "no photo yet" : full ? `full, ${full.seconds.toFixed(2)} s`
    : coarse ? `coarse, ${coarse.seconds.toFixed(2)} s — planning the full one…` : "planning…";
  label.dataset.generation = best ? best.generation : "";
  const f = full && !full.error ? full.figures : null;
  $("fig-pen-down").textContent = f && f.pen_down_m !== undefined ? `${f.pen_down_m} m` : "…";
  $("fig-pen-up").textContent = f && f.pen_up_m !== undefined ? `${f.pen_up_m} m` : "…";
  $("fig-lifts").textContent = f && f.lifts !== undefined ? f.lifts : "…";
  $("fig-time").textContent = f ? (f.seconds !== undefined ? duration(f.seconds) : f.estimate_error) : "…";
  $("fig-likeness").textContent = f ? (f.likeness === undefined ? "– (a drawing)" : `ρ ${f.likeness}`) : "…";
  $("fig-paths").textContent = f ? `${f.paths} on ${f.page}` : "…";
  // Nothing to show or download yet: no empty picture boxes, no links that give nothing.
  $("sketch").closest("details").hidden = !shown.preview || !!(state.photo && state.photo.svg);
  showProgress(full, coarse);
  sheetDrawing(full && !full.error ? full.generation : 0, best && !error ? shown.preview : "");
  document.querySelector(".downloads").hidden = !f;
  $("dl-sketch").hidden = !!(state.photo && state.photo.svg);  // a drawing has no sketch
  $("plot-start").disabled = !f || !!(plotOf($("port").value) || {}).active;
  $("dl-gcode").href = `/api/download/plan.gcode?profile=${encodeURIComponent($("profile").value)}`;
}

function plotOf(port) { return state && state.plots.find((p) => p.port === port); }

async function showPlot() {
  const plot = plotOf($("port").value);
  const record = plot ? plot.record : {};
  const paused = plot && plot.active && (record.state || "").startsWith("paused");
  const pausedWords = (record.state || "").replace(/^paused: from the keyboard.*/, "paused (Resume goes on)");
  $("plot-status").textContent = !plot ? "idle" : plot.prompt ? "waiting for you" : paused ? pausedWords
    : plot.active ? plotting(record.state) : plot.status;
  $("plot-line").textContent = record.running ? `${record.running} (${record.line} of ${record.total} acknowledged)` : record.line ? `${record.line} of ${record.total}` : "–";
  $("plot-percent").textContent = record.percent !== undefined ? `${record.percent.toFixed(1)} % of plot time` : "–";
  $("plot-elapsed").textContent = duration(plot && plot.active ? Date.now() / 1000 - plot.started : record.elapsed_s);
  $("plot-remaining").textContent = plot && plot.status === "done" ? "0:00:00" : duration(record.eta_s);
  const message = plot ? plot.message : "";
  if (message !== shownPlotMessage) $("plot-message").textContent = shownPlotMessage = message;  // (a machine
  // control's answer stays until the plot has something new to say: every state update wiped it)
  $("pause").disabled = $("stop").disabled = !(plot && plot.active);
  $("pause").textContent = paused && !plot.prompt ? "Resume" : "Pause";
  $("resume-job").hidden = !(plot && plot.resumable && !plot.active);
  for (const b of $("machine").querySelectorAll("button")) b.disabled = !!(plot && plot.active);
  const dialog = $("prompt");
  if (plot && plot.prompt) {
    $("prompt-text").textContent = plot.prompt.text;
    dialog.dataset.prompt = plot.prompt.id;  // the buttons answer this prompt, never a later one
    $("jog").hidden = $("prompt-giveup").hidden = plot.prompt.kind !== "rezero";
    if (!dialog.open) dialog.showModal();
  } else if (dialog.open) dialog.close();
  sheetPlot(plot);
}

function showProgress(full, coarse) {  // the planning steps of the newest change, as the server says
  const p = state.progress || {}, planning = state.photo && !full && !(coarse && coarse.error);
  $("plan-progress-row").hidden = !planning;
  if (!planning) return;
  const now = p.generation === state.generation ? p : null;
  const stage = now ? now.stage : "coarse", step = now ? now.step : 0, of = now ? now.of : 3;
  const done = (stage === "full" ? 0.5 : 0) + 0.5 * (step / of);
  $("plan-progress").value = done;
  $("plan-step").textContent = `${stage === "full" ? "full" : "coarse"} preview: ${now ? now.words : "starting"} (step ${step + 1} of ${of})`;
}

function plotting(machine) {  // the machine's own state word, only when it says more than "plotting"
  const said = { Hold: "holding", Jog: "jogging", Home: "homing", Door: "door open", Alarm: "alarm", Check: "checking" };
  const word = (machine || "").split(":")[0];
  return !machine ? "starting" : said[word] ? `plotting (${said[word]})` : "plotting";
}

function render() { showPhoto(); showDrawing(); showPlot(); }

async function plotButton(button, extra = {}) {
  try { await call("POST", `/api/plot/${button}`, { port: $("port").value, ...extra }); }
  catch (err) { $("plot-message").textContent = err.message; }
}

function listen() {
  const events = new EventSource("/api/events");
  events.onopen = () => { $("connection").textContent = "connected"; };
  events.onerror = () => { $("connection").textContent = "reconnecting…"; };
  events.onmessage = (event) => {
    state = JSON.parse(event.data);
    // Another tab's change: show it here too (not while this tab's own change is on its way).
    if (!sendTimer && !sending && JSON.stringify(state.options) !== applied) applyOptions(state.options);
    applyPlacement(state.placement);
    render();
  };
}

async function start() {
  choices = await call("GET", "/api/choices");
  fill($("style"), choices.styles, choices.style);
  fill($("page"), [...choices.pages, "custom"]);
  fill($("orientation"), choices.orientations);
  fill($("pens"), choices.pens);
  fill($("profile"), choices.profiles, choices.profile);
  fill($("port"), choices.ports);
  const form = $("controls");
  form.addEventListener("input", controlsChanged);
  form.addEventListener("change", controlsChanged);
  $("photo-input").addEventListener("change", (e) => e.target.files[0] && upload(e.target.files[0]));
  const drop = $("drop");
  drop.addEventListener("dragover", (e) => { e.preventDefault(); drop.classList.add("over"); });
  drop.addEventListener("dragleave", () => drop.classList.remove("over"));
  drop.addEventListener("drop", (e) => { e.preventDefault(); drop.classList.remove("over"); if (e.dataTransfer.files[0]) upload(e.dataTransfer.files[0]); });
  $("plot-start").addEventListener("click", async () => {
    try { await call("POST", "/api/plot", { port: $("port").value, profile: $("profile").value }); $("plot-message").textContent = ""; }
    catch (err) { $("plot-message").textContent = err.message; }
  });
  $("pause").addEventListener("click", () => plotButton("pause"));
  $("stop").addEventListener("click", () => plotButton("stop"));
  $("resume-job").addEventListener("click", () => plotButton("resume-job"));
  const shownPrompt = () => ({ prompt: Number($("prompt").dataset.prompt) });
  $("prompt-go").addEventListener("click", () => plotButton("go", shownPrompt()));
  $("prompt-giveup").addEventListener("click", () => plotButton("give up", shownPrompt()));
  $("prompt-stop").addEventListener("click", () => plotButton("stop"));
  for (const b of $("jog").querySelectorAll("button")) {
    b.addEventListener("click", () => { const s = Number($("jog-step").value); plotButton("jog", { dx: s * b.dataset.dx, dy: s * b.dataset.dy, ...shownPrompt() }); });
  }
  for (const b of $("machine").querySelectorAll("button[data-action]")) {  // the library's machine controls
    b.addEventListener("click", async () => {
      const step = Number($("walk-step").value), body = { port: $("port").value, profile: $("profile").value };
      if (b.dataset.action === "walk") Object.assign(body, { dx: step * b.dataset.dx, dy: step * b.dataset.dy });
      $("plot-message").textContent = "…";
      try { $("plot-message").textContent = (await call("POST", `/api/machine/${b.dataset.action}`, body)).said; }
      catch (err) { $("plot-message").textContent = err.message; }
    });
  }
  $("port").addEventListener("change", render);
  $("profile").addEventListener("change", () => state && showDrawing());
  state = await call("GET", "/api/state");
  applyOptions(state.options);  // a reopened page or a second tab: the server's choices
  render();
  listen();
}

setInterval(() => { const plot = state && plotOf($("port").value); if (plot && plot.active) showPlot(); }, 1000);

// keys.js, the last script, starts the page.
