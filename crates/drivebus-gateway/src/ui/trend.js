// The trend: up to 8 points, each drawn on its own scale. A point added to it first loads the
// last 10 minutes the gateway kept (GET /api/history/…), then follows the live events; the
// events that arrive while its history loads are held and joined after the history's newest
// sample, so nothing is missed and nothing is drawn twice. It is loaded before app.js, which
// calls toggleTrend, addSample, trendPlant, trendFigures and trendReload.
"use strict";

const TREND_MAX = 8;
const TREND_WINDOW_MS = 10 * 60 * 1000;
// The measured rate is taken over the last minute of a point's samples.
const RATE_SPAN_MS = 60 * 1000;
const COLOURS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2"];
const SVG_NS = "http://www.w3.org/2000/svg";
// key "bus.drive.point" → {title, unit, period, bus, colour, samples, loading, held, error}
const trend = new Map();
// Each bus's demand (the share of the wire its polls ask for), from the bus figures.
const busDemand = [];
let trendPaused = false;
// While paused: the newest time shown.
let pausedEnd = null;
// The span the plot follows (the last N minutes), or a span picked by a drag (fixed).
let zoomMs = TREND_WINDOW_MS;
let picked = null;

function historyUrl(key) {
  return "/api/history/" + key.split(".").join("/");
}

function numeric(v) {
  return v && typeof v.value === "number" && typeof v.ts === "number";
}

function sampleOf(v) {
  return { ts: v.ts, value: v.value, raw: v.raw };
}

// Load (or load again) a point's history, then join what arrived meanwhile.
async function loadHistory(key) {
  const t = trend.get(key);
  if (!t) return;
  // Only the latest load is joined: one started before it would miss what it holds.
  const mine = (t.load = (t.load || 0) + 1);
  t.loading = true;
  t.held = [];
  let got = null;
  try {
    const r = await fetch(historyUrl(key), { cache: "no-store" });
    if (!r.ok) throw new Error(`the gateway answered ${r.status}`);
    got = await r.json();
  } catch (e) {
    t.error = `no history: ${e.message}`;
  }
  // Taken off the trend while loading, or loaded again since.
  if (trend.get(key) !== t || t.load !== mine) return;
  const samples = got ? got.samples.filter(numeric).map(sampleOf) : t.samples;
  if (got) {
    t.error = null;
    const last = got.samples.findLast((s) => s.unit !== undefined);
    if (last) t.unit = last.unit;
  }
  let newest = samples.length ? samples[samples.length - 1].ts : -Infinity;
  for (const v of t.held) {
    if (v.ts > newest) {
      samples.push(sampleOf(v));
      newest = v.ts;
    }
  }
  t.samples = samples;
  t.loading = false;
  t.held = [];
  trim(t);
  drawTrend();
}

function toggleTrend(box, key, title, point) {
  if (!box.checked) {
    trend.delete(key);
  } else if (trend.size >= TREND_MAX) {
    box.checked = false;
    alert(`The trend shows at most ${TREND_MAX} points.`);
    return;
  } else {
    const used = new Set([...trend.values()].map((t) => t.colour));
    const colour = COLOURS.find((c) => !used.has(c)) || COLOURS[0];
    trend.set(key, {
      title, unit: point.latest ? point.latest.unit : null, period: point.period_ms,
      bus: Number(key.split(".")[0]), colour, samples: [], loading: true, held: [], error: null,
    });
    loadHistory(key);
  }
  drawTrend();
}

// Drop what is older than 10 minutes before a point's newest sample.
function trim(t) {
  const last = t.samples[t.samples.length - 1];
  if (!last) return;
  const oldest = last.ts - TREND_WINDOW_MS;
  let n = 0;
  while (n < t.samples.length && t.samples[n].ts < oldest) n++;
  if (n) t.samples.splice(0, n);
}

// The gateway's config was reloaded: each point of the trend under its number in `after`, found
// by its bus, drive and point names in `before`; a point the reloaded config no longer has
// leaves the trend.
function trendRekey(before, after) {
  if (!before) return;
  const at = new Map();
  after.buses.forEach((bus, b) => bus.drives.forEach((drive, d) => drive.points.forEach((p, i) => {
    at.set(`${bus.name}\u0000${drive.name}\u0000${p.name}`, `${b}.${d}.${i}`);
  })));
  const old = [...trend.entries()];
  trend.clear();
  for (const [key, t] of old) {
    const [b, d, i] = key.split(".").map(Number);
    const bus = before.buses[b], drive = bus && bus.drives[d], p = drive && drive.points[i];
    const next = p && at.get(`${bus.name}\u0000${drive.name}\u0000${p.name}`);
    if (next) {
      t.bus = Number(next.split(".")[0]);
      trend.set(next, t);
    }
  }
  drawTrend();
}

