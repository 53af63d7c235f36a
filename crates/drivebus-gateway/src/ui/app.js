// The plant page: load the plant once, then follow the gateway's events (no polling).
"use strict";

const main = document.getElementById("plant");
const link = document.getElementById("link");
let cells = {};

function el(tag, cls, text) {
  const e = document.createElement(tag);
  if (cls) e.className = cls;
  if (text !== undefined && text !== null) e.textContent = text;
  return e;
}

function figuresText(f) {
  if (!f) return "no figures yet";
  const pct = (x) => (x * 100).toFixed(1) + " %";
  return `utilisation ${pct(f.utilisation)}, demand ${pct(f.demand)}, ` +
    `${f.transactions} transactions, ${f.timeouts} timeouts, ${f.retries} retries`;
}

function valueText(v) {
  if (!v) return "–";
  return v.unit ? `${v.value} ${v.unit}` : `${v.value}`;
}

function showValue(c, v) {
  c.value.textContent = valueText(v);
  c.value.title = v ? `raw ${v.raw}, read ${new Date(v.ts).toISOString()}` : c.unread;
  c.text.textContent = v && v.text ? v.text : (v ? "" : c.unread);
}

function showStatus(e, s) {
  const state = s ? s.state : "unknown";
  e.className = "state " + state;
  e.textContent = s && s.text ? `${state}: ${s.text}` : state;
}

function showProcessData(e, pd) {
  const hex = (w) => "0x" + w.toString(16).toUpperCase().padStart(4, "0");
  e.textContent = pd ? "process data in: " + pd.in.map(hex).join(" ") : "";
}

function render(plant) {
  document.getElementById("gateway").textContent = plant.gateway;
  main.replaceChildren();
  cells = {};
  plant.buses.forEach((bus, b) => {
    const sec = el("section", "bus");
    sec.append(el("h2", null, `${bus.name} (${bus.protocol})`));
    const fig = el("div", "figures", figuresText(bus.figures));
    sec.append(fig);
    cells[`f${b}`] = fig;
    const grid = el("div", "drives");
    bus.drives.forEach((drive, d) => {
      const art = el("article", "drive");
      art.dataset.drive = drive.name;
      const h = el("h3");
      const a = el("a", null, `${drive.name} · address ${drive.address}`);
      a.href = `#drive/${b}/${d}`;
      a.title = "the drive's parameter table";
      h.append(a);
      const st = el("span", "state");
      showStatus(st, drive.status);
      h.append(st);
      art.append(h);
      cells[`s${b}.${d}`] = st;
      const table = el("table");
      drive.points.forEach((p, i) => {
        const tr = el("tr");
        tr.dataset.point = p.name;
        const name = el("td", "name");
        name.append(el("div", null, p.name), el("div", "muted", [p.label, p.name_en].filter(Boolean).join(" ")));
        name.title = [p.name_en, p.name_de].filter(Boolean).join(" / ");
        const cell = el("td", "value");
        const value = el("div");
        const text = el("div", "text");
        cell.append(value, text);
        const pick = el("td", "pick");
        const box = el("input");
        box.type = "checkbox";
        box.title = "show in the trend (up to 8)";
        box.dataset.key = `${b}.${d}.${i}`;
        box.addEventListener("change", () => toggleTrend(box, `${b}.${d}.${i}`, `${drive.name} ${p.name}`, p));
        pick.append(box);
        tr.append(pick, name, cell);
        table.append(tr);
        // A point without a period is read only after a write.
        const c = { value, text, unread: p.period_ms === null ? "not polled: read after a write" : "not read yet" };
        showValue(c, p.latest);
        cells[`v${b}.${d}.${i}`] = c;
      });
      art.append(table);
      const pd = el("div", "pd");
      showProcessData(pd, drive.process_data);
      art.append(pd);
      cells[`p${b}.${d}`] = pd;
      grid.append(art);
    });
    sec.append(grid);
    main.append(sec);
  });
}

async function load() {
  const r = await fetch("/api/plant", { cache: "no-store" });
  render(await r.json());
}

// How long a value takes from its read on the bus (its `ts`) to this page: the last 1000.
const latencies = [];

function noteLatency(ms) {
  latencies.push(ms);
  if (latencies.length > 1000) latencies.shift();
}

// {count, median, p99} in ms, for a look in the console and for the tests.
function latency() {
  const sorted = [...latencies].sort((a, b) => a - b);
  const at = (q) => sorted.length ? sorted[Math.min(sorted.length - 1, Math.floor(q * sorted.length))] : null;
  return { count: sorted.length, median: at(0.5), p99: at(0.99) };
}

