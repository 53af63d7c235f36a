// The drive view's work with the drive: read on demand, check and write through the guard,
// faults, backup, restore and compare. Every request goes to the gateway, which runs it on the
// drive's bus between its polls.
"use strict";

// A POST of `body` (text, sent as it is: a backup file) with the session's CSRF token (login.js;
// the gateway refuses a state-changing request without it).
async function postTo(path, body, type) {
  if (csrfToken === null) await sessionReady();
  const headers = { "Content-Type": type || "application/json", "X-CSRF-Token": csrfToken || "" };
  return fetch(path, { method: "POST", headers, body, cache: "no-store" });
}

// Read an answer of JSON lines, handing each to `onLine` as it comes.
async function readLines(response, onLine) {
  if (!response.ok || !response.body) {
    let message = `the gateway answered ${response.status}`;
    try { const j = await response.json(); if (j.message) message = j.message; } catch (_) { /* not JSON */ }
    onLine({ type: "error", message });
    return;
  }
  const reader = response.body.getReader();
  const decoder = new TextDecoder();
  let buffer = "";
  for (;;) {
    const { value, done } = await reader.read();
    if (done) break;
    buffer += decoder.decode(value, { stream: true });
    let at;
    while ((at = buffer.indexOf("\n")) >= 0) {
      const line = buffer.slice(0, at);
      buffer = buffer.slice(at + 1);
      if (line.trim()) onLine(JSON.parse(line));
    }
  }
}

function progressText(p) {
  return `${p.phase} ${p.done} of ${p.of}`;
}

function payloadText(v) {
  if (!v) return "–";
  const value = v.unit ? `${v.value} ${v.unit}` : `${v.value}`;
  return v.text ? `${value} (${v.text})` : value;
}

// A viewer reads; only an operator writes and restores (the gateway refuses a viewer's POST
// anyway: the page does not offer what would be refused).
function mayWrite() {
  return !sessionInfo || sessionInfo.role !== "viewer";
}

// The value cells of the rows shown, by the parameter's key.
let rowCells = new Map();

// One row of the parameter table: the value read on demand and the editor.
function driveRow(tr, p, b, d) {
  const value = el("td", "value read");
  value.textContent = "";
  const readButton = el("button", "small", "read");
  readButton.type = "button";
  readButton.title = "read this parameter from the drive";
  readButton.addEventListener("click", () => readKeys(b, d, [p.key]));
  const edit = el("td", "edit");
  const input = el("input");
  input.size = 8;
  input.placeholder = "new value";
  input.setAttribute("aria-label", `new value of ${p.number}`);
  // A value list: the names to pick from (the gateway takes a value's name or its number).
  if (p.values && p.values.length) {
    const list = el("datalist");
    list.id = `values-${p.key}`;
    for (const v of p.values) list.append(new Option(`${v.value} = ${v.en || v.de}`, v.en || String(v.value)));
    edit.append(list);
    input.setAttribute("list", list.id);
  }
  const eeprom = el("input");
  eeprom.type = "checkbox";
  eeprom.title = "write to EEPROM too (kept after power-off; the wear rule applies)";
  const eepromLabel = el("label", "muted", " EEPROM");
  eepromLabel.prepend(eeprom);
  const checkButton = el("button", "small", "check");
  checkButton.type = "button";
  const writeButton = el("button", "small", "write");
  writeButton.type = "button";
  writeButton.disabled = true;
  const note = el("div", "note");
  if (mayWrite()) edit.append(input, eepromLabel, checkButton, writeButton, note);
  const readCell = el("td");
  readCell.append(readButton);
  tr.append(readCell, value, edit);
  rowCells.set(p.key, value);
  let checked = null;
  const invalidate = () => { checked = null; writeButton.disabled = true; };
  input.addEventListener("input", invalidate);
  eeprom.addEventListener("change", invalidate);
  checkButton.addEventListener("click", async () => {
    invalidate();
    note.className = "note";
    note.textContent = "checking…";
    const q = new URLSearchParams({ key: p.key, value: input.value, eeprom: eeprom.checked });
    const r = await fetch(`/api/drive/${b}/${d}/check?${q}`, { cache: "no-store" });
    const c = await r.json();
    note.replaceChildren();
    if (!c.ok) {
      note.className = "note refused";
      note.append(el("span", null, `${c.reason}: ${c.message}`));
      if (c.nearest) {
        const use = el("button", "small", `use ${c.nearest}`);
        use.type = "button";
        use.addEventListener("click", () => { input.value = String(parseFloat(c.nearest)); invalidate(); checkButton.click(); });
        note.append(" ", use);
      }
      return;
    }
    checked = c;
    note.className = "note ok";
    note.append(el("span", null, `will write ${payloadText(c)} (raw ${c.raw}) to ${c.eeprom ? "RAM and EEPROM" : "RAM only"}`));
    if (c.warning) note.append(el("div", "warn", c.warning));
    if (c.link_change) {
      const box = el("input");
      box.type = "checkbox";
      const l = el("label", "warn", ` ${c.link_change}: write it anyway`);
      l.prepend(box);
      note.append(l);
      box.addEventListener("change", () => { writeButton.disabled = !box.checked; checked.confirm = box.checked; });
      return;
    }
    writeButton.disabled = false;
  });
  writeButton.addEventListener("click", async () => {
    if (!checked) return;
    writeButton.disabled = true;
    note.className = "note";
    note.textContent = "writing…";
    const body = JSON.stringify({ key: p.key, value: input.value, eeprom: eeprom.checked, confirm: !!checked.confirm });
    const r = await postTo(`/api/drive/${b}/${d}/write`, body);
    const w = await r.json().catch(() => ({ outcome: "refused", reason: String(r.status), message: "the gateway refused the request" }));
    checked = null;
    if (w.outcome === "written") {
      note.className = "note ok";
      note.textContent = `written; the drive holds ${payloadText(w.payload)}` + (w.differs ? ` — ${w.differs}` : "") + (w.link_note ? ` — ${w.link_note}` : "");
      value.textContent = payloadText(w.payload);
    } else {
      note.className = "note refused";
      note.textContent = `${w.outcome === "unknown" ? "in doubt" : "refused"} (${w.reason}): ${w.message}`;
    }
  });
}

