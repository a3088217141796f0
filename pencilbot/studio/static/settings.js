// pencilbot studio: the settings around the drawing. Where the drawing sits on the paper, the
// presets kept in the user's config folder, reset, undo and redo, and the pen heights.
"use strict";

const undoState = { undo: [], redo: [], current: null };
let placeTimer = null, placing = 0;  // a placement on its way: the server's older one is not shown

function showPlacement() {
  $("place-scale").value = Math.round(placement.scale * 100);
  $("placement").querySelector("output").textContent = Math.round(placement.scale * 100);
  $("place-dx").value = placement.dx; $("place-dy").value = placement.dy;
}

function setPlacement(change, record) {  // the person moved the drawing: shown now, sent soon
  Object.assign(placement, change);
  showPlacement(); showLayers(); drawSheet();
  clearTimeout(placeTimer);
  placeTimer = setTimeout(async () => {
    placeTimer = null;
    placing++;
    try { $("plan-error").textContent = ""; await call("POST", "/api/placement", { ...placement }); }
    catch (err) { $("plan-error").textContent = err.message; }
    finally { placing--; }
  }, 60);
  if (record) settingsChanged();
}

function applyPlacement(server) {  // the server's placement (another tab's, a preset's)
  if (placeTimer || placing || !server) return;
  if (JSON.stringify(server) === JSON.stringify(placement)) return;
  placement = { ...server };
  showPlacement(); showLayers(); drawSheet();
}

function snapshot() { return JSON.stringify({ options: options(), placement }); }

function settingsChanged() {  // one step of undo: the settings before this change
  const now = snapshot();
  if (undoState.current !== null && now !== undoState.current) { undoState.undo.push(undoState.current); undoState.redo = []; }
  undoState.current = now;
  showHistory();
}

function showHistory() {
  $("undo").disabled = !undoState.undo.length;
  $("redo").disabled = !undoState.redo.length;
}

let settingsSent = Promise.resolve();  // each change's requests after the one before: the last one wins

function applySettings(saved) {  // options and placement as one: shown now, sent in order
  const options = saved.options || {}, place = saved.placement || {};
  applyOptions({ style: null, pens: null, profile: null, ...options });
  const wanted = { scale: 1, dx: 0, dy: 0, skip: [], ...place };
  placement = { ...wanted };
  showPlacement(); showLayers(); drawSheet();
  placing++; sending++;  // the server's older settings are not shown meanwhile
  settingsSent = settingsSent.then(async () => {
    try {
      $("plan-error").textContent = "";
      await call("POST", "/api/placement", wanted);
      await call("POST", "/api/drawing", options);
    } catch (err) { $("plan-error").textContent = err.message; }
    finally { placing--; sending--; }
  });
  return settingsSent;
}

async function undoRedo(from, to) {
  if (!from.length) return;
  to.push(undoState.current);
  undoState.current = from.pop();
  showHistory();
  await applySettings(JSON.parse(undoState.current));
}

const undo = () => undoRedo(undoState.undo, undoState.redo);
const redo = () => undoRedo(undoState.redo, undoState.undo);

async function listPresets(chosen) {
  const { presets } = await call("GET", "/api/presets"), list = $("preset-list");
  list.replaceChildren(list.options[0] || new Option("— saved presets —", ""));
  if (!list.options.length) list.append(new Option("— saved presets —", ""));
  for (const name of presets) list.append(new Option(name, name));
  if (chosen) list.value = chosen;
}

async function presetAction(what) {
  const say = (text) => { $("preset-message").textContent = text; };
  const name = what === "save" ? $("preset-name").value.trim() : $("preset-list").value;
  if (!name) { say(what === "save" ? "give the preset a name first" : "pick a preset first"); return; }
  if (!/^[A-Za-z0-9][A-Za-z0-9 _-]{0,39}$/.test(name)) {
    say("a preset name is up to 40 letters, digits, spaces, - or _, starting with a letter or digit"); return;
  }
  try {
    const url = `/api/presets/${encodeURIComponent(name)}`;
    if (what === "save") {
      await call("POST", url, { options: options(), placement }); await listPresets(name); say(`saved as ${name}`);
    } else if (what === "delete") {
      await call("DELETE", url); await listPresets(); say(`${name} deleted`);
    } else {
      await applySettings(await call("GET", url)); settingsChanged(); say(`${name} loaded`);
    }
  } catch (err) { say(err.message); }
}

async function resetSettings() {
  await applySettings({ options: {}, placement: {} });
  settingsChanged();
  $("preset-message").textContent = "the style's own settings, the drawing centred";
}

async function showHeights() {  // the chosen profile's pen heights, in its unit
  try {
    const h = await call("GET", `/api/pen-heights?profile=${encodeURIComponent($("profile").value)}`);
    $("height-up").value = h.up; $("height-down").value = h.down; $("height-unit").textContent = h.unit;
  } catch (err) { $("plot-message").textContent = err.message; }
}

async function heightButton(what) {
  const body = { port: $("port").value, profile: $("profile").value };
  if (what === "save") Object.assign(body, { up: Number($("height-up").value), down: Number($("height-down").value) });
  else Object.assign(body, { which: what, value: Number($(`height-${what}`).value) });
  $("plot-message").textContent = "…";
  try { $("plot-message").textContent = (await call("POST", `/api/pen-height/${what === "save" ? "save" : "try"}`, body)).said; }
  catch (err) { $("plot-message").textContent = err.message; }
}

function settingsEvents() {
  $("place-scale").addEventListener("input", () => setPlacement({ scale: Number($("place-scale").value) / 100 }, false));
  $("place-scale").addEventListener("change", () => settingsChanged());
  for (const key of ["dx", "dy"]) $(`place-${key}`).addEventListener("change", () => setPlacement({ [key]: Number($(`place-${key}`).value) || 0 }, true));
  $("place-reset").addEventListener("click", () => setPlacement({ scale: 1, dx: 0, dy: 0 }, true));
  $("undo").addEventListener("click", undo);
  $("redo").addEventListener("click", redo);
  $("preset-save").addEventListener("click", () => presetAction("save"));
  $("preset-load").addEventListener("click", () => presetAction("load"));
  $("preset-delete").addEventListener("click", () => presetAction("delete"));
  $("reset").addEventListener("click", resetSettings);
  $("try-up").addEventListener("click", () => heightButton("up"));
  $("try-down").addEventListener("click", () => heightButton("down"));
  $("heights-save").addEventListener("click", () => heightButton("save"));
  $("profile").addEventListener("change", showHeights);
}

settingsEvents();
