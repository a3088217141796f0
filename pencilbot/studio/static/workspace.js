// pencilbot studio: the sheet. The paper and its margins to scale, the plan over it (the preview
// picture until the full plan's paths arrive), zoom and pan down to the pen's width, the drawing
// dragged where it goes, and a plot's progress in the pens' colours. Page mm, Y up.
"use strict";

const sheet = { plan: null, planGeneration: 0, loadingPlan: 0, image: new Image(), imageTag: "", job: null,
  jobKey: "", jobGeneration: 0, loadingJob: "", view: null, fitted: false, hidden: new Set(), box: null };
let placement = { scale: 1, dx: 0, dy: 0, skip: [] };
const MAX_ZOOM = 400;  // px per mm: a 0.3 mm pen is then 120 px wide

function pageOf() {  // the sheet's size and margin: the plan's, else the controls'
  if (sheet.plan) return sheet.plan.page;
  const sizes = { A5: [148, 210], A4: [210, 297], A3: [297, 420], Letter: [215.9, 279.4] };
  const form = $("controls"), name = form.page.value;
  let [w, h] = name === "custom" ? [Number(form.page_w.value) || 210, Number(form.page_h.value) || 297] : sizes[name] || sizes.A4;
  const photo = state && state.photo, orientation = form.orientation.value;
  const wide = orientation === "landscape" || (orientation === "auto" && !!photo && photo.width > photo.height);
  if (wide !== w > h) [w, h] = [h, w];
  return { width: w, height: h, margin: Number(form.margin.value) || 0 };
}

function canvasSize() {
  const canvas = $("sheet"), ratio = window.devicePixelRatio || 1;
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== Math.round(w * ratio) || canvas.height !== Math.round(h * ratio)) {
    canvas.width = Math.round(w * ratio); canvas.height = Math.round(h * ratio);
  }
  return [w, h, ratio];
}

function fitView() {
  const [w, h] = canvasSize(), page = pageOf(), pad = 16;
  const s = Math.max(0.05, Math.min((w - 2 * pad) / page.width, (h - 2 * pad) / page.height));
  sheet.view = { s, ox: (w - page.width * s) / 2, oy: (h - page.height * s) / 2 };
  drawSheet();
}

function zoomAt(factor, x, y) {
  const v = sheet.view, s = Math.min(MAX_ZOOM, Math.max(0.05, v.s * factor)), k = s / v.s;
  if (x === undefined) { const [w, h] = canvasSize(); x = w / 2; y = h / 2; }
  sheet.view = { s, ox: x - (x - v.ox) * k, oy: y - (y - v.oy) * k };
  drawSheet();
}

function penScale() {  // the thinnest pen 12 px wide, about the drawing's middle
  const widths = sheet.plan ? sheet.plan.layers.map((l) => l.width) : [Number($("pen_width").value) || 0.3];
  const [w, h] = canvasSize(), target = 12 / Math.min(...widths);
  zoomAt(target / sheet.view.s, w / 2, h / 2);
}

function toScreen(page) {  // page mm (Y up) → canvas px, for the current view
  const v = sheet.view, H = page.height;
  return { X: (x) => v.ox + x * v.s, Y: (y) => v.oy + (H - y) * v.s };
}

function placedBox(page) {  // the drawing's box on the sheet, with the person's placement (mm)
  const b = sheet.box || [page.margin, page.margin, page.width - page.margin, page.height - page.margin];
  const cx = page.width / 2, cy = page.height / 2, k = placement.scale;
  return [cx + (b[0] - cx) * k + placement.dx, cy + (b[1] - cy) * k + placement.dy,
    cx + (b[2] - cx) * k + placement.dx, cy + (b[3] - cy) * k + placement.dy];
}