// A live value (from app.js's event stream).
function addSample(key, v) {
  const t = trend.get(key);
  if (!t || !numeric(v)) return;
  if (t.loading) {
    t.held.push(v);
    return;
  }
  const last = t.samples[t.samples.length - 1];
  // Already there (the history had it) or older: not drawn twice.
  if (last && v.ts <= last.ts) return;
  t.unit = v.unit;
  t.samples.push(sampleOf(v));
  trim(t);
  if (!trendPaused) drawTrend();
}

// The plant as loaded (app.js): each bus's demand.
function trendPlant(plant) {
  plant.buses.forEach((b, i) => { busDemand[i] = b.figures ? b.figures.demand : null; });
}

// A bus's figures (app.js's event stream).
function trendFigures(bus, f) {
  if (f) busDemand[bus] = f.demand;
}

// The event stream was lost and is back (or the page fell behind): load every history again.
function trendReload() {
  for (const key of trend.keys()) loadHistory(key);
}

// The span shown: {start, end} in ms, `window` its length, `picked` for a dragged span.
function trendView() {
  let newest = -Infinity, first = Infinity;
  for (const t of trend.values()) {
    if (!t.samples.length) continue;
    first = Math.min(first, t.samples[0].ts);
    newest = Math.max(newest, t.samples[t.samples.length - 1].ts);
  }
  if (picked) return { start: picked.start, end: picked.end, window: picked.end - picked.start, picked: true, paused: trendPaused };
  if (newest === -Infinity) return { start: 0, end: 0, window: zoomMs, picked: false, paused: trendPaused };
  const end = trendPaused && pausedEnd !== null ? pausedEnd : newest;
  // The axis starts at the oldest sample kept when there is less than the zoom's span, so the
  // first minutes fill the plot too.
  const start = Math.max(end - zoomMs, first);
  return { start, end, window: zoomMs, picked: false, paused: trendPaused };
}

function shown(t, view) {
  return t.samples.filter((s) => s.ts >= view.start && s.ts <= view.end);
}

// The polyline points (in a 1000 × 200 box) of what is shown of each point.
function plotLines(view) {
  const width = Math.max(view.end - view.start, 1000);
  const lines = [];
  for (const [key, t] of trend) {
    const samples = shown(t, view);
    const values = samples.map((s) => s.value);
    const lo = Math.min(...values), hi = Math.max(...values);
    const span = hi > lo ? hi - lo : 1;
    const pts = samples.map((s) => {
      const x = ((s.ts - view.start) / width) * 1000;
      // A value that does not change is drawn across the middle.
      const y = hi > lo ? 190 - ((s.value - lo) / span) * 180 : 100;
      return `${x.toFixed(1)},${y.toFixed(1)}`;
    });
    lines.push({ key, t, samples, lo, hi, points: pts.join(" ") });
  }
  return lines;
}

function rateText(r) {
  if (r === null) return "–";
  return r >= 10 ? `${r.toFixed(0)}/s` : r >= 0.1 ? `${r.toFixed(2)}/s` : `1 per ${(1 / r).toFixed(0)} s`;
}

// What a point gets (its samples of the last minute) and what the wire allows (its period,
// stretched by the bus's demand when the polls ask more than the wire carries).
function rates(t) {
  const n = t.samples.length;
  let got = null;
  if (n >= 2) {
    const newest = t.samples[n - 1].ts;
    let i = n - 1;
    while (i > 0 && t.samples[i - 1].ts >= newest - RATE_SPAN_MS) i--;
    const span = newest - t.samples[i].ts;
    if (span > 0) got = ((n - 1 - i) * 1000) / span;
  }
  if (!t.period) return { got, allowed: null, text: `gets ${rateText(got)}; read after writes only` };
  const demand = busDemand[t.bus];
  const stretch = typeof demand === "number" && demand > 1 ? demand : 1;
  const every = t.period * stretch;
  const allowed = 1000 / every;
  const how = stretch > 1
    ? `every ${periodText(t.period)} × ${stretch.toFixed(2)} = ${periodText(Math.round(every))}: the bus's polls ask ${(stretch * 100).toFixed(0)} % of the wire`
    : `every ${periodText(t.period)}`;
  return { got, allowed, text: `gets ${rateText(got)}, the wire allows ${rateText(allowed)} (${how})` };
}

