// Who uses the page: the session (GET /api/session), the log-in form when the gateway asks
// for one, the user and role in the header with a log-out button, and post(): every POST with
// the CSRF token. Loaded before app.js, which starts once sessionReady() resolves.
"use strict";

let csrfToken = null;
let sessionInfo = null;

// The gateway's config generation of the plant this page shows (app.js) and of the open drive
// view: sent with every request that names a bus by its number, so that after a reload of the
// gateway's config a request reaches the drive this page means, or is refused (409: its bus was
// removed or changed), never another drive that now has that number.
let plantGeneration = null;
let driveGeneration = null;
const plainFetch = window.fetch.bind(window);
window.fetch = (input, init) => {
  const path = typeof input === "string" ? input : "";
  const g = path.startsWith("/api/drive/") ? driveGeneration
    : path.startsWith("/api/history/") ? plantGeneration : null;
  if (g === null) return plainFetch(input, init);
  const o = Object.assign({}, init || {});
  o.headers = Object.assign({}, o.headers || {}, { "X-Drivebus-Generation": String(g) });
  return plainFetch(input, o);
};

function loginEl(tag, attrs, text) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
  if (text !== undefined) e.textContent = text;
  return e;
}

// POST `body` as JSON to `path` with the CSRF token; the fetch's Response. A 401 (the
// session ended) shows the log-in form again.
async function post(path, body) {
  if (csrfToken === null) await sessionReady();
  const r = await fetch(path, {
    method: "POST",
    cache: "no-store",
    headers: { "Content-Type": "application/json", "X-CSRF-Token": csrfToken || "" },
    body: JSON.stringify(body === undefined ? {} : body),
  });
  if (r.status === 401 && sessionInfo && sessionInfo.login_required) showLogin("the session ended: log in again");
  return r;
}

function showWho() {
  const header = document.querySelector("header");
  let who = document.getElementById("who");
  if (!who) {
    who = loginEl("span", { id: "who", class: "who" });
    header.append(who);
  }
  who.replaceChildren();
  if (!sessionInfo || !sessionInfo.login_required || !sessionInfo.user) return;
  who.append(loginEl("span", { class: "muted" }, `${sessionInfo.user} (${sessionInfo.role}) `));
  const out = loginEl("button", { id: "logout", type: "button" }, "log out");
  out.addEventListener("click", async () => {
    await post("/api/logout", {});
    location.reload();
  });
  who.append(out);
}

let loginDone = null;

function showLogin(why) {
  let form = document.getElementById("login");
  if (!form) {
    form = loginEl("form", { id: "login", class: "login" });
    form.append(
      loginEl("h2", {}, "Log in"),
      loginEl("label", { for: "login-user" }, "user"),
      loginEl("input", { id: "login-user", name: "user", autocomplete: "username", required: "" }),
      loginEl("label", { for: "login-password" }, "password"),
      loginEl("input", { id: "login-password", name: "password", type: "password", autocomplete: "current-password", required: "" }),
      loginEl("button", { id: "login-submit", type: "submit" }, "log in"),
      loginEl("p", { id: "login-message", class: "message", role: "alert" }),
    );
    form.addEventListener("submit", submitLogin);
    document.querySelector("header").after(form);
  }
  for (const id of ["plant", "drive", "trend"]) {
    const e = document.getElementById(id);
    if (e) e.hidden = true;
  }
  form.hidden = false;
  const link = document.getElementById("link");
  if (link) link.textContent = "not logged in";
  document.getElementById("login-message").textContent = why || "";
  document.getElementById("login-user").focus();
}

let waitTimer = null;

function waitOut(secs) {
  const button = document.getElementById("login-submit");
  const message = document.getElementById("login-message");
  clearInterval(waitTimer);
  button.disabled = true;
  let left = secs;
  const tick = () => {
    if (left <= 0) {
      clearInterval(waitTimer);
      button.disabled = false;
      message.textContent = "try again";
      return;
    }
    message.textContent = `too many attempts: wait ${left} s`;
    left -= 1;
  };
  tick();
  waitTimer = setInterval(tick, 1000);
}

async function submitLogin(ev) {
  ev.preventDefault();
  const message = document.getElementById("login-message");
  const user = document.getElementById("login-user").value;
  const password = document.getElementById("login-password").value;
  message.textContent = "checking…";
  let r;
  try {
    r = await fetch("/api/login", {
      method: "POST",
      cache: "no-store",
      headers: { "Content-Type": "application/json" },
      body: JSON.stringify({ user, password }),
    });
  } catch (e) {
    message.textContent = "the gateway cannot be reached";
    return;
  }
  const answer = await r.json().catch(() => ({}));
  if (r.ok) {
    document.getElementById("login-password").value = "";
    message.textContent = "";
    sessionInfo = answer;
    csrfToken = answer.csrf;
    if (loginDone) {
      loginDone();
      loginDone = null;
      document.getElementById("login").hidden = true;
      document.getElementById("plant").hidden = false;
      showWho();
    } else {
      location.reload();
    }
  } else if (r.status === 429) {
    waitOut(answer.retry_after || Number(r.headers.get("Retry-After")) || 1);
  } else {
    message.textContent = answer.message || `refused (${r.status})`;
  }
}

let readyPromise = null;

// Resolves once the page may load the plant: at once without users or with a session, after
// the log-in otherwise.
function sessionReady() {
  if (!readyPromise) {
    readyPromise = (async () => {
      const r = await fetch("/api/session", { cache: "no-store" });
      sessionInfo = await r.json();
      csrfToken = sessionInfo.csrf;
      if (sessionInfo.login_required && !sessionInfo.user) {
        await new Promise((resolve) => {
          loginDone = resolve;
          showLogin("");
        });
      }
      showWho();
    })();
  }
  return readyPromise;
}