function drawSheet() {
  if (!sheet.view) return;
  const canvas = $("sheet"), [w, h, ratio] = canvasSize(), ctx = canvas.getContext("2d");
  ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
  ctx.clearRect(0, 0, w, h);
  const plot = state && plotOf($("port").value);
  // A plot's progress while it runs, and after it until the drawing is changed.
  const showJob = plot && sheet.job && sheet.jobKey === `${plot.port} ${plot.started}`
    && (plot.active || sheet.jobGeneration === state.generation);
  const page = showJob ? { ...pageOf(), width: sheet.job.page[0], height: sheet.job.page[1] } : pageOf();
  const v = sheet.view, { X, Y } = toScreen(page);
  ctx.fillStyle = "rgba(0,0,0,.25)"; ctx.fillRect(X(0) + 3, Y(page.height) + 3, page.width * v.s, page.height * v.s);
  ctx.fillStyle = "#fff"; ctx.fillRect(X(0), Y(page.height), page.width * v.s, page.height * v.s);
  ctx.strokeStyle = "#888"; ctx.lineWidth = 1; ctx.strokeRect(X(0), Y(page.height), page.width * v.s, page.height * v.s);
  ctx.setLineDash([4, 4]); ctx.strokeStyle = "#9ab";
  const m = page.margin;
  ctx.strokeRect(X(m), Y(page.height - m), (page.width - 2 * m) * v.s, (page.height - 2 * m) * v.s);
  ctx.setLineDash([]);
  if (showJob) drawJob(ctx, plot, page);
  else if (sheet.plan) drawPlan(ctx, page);
  else if (sheet.imageTag && sheet.image.complete && sheet.image.naturalWidth) drawPicture(ctx, page);
  $("zoom-level").textContent = `1 mm = ${v.s < 10 ? v.s.toFixed(1) : Math.round(v.s)} px`;
}

function drawPicture(ctx, page) {  // the preview picture covers the page: placed as the drawing is
  const { X, Y } = toScreen(page), cx = page.width / 2, cy = page.height / 2, k = placement.scale;
  const x0 = cx - cx * k + placement.dx, y1 = cy + cy * k + placement.dy;
  ctx.globalCompositeOperation = "multiply";
  ctx.drawImage(sheet.image, X(x0), Y(y1), page.width * k * sheet.view.s, page.height * k * sheet.view.s);
  ctx.globalCompositeOperation = "source-over";
}

function strokePaths(ctx, points, offsets, map, from = 0, to = offsets.length - 1) {
  ctx.beginPath();
  for (let k = from; k < to; k++) {
    const a = offsets[k], b = offsets[k + 1];
    ctx.moveTo(map.X(points[2 * a]), map.Y(points[2 * a + 1]));
    for (let i = a + 1; i < b; i++) ctx.lineTo(map.X(points[2 * i]), map.Y(points[2 * i + 1]));
    if (b - a === 1) ctx.lineTo(map.X(points[2 * a]) + 0.01, map.Y(points[2 * a + 1]));
  }
  ctx.stroke();
}

function drawPlan(ctx, page) {
  const { X, Y } = toScreen(page), cx = page.width / 2, cy = page.height / 2, k = placement.scale;
  const map = { X: (x) => X(cx + (x - cx) * k + placement.dx), Y: (y) => Y(cy + (y - cy) * k + placement.dy) };
  ctx.lineCap = ctx.lineJoin = "round";
  for (const layer of sheet.plan.layers) {
    if (sheet.hidden.has(layer.name)) continue;
    ctx.globalAlpha = placement.skip.includes(layer.name) ? 0.2 : 0.85;
    ctx.strokeStyle = layer.color || "#000";
    ctx.lineWidth = Math.max(0.5, layer.width * sheet.view.s);
    strokePaths(ctx, layer.points, layer.offsets, map);
  }
  ctx.globalAlpha = 1;
}

