// pencilbot studio: the page. It only sends the controls and buttons to the server and shows
// what the server says (server-sent events); nothing of the drawing or driving happens here.
"use strict";

const $ = (id) => document.getElementById(id);
const NUMBERS = ["margin", "pen_width", "line_length", "hatch_coverage"];
// The controls a style sets: each shows the chosen style's value until the person moves it (then
// it is "touched" and sent); an untouched one is sent as null, so the style's own value applies.
const STYLED = ["page", "orientation", "margin", "pen_width", "line_length", "hatch_coverage", "hatch"];
let state = null, choices = null, job = null, loading = null, shown = {}, sendTimer = null, sending = 0;
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
    else if (name === "hatch") values.hatch = form.hatch.checked;
    else values[name] = NUMBERS.includes(name) ? Number(form[name].value) : form[name].value;
  }
  if (values.line_length !== null && values.line_length < 2) values.line_length = null;  // 0: from the image size
  return values;
}

function setControl(name, value) {
  const form = $("controls");
  if (name === "hatch") form.hatch.checked = !!value;
  else form[name].value = name === "line_length" ? value || 0 : value;
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
  const name = event && event.target && event.target.name;
  if (STYLED.includes(name)) touched.add(name);
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
  $("photo-name").textContent = photo ? `${photo.name || "photo"}: ${photo.width} × ${photo.height} px` : "";
  $("photo-name").classList.toggle("kept", !!(photo && $("photo-error").textContent));
  if (photo && (force || shown.photo !== photo.number)) {
    shown.photo = photo.number;
    $("photo").src = `/api/picture/photo.png?n=${photo.number}`;
  }
  $("photo").closest("figure").hidden = !photo;
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
  $("fig-likeness").textContent = f ? `ρ ${f.likeness}` : "…";
  $("fig-paths").textContent = f ? `${f.paths} on ${f.page}` : "…";
  // Nothing to show or download yet: no empty picture boxes, no links that give nothing.
  $("preview").hidden = $("sketch").closest("figure").hidden = !shown.preview;
  document.querySelector(".downloads").hidden = !f;
  $("plot-start").disabled = !f || !!(plotOf($("port").value) || {}).active;
  $("dl-gcode").href = `/api/download/plan.gcode?profile=${encodeURIComponent($("profile").value)}`;
}

function plotOf(port) { return state && state.plots.find((p) => p.port === port); }

async function loadJob(plot) {  // the pen-down paths of this plot's G-code, once per plot
  const key = `${plot.port} ${plot.started}`;
  if (loading === key || (job && job.key === key)) return;
  loading = key;
  try {
    const drawing = await call("GET", `/api/plot-paths?port=${encodeURIComponent(plot.port)}`);
    const now = plotOf(plot.port);
    if (now && `${now.port} ${now.started}` === key) { drawing.key = key; job = drawing; }
  } finally { if (loading === key) loading = null; }
}

function drawJob(plot) {
  const canvas = $("plot-canvas"), ctx = canvas.getContext("2d");
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  if (!job || job.key !== `${plot.port} ${plot.started}`) return;
  const [w, h] = job.bed, scale = Math.min(canvas.width / w, canvas.height / h);
  canvas.height = Math.round(h * scale);
  const X = (x) => x * scale, Y = (y) => canvas.height - y * scale;
  const running = plot.record.running ?? (plot.status === "done" ? Infinity : 0);
  const p = job.points, lines = job.lines, off = job.offsets;
  ctx.lineCap = "round"; ctx.lineJoin = "round";
  for (const pass of ["todo", "done"]) {
    ctx.beginPath();
    ctx.strokeStyle = pass === "done" ? "#111" : "#c9d3dd";
    ctx.lineWidth = pass === "done" ? 1.2 : 0.8;
    for (let k = 0; k + 1 < off.length; k++) {
      let started = false;
      for (let i = off[k]; i < off[k + 1]; i++) {
        const done = lines[i] < running;
        if (pass === "done" && !done) {
          if (started && lines[i] === running && plot.record.view) ctx.lineTo(X(plot.record.view[0]), Y(plot.record.view[1]));
          break;
        }
        if (pass === "todo" && done && !(i + 1 < off[k + 1] && lines[i + 1] >= running)) continue;
        if (!started) { ctx.moveTo(X(p[2 * i]), Y(p[2 * i + 1])); started = true; }
        else ctx.lineTo(X(p[2 * i]), Y(p[2 * i + 1]));
      }
    }
    ctx.stroke();
  }
  if (plot.record.view && plot.active) {
    ctx.fillStyle = "#d22"; ctx.beginPath();
    ctx.arc(X(plot.record.view[0]), Y(plot.record.view[1]), 4, 0, 2 * Math.PI); ctx.fill();
  }
}

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
  $("plot-message").textContent = plot ? plot.message : "";
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
  if (plot) {
    drawJob(plot);
    if (!job || job.key !== `${plot.port} ${plot.started}`) {
      try { await loadJob(plot); drawJob(plotOf(plot.port) || plot); } catch (err) { $("plot-message").textContent = err.message; }
    }
  } else {
    const canvas = $("plot-canvas"); canvas.getContext("2d").clearRect(0, 0, canvas.width, canvas.height);
  }
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
    render();
  };
}

async function start() {
  choices = await call("GET", "/api/choices");
  fill($("style"), choices.styles, choices.style);
  fill($("page"), choices.pages);
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

start().catch((err) => { $("connection").textContent = `error: ${err.message}`; });
