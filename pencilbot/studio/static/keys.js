// pencilbot studio: the keyboard (the shortcuts the "?" panel lists, the photo picker from the
// keyboard) and the colours (light, dark, or as the system says). Then the page starts.
"use strict";

const THEMES = ["auto", "dark", "light"];

function setTheme(name) {
  if (name === "auto") delete document.documentElement.dataset.theme;
  else document.documentElement.dataset.theme = name;
  $("theme-name").textContent = name;
  try { localStorage.setItem("pencilbot-theme", name); } catch (err) { /* private mode: not kept */ }
}

function nextTheme() {
  const now = document.documentElement.dataset.theme || "auto";
  setTheme(THEMES[(THEMES.indexOf(now) + 1) % THEMES.length]);
}

function typing(target) {  // keys typed into a field are the field's
  return target.closest("input, select, textarea, [contenteditable]") && !(target.type === "checkbox" || target.type === "range");
}

function onKey(e) {
  const key = e.key, ctrl = e.ctrlKey || e.metaKey;
  if (ctrl && !e.altKey && (key === "z" || key === "Z" || key === "y")) {
    if (typing(e.target) && e.target.type !== "range") return;  // a text field's own undo
    e.preventDefault();
    if (key === "y" || e.shiftKey) redo(); else undo();
    return;
  }
  if (ctrl || e.altKey || typing(e.target) || document.querySelector("dialog[open]:not(#keys)")) return;
  const onSheet = e.target === $("sheet"), pan = 40;
  const actions = {
    "?": () => $("keys").showModal(), o: () => $("photo-input").click(), O: () => $("photo-input").click(),
    d: nextTheme, D: nextTheme, "+": () => zoomAt(1.5), "=": () => zoomAt(1.5), "-": () => zoomAt(1 / 1.5),
    "0": fitView, "1": penScale, p: () => $("plot-start").click(), P: () => $("plot-start").click(),
  };
  if (onSheet) {
    const move = { ArrowLeft: [pan, 0], ArrowRight: [-pan, 0], ArrowUp: [0, pan], ArrowDown: [0, -pan] }[key];
    if (move) { sheet.view.ox += move[0]; sheet.view.oy += move[1]; drawSheet(); e.preventDefault(); return; }
    if (key === " ") { if (!$("pause").disabled) $("pause").click(); e.preventDefault(); return; }
  }
  if (key === "Escape" && $("keys").open) { $("keys").close(); return; }
  const action = actions[key];
  const blocked = (key === "p" || key === "P") && $("plot-start").disabled;
  if (action && !blocked) { e.preventDefault(); action(); }
}

function keyEvents() {
  document.addEventListener("keydown", onKey);
  $("drop").addEventListener("keydown", (e) => {  // the picker from the keyboard: Enter or Space
    if (e.key === "Enter" || e.key === " ") { e.preventDefault(); $("photo-input").click(); }
  });
  $("keys-open").addEventListener("click", () => $("keys").showModal());
  $("keys-close").addEventListener("click", () => $("keys").close());
  $("theme").addEventListener("click", nextTheme);
  let saved = "auto";
  try { saved = localStorage.getItem("pencilbot-theme") || "auto"; } catch (err) { /* not kept */ }
  setTheme(THEMES.includes(saved) ? saved : "auto");
}

keyEvents();
start().then(() => {
  applyPlacement(state.placement);
  undoState.current = snapshot();
  fitView();
  listPresets().catch(() => {});
  showHeights();
}).catch((err) => { $("connection").textContent = `error: ${err.message}`; });