// Read `keys` from the drive, showing each value in its row as it comes.
async function readKeys(b, d, keys, progress) {
  for (const k of keys) { const c = rowCells.get(k); if (c) c.textContent = "…"; }
  const r = await fetch(`/api/drive/${b}/${d}/read?keys=${encodeURIComponent(keys.join(","))}`, { cache: "no-store" });
  await readLines(r, (line) => {
    const c = rowCells.get(line.key);
    if (line.type === "value" && c) { c.textContent = payloadText(line.payload); c.title = `raw ${line.payload.raw}`; }
    else if (line.type === "error" && c) { c.textContent = line.message; c.className = "value read refused"; }
    else if (line.type === "progress" && progress) progress.textContent = progressText(line);
    else if (line.type === "end" && progress) progress.textContent = `read ${line.read}, failed ${line.failed}`;
    else if (line.type === "error" && progress) progress.textContent = line.message;
  });
}

// The drive's backup file as the gateway made it (the `drivebus-backup` v1 text), or null.
async function fetchBackup(b, d, status) {
  let file = null;
  const r = await fetch(`/api/drive/${b}/${d}/backup`, { cache: "no-store" });
  await readLines(r, (line) => {
    if (line.type === "progress") status.textContent = `backup: ${progressText(line)}`;
    else if (line.type === "backup") {
      file = line.file;
      status.textContent = `backup: ${JSON.parse(file).parameters.length} values` +
        (line.complete ? "" : `, ${line.unreadable.length} the drive refused to read`);
    } else if (line.type === "error") status.textContent = `backup failed: ${line.message}`;
  });
  return file;
}

