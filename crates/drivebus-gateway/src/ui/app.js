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
  trendPlant(plant);
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
        box.checked = trend.has(box.dataset.key);
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
  const plant = await r.json();
  shownPlant = plant;
  plantGeneration = plant.generation;
  render(plant);
  rendered = true;
  if (refreshAfterLoad) { refreshAfterLoad = false; refresh(); }
  // Every drive is on the page from here on: scripts/ui-measure reads the first of these.
  performance.mark("plant-shown");
}
let rendered = false;
// The plant as shown (names and numbers), for a reload of the gateway's config.
let shownPlant = null;
// Between a reload's notice and the reloaded plant on the page: events are not drawn (their
// numbers are the new plant's).
let reloading = false;

// The gateway's config was reloaded: the plant again (its buses may have other numbers now),
// the trend's points carried over by name, the drive view told.
async function reloadPlant() {
  reloading = true;
  cells = {};
  try {
    const r = await fetch("/api/plant", { cache: "no-store" });
    if (!r.ok) return;
    const plant = await r.json();
    trendRekey(shownPlant, plant);
    shownPlant = plant;
    plantGeneration = plant.generation;
    render(plant);
    if (!driveView.hidden) {
      const note = document.getElementById("reloaded") || el("p", "control-note");
      note.id = "reloaded";
      note.textContent = `The gateway's config was reloaded (generation ${plant.generation}): this view still reaches its drive if its bus runs on unchanged; otherwise go back to the plant.`;
      if (!note.parentNode) driveView.prepend(note);
    }
  } finally {
    reloading = false;
  }
  trendReload();
}
// The stream opened while the first load was on its way: refresh once it is shown.
let refreshAfterLoad = false;

// The gateway's latest of everything onto the page as it stands (its check boxes and trend
// kept): each time the event stream opens, so that what changed before it was open (a drive's
// first status, a change while it was lost) is not missed: statuses are sent only on change.
async function refresh() {
  if (!rendered) { refreshAfterLoad = true; return; }
  const r = await fetch("/api/plant", { cache: "no-store" });
  if (!r.ok) return;
  const plant = await r.json();
  plant.buses.forEach((bus, b) => {
    const f = cells[`f${b}`];
    if (f && bus.figures) f.textContent = figuresText(bus.figures);
    trendFigures(b, bus.figures);
    bus.drives.forEach((drive, d) => {
      const s = cells[`s${b}.${d}`];
      if (s && drive.status) showStatus(s, drive.status);
      const pd = cells[`p${b}.${d}`];
      if (pd && drive.process_data) showProcessData(pd, drive.process_data);
      drive.points.forEach((p, i) => {
        const c = cells[`v${b}.${d}.${i}`];
        if (c && p.latest) showValue(c, p.latest);
      });
    });
  });
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

// The live events: through the shared worker of events.js (one stream for all of this
// browser's tabs of the page), or this tab's own stream where there are no shared workers.
function follow() {
  const opened = () => {
    // Back after a loss: the trend loads what it missed from the gateway's history.
    if (link.classList.contains("down")) trendReload();
    link.textContent = "live"; link.classList.remove("down");
    refresh();
  };
  const lost = () => { link.textContent = "connection lost: retrying"; link.classList.add("down"); };
  if (typeof SharedWorker === "function") {
    try {
      const worker = new SharedWorker("/events.js");
      worker.port.onmessage = (m) => {
        if (m.data.kind === "open") opened();
        else if (m.data.kind === "error") lost();
        else if (m.data.kind === "event") onEvent(m.data.data);
      };
      worker.port.start();
      window.addEventListener("pagehide", () => worker.port.postMessage("bye"));
      return;
    } catch (_) { /* no shared worker here: a stream of this tab's own */ }
  }
  const source = new EventSource("/api/events");
  source.onopen = opened;
  source.onerror = lost;
  source.onmessage = (m) => onEvent(m.data);
}

function onEvent(data) {
  const e = JSON.parse(data);
  if (e.type === "reload") { reloadPlant(); return; }
  if (reloading) return;
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
    trendFigures(e.bus, e.payload);
  } else if (e.type === "resync") {
    refresh();
    trendReload();
  }
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
  rowCells = new Map();
  let group = null;
  for (const p of t.params) {
    const g = p.group_en || p.group_de || "";
    if (g !== group) {
      group = g;
      const tr = el("tr", "group");
      const th = el("th", null, [p.group_en, p.group_de].filter(Boolean).join(" / "));
      th.colSpan = 8;
      tr.append(th);
      table.append(tr);
    }
    const tr = el("tr");
    tr.dataset.number = p.number;
    const names = el("td");
    names.append(el("div", null, p.name_en), el("div", "muted", p.name_de));
    // The value list, as the manual names each value (English, German).
    if (p.values && p.values.length) {
      const list = p.values.map((v) => `${v.value} = ${v.en || v.de}`);
      const shown = list.length > 6 ? [...list.slice(0, 6), `… ${list.length} values`] : list;
      const line = el("div", "values muted", shown.join(", "));
      line.title = p.values.map((v) => `${v.value} = ${v.en} / ${v.de}`).join("\n");
      names.append(line);
    }
    const range = p.min !== null && p.max !== null ? `${numberText(p.min, p.unit)} … ${numberText(p.max, p.unit)}` : "";
    tr.append(el("td", "number", p.number), names, el("td", "muted", p.access), el("td", "value", range),
      el("td", "value", p.default !== null ? `default ${numberText(p.default, p.unit)}` : ""));
    driveRow(tr, p, b, d);
    table.append(tr);
  }
  list.replaceChildren(table);
}

function openDrive(b, d) {
  driveGeneration = plantGeneration;
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
  const tools = el("div");
  driveView.append(back, el("h2", null, `bus ${b}, drive ${d}`), tools, input, count, list);
  input.addEventListener("input", () => {
    clearTimeout(searchTimer);
    searchTimer = setTimeout(() => showParams(b, d, input.value, list, count), 200);
  });
  fetch("/api/plant", { cache: "no-store" }).then((r) => r.json()).then((p) => {
    const bus = p.buses[b], drive = bus && bus.drives[d];
    if (!drive) return;
    driveView.querySelector("h2").textContent = `${drive.name} · address ${drive.address} (${bus.name})`;
    driveTools(b, d, tools, bus.protocol, p);
    driveControl(b, d, tools, bus, drive);
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

window.addEventListener("hashchange", route);
// After the log-in (login.js); follow first, so nothing that happens while the plant loads is
// missed.
sessionReady().then(() => {
  follow();
  load().then(route);
});