function drawJob(ctx, plot, page) {  // what the machine has drawn in its pens' colours, the rest pale
  const job = sheet.job, { X, Y } = toScreen(page), map = { X, Y };
  const running = plot.record.running ?? (plot.status === "done" ? Infinity : 0);
  const off = job.offsets, firsts = off.slice(0, -1).map((i) => job.lines[i]);
  let done = firsts.findIndex((line) => line >= running);
  if (done < 0) done = firsts.length;
  ctx.lineCap = ctx.lineJoin = "round";
  ctx.strokeStyle = "#c9d3dd"; ctx.lineWidth = 1;
  strokePaths(ctx, job.points, off, map, done);
  const width = Math.max(1.5, (sheet.plan ? sheet.plan.layers[0].width : 0.3) * sheet.view.s);
  for (let k = 0; k < done;) {  // runs of one colour
    let end = k;
    while (end < done && job.colors[end] === job.colors[k]) end++;
    ctx.strokeStyle = job.colors[k]; ctx.lineWidth = width;
    strokePaths(ctx, job.points, off, map, k, end);
    k = end;
  }
  if (plot.record.view && plot.active && sheet.view) {
    const last = done > 0 ? off[done] - 1 : 0;
    ctx.fillStyle = "#d22"; ctx.beginPath();
    ctx.arc(X(job.points[2 * last]), Y(job.points[2 * last + 1]), 5, 0, 2 * Math.PI); ctx.fill();
  }
}

async function sheetDrawing(generation, tag) {  // the server's newest plan: its picture, then its paths
  if (tag && sheet.imageTag !== tag) {
    sheet.imageTag = tag;
    sheet.image.onload = drawSheet;
    sheet.image.src = $("preview").src;
  }
  if (!generation) { if (sheet.plan && sheet.planGeneration !== state.generation) { sheet.plan = null; drawSheet(); } return; }
  if (sheet.planGeneration === generation || sheet.loadingPlan === generation) return;
  sheet.loadingPlan = generation;
  try {
    const plan = await call("GET", "/api/plan-drawing");
    if (plan.generation !== state.generation) return;
    let lo = [Infinity, Infinity], hi = [-Infinity, -Infinity];
    for (const layer of plan.layers) {
      const p = layer.points;
      for (let i = 0; i < p.length; i += 2) {
        lo = [Math.min(lo[0], p[i]), Math.min(lo[1], p[i + 1])]; hi = [Math.max(hi[0], p[i]), Math.max(hi[1], p[i + 1])];
      }
    }
    sheet.box = lo[0] <= hi[0] ? [lo[0], lo[1], hi[0], hi[1]] : null;
    const resized = !sheet.plan || sheet.plan.page.width !== plan.page.width || sheet.plan.page.height !== plan.page.height;
    sheet.plan = plan; sheet.planGeneration = plan.generation;
    showLayers();
    if (resized || !sheet.fitted) { sheet.fitted = true; fitView(); } else drawSheet();
  } catch (err) { /* a newer change is on its way: it brings its own plan */ }
  finally { if (sheet.loadingPlan === generation) sheet.loadingPlan = 0; }
}

function showLayers() {  // one row per layer: its pen's colour, shown or not, plotted or skipped
  const box = $("layers");
  box.replaceChildren();
  if (!sheet.plan || sheet.plan.layers.length < 1) return;
  for (const layer of sheet.plan.layers) {
    const row = document.createElement("span"); row.className = "layer"; row.dataset.layer = layer.name;
    row.innerHTML = `<span class="swatch"></span><span class="name"></span>
      <label><input type="checkbox" class="layer-show"> show</label><label><input type="checkbox" class="layer-plot"> plot</label>`;
    row.querySelector(".swatch").style.background = layer.color;
    row.querySelector(".name").textContent = layer.pen && layer.pen !== layer.name ? `${layer.name} (${layer.pen})` : layer.name;
    const show = row.querySelector(".layer-show"), plot = row.querySelector(".layer-plot");
    show.checked = !sheet.hidden.has(layer.name); plot.checked = !placement.skip.includes(layer.name);
    show.addEventListener("change", () => { if (show.checked) sheet.hidden.delete(layer.name); else sheet.hidden.add(layer.name); drawSheet(); });
    plot.addEventListener("change", () => {
      const skip = new Set(placement.skip);
      if (plot.checked) skip.delete(layer.name); else skip.add(layer.name);
      setPlacement({ skip: [...skip] }, true);
    });
    box.append(row);
  }
}