// The drive view's tools: read what is shown, faults, backup, restore, compare.
function driveTools(b, d, view, family, plant) {
  const bar = el("div", "tools");
  // Not `.figures`: the parameter count below is the view's `.figures` line.
  const status = el("div", "tool-status");
  status.id = "tool-status";
  const out = el("div", "tool-out");
  const button = (text, title) => { const x = el("button", null, text); x.type = "button"; x.title = title; bar.append(x); return x; };
  const readShown = button("read shown", "read every parameter listed below from the drive");
  const faults = button("faults", "the present fault and the fault memory");
  const backup = button("backup", "save every parameter as a drivebus-backup file (as drivectl backup writes it)");
  const fileInput = el("input");
  fileInput.type = "file";
  fileInput.accept = ".json,application/json";
  fileInput.id = "restore-file";
  const restoreLabel = el("label", null, "restore from a file: ");
  restoreLabel.append(fileInput);
  if (mayWrite()) bar.append(restoreLabel);
  const compareWith = el("select");
  compareWith.id = "compare-with";
  compareWith.append(new Option("compare with…", ""));
  plant.buses.forEach((bus, ob) => bus.drives.forEach((drive, od) => {
    if ((ob !== b || od !== d) && bus.protocol === plant.buses[b].protocol) compareWith.append(new Option(`${drive.name} (${bus.name})`, `${ob}/${od}`));
  }));
  // Only where the plant has another drive of the family.
  if (compareWith.options.length > 1) bar.append(compareWith);
  const compareFile = el("input");
  compareFile.type = "file";
  compareFile.accept = ".json,application/json";
  compareFile.id = "compare-file";
  const compareLabel = el("label", null, "compare with a file: ");
  compareLabel.append(compareFile);
  bar.append(compareLabel);
  view.append(bar, status, out);

  readShown.addEventListener("click", () => readKeys(b, d, [...rowCells.keys()], status));

  faults.addEventListener("click", async () => {
    const table = el("table", "faults");
    out.replaceChildren(el("h3", null, "Present fault and fault memory"), table);
    const r = await fetch(`/api/drive/${b}/${d}/faults`, { cache: "no-store" });
    await readLines(r, (line) => {
      if (line.type === "progress") status.textContent = `faults: ${progressText(line)}`;
      else if (line.type === "value" || (line.type === "error" && line.key)) {
        const tr = el("tr");
        tr.append(el("td", "number", line.label), el("td", null, line.name_en || ""), el("td", "muted", line.name_de || ""),
          el("td", "value", line.type === "value" ? payloadText(line.payload) : line.message));
        table.append(tr);
      } else if (line.type === "end") status.textContent = `faults: ${line.read} read`;
      else if (line.type === "error") status.textContent = `faults: ${line.message}`;
    });
  });

  backup.addEventListener("click", async () => {
    const file = await fetchBackup(b, d, status);
    if (file) download(`backup-${plant.buses[b].name}-${plant.buses[b].drives[d].name}.json`, "application/json", file + "\n");
    window.lastBackup = file;
  });

  fileInput.addEventListener("change", async () => {
    const f = fileInput.files[0];
    if (!f) return;
    const text = await f.text();
    fileInput.value = "";
    await restorePlan(b, d, f.name, text, status, out);
  });

  compareWith.addEventListener("change", async () => {
    const which = compareWith.value;
    compareWith.value = "";
    if (!which) return;
    const [ob, od] = which.split("/").map(Number);
    const other = await fetchBackup(ob, od, status);
    const mine = await fetchBackup(b, d, status);
    if (mine && other) showCompare(out, plant.buses[b].drives[d].name, mine, plant.buses[ob].drives[od].name, other);
  });

  compareFile.addEventListener("change", async () => {
    const f = compareFile.files[0];
    if (!f) return;
    const other = await f.text();
    compareFile.value = "";
    const mine = await fetchBackup(b, d, status);
    if (mine) showCompare(out, plant.buses[b].drives[d].name, mine, f.name, other);
  });
}

// Two backups side by side: the parameters whose raw values differ.
function compareBackups(aText, bText) {
  const parse = (t) => {
    const doc = JSON.parse(t.replace(/^\uFEFF/, ""));
    return new Map((doc.parameters || []).map((p) => [`${p.index}.${p.sub}`, p]));
  };
  const a = parse(aText), other = parse(bText);
  const rows = [];
  let same = 0;
  for (const [k, p] of a) {
    const q = other.get(k);
    if (q && q.raw === p.raw) same++;
    else rows.push({ key: k, number: p.number, name: p.name, a: p.raw, b: q ? q.raw : null });
  }
  for (const [k, q] of other) if (!a.has(k)) rows.push({ key: k, number: q.number, name: q.name, a: null, b: q.raw });
  return { rows, same };
}