function periodText(ms) {
  return ms >= 1000 && ms % 1000 === 0 ? `${ms / 1000} s` : `${ms} ms`;
}

function timeText(ms) {
  return new Date(ms).toLocaleTimeString([], { hour12: false });
}

function spanText(ms) {
  const s = Math.round(ms / 1000);
  if (s < 60) return `${s} s`;
  return s % 60 ? `${Math.floor(s / 60)} min ${s % 60} s` : `${s / 60} min`;
}

function legendText(line) {
  const { t, samples, lo, hi } = line;
  const last = samples[samples.length - 1];
  const now = last ? valueText({ value: last.value, unit: t.unit }) : "–";
  const range = samples.length ? `${lo} … ${hi}` : "no values";
  const state = t.loading ? "loading its history…" : t.error ? t.error : rates(t).text;
  return `${t.title}: ${now} (${samples.length} samples, ${range}; ${state})`;
}

function drawTrend() {
  const section = document.getElementById("trend");
  section.hidden = trend.size === 0;
  const svg = document.getElementById("trend-plot");
  const legend = document.getElementById("trend-legend");
  const view = trendView();
  svg.replaceChildren();
  legend.replaceChildren();
  for (const line of plotLines(view)) {
    const p = document.createElementNS(SVG_NS, "polyline");
    p.setAttribute("points", line.points);
    p.setAttribute("fill", "none");
    p.setAttribute("stroke", line.t.colour);
    p.setAttribute("stroke-width", "2");
    p.setAttribute("vector-effect", "non-scaling-stroke");
    p.dataset.key = line.key;
    svg.append(p);
    const li = el("li");
    li.dataset.key = line.key;
    const swatch = el("span", "swatch");
    swatch.style.background = line.t.colour;
    li.append(swatch, el("span", null, legendText(line)));
    legend.append(li);
  }
  const axis = document.getElementById("trend-axis");
  const what = view.picked ? "picked span" : view.paused ? "paused" : `last ${spanText(view.window)}`;
  axis.replaceChildren(
    el("span", null, view.end ? timeText(view.start) : ""),
    el("span", "muted", view.end ? `${spanText(view.end - view.start)} shown (${what})` : ""),
    el("span", null, view.end ? timeText(view.end) : ""));
  for (const b of document.querySelectorAll("#trend-zoom button")) {
    b.classList.toggle("on", !view.picked && Number(b.dataset.minutes) * 60000 === zoomMs);
  }
}

// The trend's shown samples as CSV: one row per sample, oldest first.
function trendCsv() {
  const view = trendView();
  const rows = ["time,point,value,unit,raw"];
  const all = [];
  for (const t of trend.values()) for (const s of shown(t, view)) all.push([s.ts, t, s]);
  all.sort((a, b) => a[0] - b[0]);
  const quote = (x) => `"${String(x).replaceAll('"', '""')}"`;
  for (const [ts, t, s] of all) rows.push([new Date(ts).toISOString(), quote(t.title), s.value, quote(t.unit || ""), s.raw].join(","));
  return rows.join("\n") + "\n";
}