function follow() {
  const source = new EventSource("/api/events");
  source.onopen = () => { link.textContent = "live"; link.classList.remove("down"); };
  source.onerror = () => { link.textContent = "connection lost: retrying"; link.classList.add("down"); };
  source.onmessage = (m) => {
    const e = JSON.parse(m.data);
    if (e.type === "value" && e.payload && e.payload.ts) noteLatency(Date.now() - e.payload.ts);
    if (e.type === "value") {
      const c = cells[`v${e.bus}.${e.drive}.${e.point}`];
      if (c) showValue(c, e.payload);
      addSample(`${e.bus}.${e.drive}.${e.point}`, e.payload);
    } else if (e.type === "status") {
      const s = cells[`s${e.bus}.${e.drive}`];
      if (s) showStatus(s, e.payload);
    } else if (e.type === "process_data") {
      const p = cells[`p${e.bus}.${e.drive}`];
      if (p) showProcessData(p, e.payload);
    } else if (e.type === "figures") {
      const f = cells[`f${e.bus}`];
      if (f) f.textContent = figuresText(e.payload);
    } else if (e.type === "resync") {
      load();
    }
  };
}

// The drive view (#drive/BUS/DRIVE): its family's parameter table, searched in German and
// English (umlauts folded by the gateway: "ueberwachung" finds "Überwachung").
const driveView = document.getElementById("drive");
let searchTimer = null;

function numberText(v, unit) {
  if (v === null || v === undefined) return "";
  return unit ? `${v} ${unit}` : `${v}`;
}

let searchSeq = 0;

async function showParams(b, d, term, list, count) {
  // Only the answer to the latest search is shown, whatever order the answers come in.
  const mine = ++searchSeq;
  const q = term ? `?search=${encodeURIComponent(term)}` : "";
  const r = await fetch(`/api/drive/${b}/${d}/params${q}`, { cache: "no-store" });
  if (mine !== searchSeq) return;
  if (!r.ok) { list.replaceChildren(el("p", "muted", "no such drive")); return; }
  const t = await r.json();
  if (mine !== searchSeq) return;
  count.textContent = `${t.params.length} parameter(s) of the ${t.family} table` + (t.search ? ` matching “${t.search}”` : "");
  const table = el("table", "params");
  let group = null;
  for (const p of t.params) {
    const g = p.group_en || p.group_de || "";
    if (g !== group) {
      group = g;
      const tr = el("tr", "group");
      const th = el("th", null, [p.group_en, p.group_de].filter(Boolean).join(" / "));
      th.colSpan = 5;
      tr.append(th);
      table.append(tr);
    }
    const tr = el("tr");
    tr.dataset.number = p.number;
    const names = el("td");
    names.append(el("div", null, p.name_en), el("div", "muted", p.name_de));
    const range = p.min !== null && p.max !== null ? `${numberText(p.min, p.unit)} … ${numberText(p.max, p.unit)}` : "";
    tr.append(el("td", "number", p.number), names, el("td", "muted", p.access), el("td", "value", range),
      el("td", "value", p.default !== null ? `default ${numberText(p.default, p.unit)}` : ""));
    table.append(tr);
  }
  list.replaceChildren(table);
}

function openDrive(b, d) {
  main.hidden = true;
  driveView.hidden = false;
  driveView.replaceChildren();
  const back = el("a", null, "← plant");
  back.href = "#";
  const input = el("input");
  input.type = "search";
  input.placeholder = "search the names (German or English)";
  input.id = "search";
  const count = el("div", "figures");
  const list = el("div");
  driveView.append(back, el("h2", null, `bus ${b}, drive ${d}`), input, count, list);
  input.addEventListener("input", () => {
    clearTimeout(searchTimer);
    searchTimer = setTimeout(() => showParams(b, d, input.value, list, count), 200);
  });
  fetch("/api/plant", { cache: "no-store" }).then((r) => r.json()).then((p) => {
    const bus = p.buses[b], drive = bus && bus.drives[d];
    if (drive) driveView.querySelector("h2").textContent = `${drive.name} · address ${drive.address} (${bus.name})`;
  });
  showParams(b, d, "", list, count);
}

function route() {
  const m = location.hash.match(/^#drive\/(\d+)\/(\d+)$/);
  if (m) {
    openDrive(Number(m[1]), Number(m[2]));
  } else {
    driveView.hidden = true;
    main.hidden = false;
  }
}

// The trend: up to 8 points, each drawn on its own scale, kept for 10 minutes in the page.
const TREND_MAX = 8;
const TREND_WINDOW_MS = 10 * 60 * 1000;
const COLOURS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2"];
const trend = new Map();
let trendPaused = false;

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
    trend.set(key, { title, unit: point.latest ? point.latest.unit : null, period: point.period_ms, colour, samples: [] });
    if (point.latest) addSample(key, point.latest);
  }
  drawTrend();
}