async function sheetPlot(plot) {  // a plot's drawn paths, once per plot; then its progress
  const key = plot ? `${plot.port} ${plot.started}` : "";
  if (plot && sheet.jobKey !== key && sheet.loadingJob !== key) {
    sheet.loadingJob = key;
    try {
      const job = await call("GET", `/api/plot-sheet?port=${encodeURIComponent(plot.port)}`);
      sheet.job = job; sheet.jobKey = key; sheet.jobGeneration = state.generation;
    } catch (err) { $("plot-message").textContent = err.message; }
    finally { if (sheet.loadingJob === key) sheet.loadingJob = ""; }
  }
  drawSheet();
}

function sheetEvents() {
  const canvas = $("sheet"), pointers = new Map();
  let drag = null;
  const at = (e) => { const r = canvas.getBoundingClientRect(); return [e.clientX - r.left, e.clientY - r.top]; };
  const onDrawing = ([x, y]) => {
    if (!sheet.plan && !sheet.imageTag) return false;
    const page = pageOf(), { X, Y } = toScreen(page), b = placedBox(page);
    return x >= X(b[0]) && x <= X(b[2]) && y >= Y(b[3]) && y <= Y(b[1]);
  };
  canvas.addEventListener("wheel", (e) => { e.preventDefault(); const [x, y] = at(e); zoomAt(Math.exp(-e.deltaY * 0.0015), x, y); }, { passive: false });
  canvas.addEventListener("pointerdown", (e) => {
    canvas.setPointerCapture(e.pointerId); pointers.set(e.pointerId, at(e));
    const plotting = state && (plotOf($("port").value) || {}).active;
    if (pointers.size === 2) drag = { pinch: [...pointers.values()], s: sheet.view.s };
    else drag = { start: at(e), view: { ...sheet.view }, place: { ...placement }, move: !plotting && onDrawing(at(e)) };
    canvas.classList.add("moving");
  });
  canvas.addEventListener("pointermove", (e) => {
    if (!drag) { canvas.classList.toggle("over-drawing", onDrawing(at(e))); return; }
    pointers.set(e.pointerId, at(e));
    if (drag.pinch && pointers.size === 2) {
      const [a, b] = [...pointers.values()], [a0, b0] = drag.pinch;
      const d = Math.hypot(a[0] - b[0], a[1] - b[1]), d0 = Math.hypot(a0[0] - b0[0], a0[1] - b0[1]) || 1;
      zoomAt((drag.s * d / d0) / sheet.view.s, (a[0] + b[0]) / 2, (a[1] + b[1]) / 2);
      return;
    }
    if (drag.pinch) return;
    const [x, y] = at(e), dx = x - drag.start[0], dy = y - drag.start[1];
    if (drag.move) {
      placement.dx = Math.round((drag.place.dx + dx / sheet.view.s) * 10) / 10;
      placement.dy = Math.round((drag.place.dy - dy / sheet.view.s) * 10) / 10;
      showPlacement();
    } else sheet.view = { ...drag.view, ox: drag.view.ox + dx, oy: drag.view.oy + dy };
    drawSheet();
  });
  const end = (e) => {
    pointers.delete(e.pointerId);
    if (drag && drag.move && (placement.dx !== drag.place.dx || placement.dy !== drag.place.dy)) setPlacement({}, true);
    if (!pointers.size) { drag = null; canvas.classList.remove("moving"); }
  };
  canvas.addEventListener("pointerup", end); canvas.addEventListener("pointercancel", end);
  $("zoom-in").addEventListener("click", () => zoomAt(1.5));
  $("zoom-out").addEventListener("click", () => zoomAt(1 / 1.5));
  $("zoom-fit").addEventListener("click", fitView);
  $("zoom-pen").addEventListener("click", penScale);
  new ResizeObserver(() => (sheet.view ? drawSheet() : fitView())).observe(canvas);
  for (const id of ["page", "orientation", "margin", "page_w", "page_h"]) $(id).addEventListener("input", () => { if (!sheet.plan) fitView(); });
}

sheetEvents();