function showCompare(out, aName, aText, bName, bText) {
  let c;
  try { c = compareBackups(aText, bText); } catch (e) { out.replaceChildren(el("p", "refused", `not a backup file: ${e.message}`)); return; }
  const table = el("table", "compare");
  const head = el("tr");
  head.append(el("th", null, "parameter"), el("th", null, "name"), el("th", null, `${aName} (raw)`), el("th", null, `${bName} (raw)`));
  table.append(head);
  for (const r of c.rows) {
    const tr = el("tr");
    tr.dataset.key = r.key;
    tr.append(el("td", "number", r.number), el("td", null, r.name || ""), el("td", "value", r.a === null ? "—" : String(r.a)), el("td", "value", r.b === null ? "—" : String(r.b)));
    table.append(tr);
  }
  out.replaceChildren(el("h3", null, `Compare: ${c.rows.length} parameter(s) differ, ${c.same} the same`), table);
}

// The plan of restoring a file, then (asked) the restore with its progress and report.
async function restorePlan(b, d, name, text, status, out) {
  const q = new URLSearchParams({ name });
  out.replaceChildren(el("h3", null, `Restore ${name}: the plan`));
  let plan = null;
  await readLines(await postTo(`/api/drive/${b}/${d}/restore?${q}`, text, "application/json"), (line) => {
    if (line.type === "progress") status.textContent = `plan: ${progressText(line)}`;
    else if (line.type === "plan") plan = line;
    else if (line.type === "error") { status.textContent = `plan: ${line.message}`; out.append(el("p", "refused", line.message)); }
  });
  if (!plan) return;
  const s = plan.summary;
  status.textContent = `plan: ${s.changes} change(s), ${s.unchanged} unchanged, ${s.skipped.length} skipped, ${plan.refused.length} refused`;
  const table = el("table", "plan");
  const head = el("tr");
  head.append(el("th", null, "parameter"), el("th", null, "name"), el("th", null, "now"), el("th", null, "→ file"));
  table.append(head);
  for (const c of plan.changes) {
    const tr = el("tr");
    tr.dataset.label = c.label;
    const unit = c.unit ? ` ${c.unit}` : "";
    tr.append(el("td", "number", c.label), el("td", null, c.name_en || ""), el("td", "value", `${c.from}${unit}`), el("td", "value", `${c.to}${unit}`));
    table.append(tr);
  }
  out.append(table);
  for (const r of plan.refused) out.append(el("p", "refused", `refused: ${r}`));
  if (s.skipped.length) {
    const details = el("details");
    details.append(el("summary", null, `${s.skipped.length} entries not restored`));
    const ul = el("ul");
    for (const k of s.skipped) ul.append(el("li", null, `${k.label} ${k.name_en || ""}: ${k.message}`));
    details.append(ul);
    out.append(details);
  }
  if (!plan.changes.length || plan.refused.length) {
    out.append(el("p", "muted", plan.refused.length ? "nothing will be written while a change is refused" : "the drive already holds the file's values"));
    return;
  }
  const go = el("button", null, `restore these ${plan.changes.length} change(s) to EEPROM`);
  go.type = "button";
  go.id = "restore-apply";
  out.append(go);
  go.addEventListener("click", async () => {
    go.disabled = true;
    const report = el("div", "report");
    out.append(report);
    await readLines(await postTo(`/api/drive/${b}/${d}/restore?${new URLSearchParams({ name, apply: true })}`, text, "application/json"), (line) => {
      if (line.type === "progress") status.textContent = `restore: ${progressText(line)}`;
      else if (line.type === "written") {
        const unit = line.unit ? ` ${line.unit}` : "";
        report.append(el("div", "ok", `written ${line.label}: ${line.from}${unit} → ${line.to}${unit}`));
      }
      else if (line.type === "restored") {
        const r = line.report;
        status.textContent = `restored: ${r.written} written, ${r.unchanged} unchanged, ${r.mismatches} mismatch(es)`;
        for (const f of line.shortfalls) report.append(el("p", "refused", f));
        report.dataset.done = "restored";
      } else if (line.type === "halted") { report.append(el("p", "refused", line.message)); report.dataset.done = "halted"; }
      else if (line.type === "error") { report.append(el("p", "refused", line.message)); report.dataset.done = "error"; }
    });
  });
}
