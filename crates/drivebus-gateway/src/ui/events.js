// One event stream for every tab of the page in this browser: a shared worker holds the one
// EventSource and hands each event to every tab. A browser opens at most six HTTP/1.1
// connections to one host; with a stream per tab, a seventh tab would wait for ever.
"use strict";

const ports = new Set();
let source = null;
let open = false;

function send(message) {
  for (const p of ports) p.postMessage(message);
}

function start() {
  source = new EventSource("/api/events");
  source.onopen = () => { open = true; send({ kind: "open" }); };
  source.onerror = () => { open = false; send({ kind: "error" }); };
  source.onmessage = (m) => send({ kind: "event", data: m.data });
}

onconnect = (e) => {
  const port = e.ports[0];
  ports.add(port);
  // A tab that closes says so; the last one gone closes the stream.
  port.onmessage = (m) => {
    if (m.data !== "bye") return;
    ports.delete(port);
    if (ports.size === 0 && source) { source.close(); source = null; open = false; }
  };
  port.start();
  if (!source) start();
  else if (open) port.postMessage({ kind: "open" });
};