function addSample(key, v) {
  const t = trend.get(key);
  if (!t || !v || typeof v.value !== "number") return;
  const last = t.samples[t.samples.length - 1];
  if (last && last.ts === v.ts) return;
  t.unit = v.unit;
  t.samples.push({ ts: v.ts, value: v.value, raw: v.raw });
  const oldest = v.ts - TREND_WINDOW_MS;
  while (t.samples.length && t.samples[0].ts < oldest) t.samples.shift();
  if (!trendPaused) drawTrend();
}

function drawTrend() {
  const section = document.getElementById("trend");
  section.hidden = trend.size === 0;
  const svg = document.getElementById("trend-plot");
  const legend = document.getElementById("trend-legend");
  const ns = "http://www.w3.org/2000/svg";
  svg.replaceChildren();
  legend.replaceChildren();
  // The time axis runs from the oldest sample kept to the newest (at most 10 minutes), so
  // the first seconds fill the plot too.
  let end = 0, first = Infinity;
  for (const t of trend.values()) for (const s of t.samples) { end = Math.max(end, s.ts); first = Math.min(first, s.ts); }
  const start = Math.max(end - TREND_WINDOW_MS, first);
  const width = Math.max(end - start, 1000);
  for (const [key, t] of trend) {
    const values = t.samples.map((s) => s.value);
    const lo = Math.min(...values), hi = Math.max(...values);
    const span = hi > lo ? hi - lo : 1;
    const pts = t.samples.map((s) => {
      const x = ((s.ts - start) / width) * 1000;
      // A value that does not change is drawn across the middle.
      const y = hi > lo ? 190 - ((s.value - lo) / span) * 180 : 100;
      return `${x.toFixed(1)},${y.toFixed(1)}`;
    });
    const line = document.createElementNS(ns, "polyline");
    line.setAttribute("points", pts.join(" "));
    line.setAttribute("fill", "none");
    line.setAttribute("stroke", t.colour);
    line.setAttribute("stroke-width", "2");
    line.setAttribute("vector-effect", "non-scaling-stroke");
    line.dataset.key = key;
    svg.append(line);
    const last = t.samples[t.samples.length - 1];
    const li = el("li");
    const swatch = el("span", "swatch");
    swatch.style.background = t.colour;
    const rate = t.period ? `, read every ${t.period} ms` : "";
    li.append(swatch, el("span", null, `${t.title}: ${last ? valueText(last.value === undefined ? null : { value: last.value, unit: t.unit }) : "–"}` +
      ` (${t.samples.length} samples, ${values.length ? `${lo} … ${hi}` : "no values"}${rate})`));
    legend.append(li);
  }
}

/// The trend's samples as CSV: one row per sample, oldest first.
function trendCsv() {
  const rows = ["time,point,value,unit,raw"];
  const all = [];
  for (const t of trend.values()) for (const s of t.samples) all.push([s.ts, t, s]);
  all.sort((a, b) => a[0] - b[0]);
  const quote = (x) => `"${String(x).replaceAll('"', '""')}"`;
  for (const [ts, t, s] of all) rows.push([new Date(ts).toISOString(), quote(t.title), s.value, quote(t.unit || ""), s.raw].join(","));
  return rows.join("\n") + "\n";
}

function download(name, type, text) {
  const a = el("a");
  a.href = URL.createObjectURL(new Blob([text], { type }));
  a.download = name;
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 1000);
}

document.getElementById("trend-pause").addEventListener("click", (e) => {
  trendPaused = !trendPaused;
  e.target.textContent = trendPaused ? "resume" : "pause";
  if (!trendPaused) drawTrend();
});
document.getElementById("trend-csv").addEventListener("click", () => download("trend.csv", "text/csv", trendCsv()));
document.getElementById("trend-svg").addEventListener("click", () => {
  const svg = document.getElementById("trend-plot").cloneNode(true);
  svg.setAttribute("xmlns", "http://www.w3.org/2000/svg");
  download("trend.svg", "image/svg+xml", svg.outerHTML);
});

window.addEventListener("hashchange", route);
// After the log-in (login.js); follow first, so nothing that happens while the plant loads is
// missed.
sessionReady().then(() => {
  follow();
  load().then(route);
});