function escapeXml(s) {
  return String(s).replace(/[<>&"']/g, (c) => `&#${c.charCodeAt(0)};`);
}

// The picture as a standalone SVG: the plot (as shown) with its times and legend.
const PICTURE_WIDTH = 1000;
function trendSvg() {
  const view = trendView();
  const lines = plotLines(view);
  const height = 262 + 18 * lines.length;
  const out = [
    `<svg xmlns="${SVG_NS}" width="${PICTURE_WIDTH}" height="${height}" viewBox="0 0 ${PICTURE_WIDTH} ${height}" font-family="sans-serif" font-size="12">`,
    `<rect width="100%" height="100%" fill="#ffffff"/>`,
    `<text x="8" y="18" font-size="14" font-weight="bold">${escapeXml(document.title)} trend</text>`,
    `<rect x="0" y="28" width="${PICTURE_WIDTH}" height="200" fill="#fbfbfa" stroke="#dddddd"/>`,
  ];
  for (const l of lines) {
    out.push(`<polyline transform="translate(0 28)" points="${l.points}" fill="none" stroke="${l.t.colour}" stroke-width="2"/>`);
  }
  if (view.end) {
    out.push(`<text x="4" y="244">${escapeXml(new Date(view.start).toISOString())}</text>`);
    out.push(`<text x="${PICTURE_WIDTH - 4}" y="244" text-anchor="end">${escapeXml(new Date(view.end).toISOString())}</text>`);
  }
  lines.forEach((l, i) => {
    const y = 262 + 18 * i;
    out.push(`<rect x="8" y="${y - 10}" width="10" height="10" fill="${l.t.colour}"/>`);
    out.push(`<text x="24" y="${y}">${escapeXml(legendText(l))}</text>`);
  });
  out.push("</svg>");
  return out.join("\n");
}

// The picture as a PNG (a Blob): the SVG drawn onto a canvas in the page, at `scale` times
// its size. Nothing is loaded from elsewhere.
async function trendPng(scale = 2) {
  const text = trendSvg();
  const size = text.match(/width="(\d+)" height="(\d+)"/);
  const [w, h] = [Number(size[1]), Number(size[2])];
  const url = URL.createObjectURL(new Blob([text], { type: "image/svg+xml" }));
  try {
    const img = new Image();
    await new Promise((ok, fail) => {
      img.onload = ok;
      img.onerror = () => fail(new Error("the picture could not be drawn"));
      img.src = url;
    });
    const canvas = document.createElement("canvas");
    canvas.width = w * scale;
    canvas.height = h * scale;
    const g = canvas.getContext("2d");
    g.scale(scale, scale);
    g.drawImage(img, 0, 0, w, h);
    return await new Promise((ok, fail) => canvas.toBlob((b) => (b ? ok(b) : fail(new Error("no PNG"))), "image/png"));
  } finally {
    URL.revokeObjectURL(url);
  }
}

// Save `data` (text of `type`, or a Blob) as the file `name`.
function download(name, type, data) {
  const a = el("a");
  a.href = URL.createObjectURL(data instanceof Blob ? data : new Blob([data], { type }));
  a.download = name;
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 1000);
}

function setPaused(on) {
  trendPaused = on;
  pausedEnd = on ? trendView().end : null;
  document.getElementById("trend-pause").textContent = on ? "resume" : "pause";
  drawTrend();
}

function setZoom(minutes) {
  zoomMs = minutes * 60 * 1000;
  picked = null;
  drawTrend();
}

// A drag across the plot (mouse, pen or finger) picks the span between its two ends.
function pickSpans(svg) {
  let from = null;
  const at = (e) => {
    const r = svg.getBoundingClientRect();
    return Math.min(1, Math.max(0, (e.clientX - r.left) / Math.max(r.width, 1)));
  };
  const band = document.getElementById("trend-pick");
  svg.addEventListener("pointerdown", (e) => {
    from = at(e);
    svg.setPointerCapture(e.pointerId);
    band.hidden = true;
  });
  svg.addEventListener("pointermove", (e) => {
    if (from === null) return;
    const a = Math.min(from, at(e)), b = Math.max(from, at(e));
    band.style.left = `${a * 100}%`;
    band.style.width = `${(b - a) * 100}%`;
    band.hidden = false;
  });
  const end = (e) => {
    if (from === null) return;
    const a = Math.min(from, at(e)), b = Math.max(from, at(e));
    from = null;
    band.hidden = true;
    // A tap is not a span.
    if (b - a < 0.02) return;
    const view = trendView();
    const width = Math.max(view.end - view.start, 1000);
    picked = { start: Math.round(view.start + a * width), end: Math.round(view.start + b * width) };
    drawTrend();
  };
  svg.addEventListener("pointerup", end);
  svg.addEventListener("pointercancel", () => { from = null; band.hidden = true; });
}

document.getElementById("trend-pause").addEventListener("click", () => setPaused(!trendPaused));
for (const b of document.querySelectorAll("#trend-zoom button")) {
  b.addEventListener("click", () => setZoom(Number(b.dataset.minutes)));
}
document.getElementById("trend-csv").addEventListener("click", () => download("trend.csv", "text/csv", trendCsv()));
document.getElementById("trend-svg").addEventListener("click", () => download("trend.svg", "image/svg+xml", trendSvg()));
document.getElementById("trend-png").addEventListener("click", () => {
  trendPng().then((b) => download("trend.png", "image/png", b), (e) => alert(e.message));
});
pickSpans(document.getElementById("trend-plot"));
