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
      const h = el("h3", null, `${drive.name} · address ${drive.address}`);
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
        tr.append(name, cell);
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

function follow() {
  const source = new EventSource("/api/events");
  source.onopen = () => { link.textContent = "live"; link.classList.remove("down"); };
  source.onerror = () => { link.textContent = "connection lost: retrying"; link.classList.add("down"); };
  source.onmessage = (m) => {
    const e = JSON.parse(m.data);
    if (e.type === "value") {
      const c = cells[`v${e.bus}.${e.drive}.${e.point}`];
      if (c) showValue(c, e.payload);
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

// Follow first, so nothing that happens while the plant loads is missed.
follow();
load();
