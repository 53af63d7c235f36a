// The drive view's control over process data, for a drive the config lets the page drive
// (`page_control = true`): enable with a setpoint, a new setpoint, stop. The page holds a lease
// (an answer of JSON lines that stays open) while it drives; when the lease ends (this page
// closed or reloaded, the view left, the connection lost) the gateway stops the drive.
"use strict";

let controlLease = null; // { n, abort, b, d, driving }

function endLease() {
  if (controlLease) {
    clearInterval(controlLease.alive);
    controlLease.abort.abort();
    controlLease = null;
  }
}

// Open the lease of drive `d` on bus `b`: its number once the first line came (or why not);
// every later line goes to `onLine`, then `{type: "ended"}`.
function openLease(b, d, onLine) {
  const abort = new AbortController();
  return new Promise((resolve) => {
    let first = true;
    (async () => {
      try {
        if (csrfToken === null) await sessionReady();
        const r = await fetch(`/api/drive/${b}/${d}/control/lease`, {
          method: "POST", headers: { "X-CSRF-Token": csrfToken || "" }, cache: "no-store", signal: abort.signal,
        });
        await readLines(r, (line) => {
          if (first) {
            first = false;
            resolve(line.type === "lease" ? { n: line.lease, abort, b, d, driving: false } : { error: line.message });
          } else {
            onLine(line);
          }
        });
      } catch (e) {
        if (first) resolve({ error: String(e) });
      }
      if (first) resolve({ error: "the gateway ended the lease" });
      onLine({ type: "ended" });
    })();
  });
}

function driveControl(b, d, view, bus, drive) {
  if (!drive.control) {
    if (bus.protocol.startsWith("modbus")) {
      view.append(el("p", "muted", "Bonfiglioli drives have no process data in the gateway: no control from this page."));
    }
    return;
  }
  const box = el("section", "control");
  box.id = "control";
  const note = el("p", "control-note",
    "Enable moves the motor from this page. Closing or reloading this page, leaving this view or losing the connection stops the drive.");
  const state = el("div", "figures", "not driven from this page");
  state.id = "control-state";
  const setpoint = el("input");
  setpoint.id = "control-setpoint";
  setpoint.type = "text";
  setpoint.inputMode = "decimal";
  setpoint.value = "0";
  setpoint.size = 8;
  const label = el("label", null, "setpoint ");
  label.append(setpoint, el("span", null, ` ${drive.control.unit}`));
  const enable = el("button", null, "enable");
  enable.id = "control-enable";
  enable.type = "button";
  const stop = el("button", null, "stop");
  stop.id = "control-stop";
  stop.type = "button";
  const message = el("div", "figures");
  message.id = "control-message";
  const row = el("div", "tools");
  row.append(label, enable, stop);
  box.append(el("h3", null, "Process data control"), note, row, state, message);
  view.append(box);

  const show = (line) => {
    if (line.type === "state") {
      const what = line.command === "enable" ? `enabled at ${line.setpoint}` : (line.command || "nothing sent yet");
      state.textContent = `${what} · the drive: ${line.state || "?"} · in ${line.in.map((w) => w.toString(16).padStart(4, "0")).join(" ")}`;
      if (line.refused) message.textContent = line.refused;
    } else if (line.type === "ended") {
      state.textContent = "not driven from this page (the lease ended)";
      if (controlLease && controlLease.b === b && controlLease.d === d) endLease();
    }
  };
  const send = async (action) => {
    const r = await postTo(`/api/drive/${b}/${d}/control`, JSON.stringify({ lease: controlLease.n, action, setpoint: setpoint.value }));
    let j = {};
    try { j = await r.json(); } catch (_) { /* not JSON */ }
    message.textContent = j.message || `the gateway answered ${r.status}`;
    return r.ok;
  };
  enable.addEventListener("click", async () => {
    if (!controlLease) {
      message.textContent = "taking the drive…";
      const lease = await openLease(b, d, show);
      if (lease.error) { message.textContent = lease.error; return; }
      controlLease = lease;
      // The gateway stops the drive when it does not hear from this page for 5 s.
      lease.alive = setInterval(() => {
        postTo(`/api/drive/${b}/${d}/control`, JSON.stringify({ lease: lease.n, action: "alive" })).catch(() => {});
      }, 1000);
    }
    const ok = await send(controlLease.driving ? "setpoint" : "enable");
    if (ok && controlLease) controlLease.driving = true;
  });
  stop.addEventListener("click", async () => {
    if (!controlLease) { message.textContent = "not driven from this page"; return; }
    if (await send("stop")) endLease();
  });
}

// Leaving the drive's view ends the lease (the gateway stops the drive).
window.addEventListener("hashchange", () => {
  if (controlLease && location.hash !== `#drive/${controlLease.b}/${controlLease.d}`) endLease();
});
window.addEventListener("beforeunload", (e) => {
  if (controlLease && controlLease.driving) {
    e.preventDefault();
    e.returnValue = "";
  }
});
