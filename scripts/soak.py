#!/usr/bin/env python3
"""The MQTT side of scripts/soak (and its arithmetic): run by that script, not by hand.

    soak.py plant PLANT.toml          one line per bus: name protocol baud bitrate addr,addr,...
    soak.py watch --dir D ...         the observer: subscribes to the gateway's topics until
                                      SIGTERM; checks the order of every payload's `ts`, counts
                                      messages, records every set result; D/state.txt says what
                                      it sees now (the script waits on it)
    soak.py burst --dir D ...         publishes a burst of sets (QoS 1, `ts`, a unique `id`) to
                                      the plant's writable points and appends them to D/sent.jsonl
    soak.py report --dir D            the checks at the end (PASS/FAIL lines); exit 1 on a FAIL

Needs paho-mqtt 1.6.1 (scripts/soak puts it in a venv). Only the standard library otherwise.
"""

import argparse
import csv
import json
import os
import random
import signal
import statistics
import sys
import threading
import time
import tomllib

# ---------------------------------------------------------------------------------------------
# The plant


def plant_buses(path):
    """(name, protocol, baud, bitrate, [addresses], [drives], [drives under process data]) of
    every bus of a gateway config."""
    with open(path, "rb") as f:
        plant = tomllib.load(f)
    for bus in plant.get("bus", []):
        drives = bus.get("drive", [])
        yield (
            bus["name"],
            bus["protocol"],
            int(bus.get("baud", 9600)),
            str(bus.get("bitrate", "500k")),
            [int(d["address"]) for d in drives],
            [d["name"] for d in drives],
            [d["name"] for d in drives if "process_data" in d],
        )


def writable_points(path):
    """(bus, drive, point name, parameter) of every `writable = true` point."""
    with open(path, "rb") as f:
        plant = tomllib.load(f)
    for bus in plant.get("bus", []):
        for drive in bus.get("drive", []):
            for p in drive.get("param", []):
                if p.get("writable"):
                    yield bus["name"], drive["name"], p.get("name", p["param"]), p["param"]


def cmd_plant(args):
    for name, protocol, baud, bitrate, addrs, drives, pd in plant_buses(args.config):
        print(name, protocol, baud, bitrate, ",".join(map(str, addrs)), ",".join(drives),
              ",".join(pd) or "-")


# ---------------------------------------------------------------------------------------------
# MQTT


def mqtt_client(client_id, clean):
    import paho.mqtt.client as mqtt  # noqa: PLC0415 (only the MQTT commands need it)

    c = mqtt.Client(client_id=client_id, clean_session=clean, protocol=mqtt.MQTTv311)
    c.reconnect_delay_set(min_delay=0.2, max_delay=2)
    c.max_inflight_messages_set(100)
    return c


def now_ms():
    return time.time_ns() // 1_000_000


def write_atomically(path, text):
    tmp = f"{path}.tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


class Watch:
    """What the observer has seen. Called from paho's network thread and the main thread."""

    def __init__(self, out, prefix):
        self.out = out
        self.prefix = prefix.rstrip("/") + "/"
        self.lock = threading.Lock()
        self.log = open(os.path.join(out, "monitor.log"), "a", buffering=1)
        self.results = open(os.path.join(out, "results.jsonl"), "a", buffering=1)
        self.connected = False
        self.connects = 0
        self.messages = 0
        self.by_kind = {}
        # Per topic: messages, the last `ts`, backwards steps, first and last arrival.
        self.topics = {}
        self.out_of_order = []
        # Per drive ("bus/drive"): its state; per value topic: stale or not.
        self.drive_state = {}
        self.stale = {}
        self.gateway = "unknown"
        self.dirty = True

    def note(self, text):
        self.log.write(f"{now_ms()} {text}\n")

    def on_connect(self, client, _userdata, flags, rc):
        with self.lock:
            self.connected = rc == 0
            self.connects += 1
            present = bool(flags.get("session present"))
            self.note(f"connected rc={rc} session_present={present}")
            self.dirty = True
        # A persistent session keeps the subscription (and what arrived meanwhile) across a
        # broker restart; subscribing again would replay every retained topic.
        if rc == 0 and not present:
            client.subscribe(self.prefix + "#", qos=1)

    def on_disconnect(self, _client, _userdata, rc):
        with self.lock:
            self.connected = False
            self.note(f"disconnected rc={rc}")
            self.dirty = True

    def kind(self, levels):
        """What a topic under the gateway's prefix is, by its levels."""
        if levels == ["status"]:
            return "gateway"
        if len(levels) == 2 and levels[1] == "status":
            return "bus_status"
        if len(levels) == 3:
            return {"status": "drive_status", "pd": "pd"}.get(levels[2], "value")
        if len(levels) == 4 and levels[3] in ("result", "set"):
            return levels[3]
        return "other"

    def on_message(self, _client, _userdata, msg):
        arrived = now_ms()
        if not msg.topic.startswith(self.prefix):
            return
        levels = msg.topic[len(self.prefix) :].split("/")
        kind = self.kind(levels)
        with self.lock:
            self.messages += 1
            self.by_kind[kind] = self.by_kind.get(kind, 0) + 1
            self.dirty = True
            if kind == "set":
                return  # our own sets, echoed by the broker (MQTT 3.1.1 has no no-local)
            t = self.topics.setdefault(
                msg.topic,
                {"kind": kind, "messages": 0, "last_ts": None, "last": None, "backwards": 0,
                 "redelivered": 0, "first": arrived, "arrived": arrived},
            )
            t["messages"] += 1
            t["arrived"] = arrived
            if msg.dup:
                t["redelivered"] += 1
            if kind == "gateway":
                # {"state": "online", "config": {...}, ...}; its state is what is followed.
                text = msg.payload.decode(errors="replace")
                try:
                    self.gateway = json.loads(text).get("state", text)
                except (ValueError, AttributeError):
                    self.gateway = text or "(cleared)"
                self.note(f"gateway {self.gateway} retain={int(msg.retain)}")
                return
            if not msg.payload:
                self.note(f"cleared {msg.topic}")
                return
            try:
                payload = json.loads(msg.payload)
            except ValueError:
                self.note(f"not JSON on {msg.topic}: {msg.payload[:200]!r}")
                return
            if kind == "result":
                self.result(msg, levels, payload, arrived)
                return
            ts = payload.get("ts") if isinstance(payload, dict) else None
            if isinstance(ts, int):
                if t["last_ts"] is not None and ts < t["last_ts"]:
                    # Published out of order (or replayed by the broker: `retain`, `dup` say).
                    t["backwards"] += 1
                    record = {
                        "topic": msg.topic, "kind": kind, "arrived": arrived,
                        "ts": ts, "previous_ts": t["last_ts"], "retain": bool(msg.retain),
                        "dup": bool(msg.dup), "payload": payload, "previous": t["last"],
                    }
                    self.out_of_order.append(record)
                    self.note("OUT OF ORDER " + json.dumps(record))
                t["last_ts"] = ts
                t["last"] = payload
            if kind == "drive_status":
                drive = "/".join(levels[:2])
                state = payload.get("state")
                if self.drive_state.get(drive) != state:
                    self.note(f"drive {drive} {state}")
                self.drive_state[drive] = state
            elif kind == "value":
                self.stale[msg.topic] = bool(payload.get("stale"))

    def result(self, msg, levels, payload, arrived):
        rec = {
            "arrived": arrived, "topic": msg.topic, "point": "/".join(levels[:3]),
            "id": payload.get("id"), "ok": payload.get("ok"), "outcome": payload.get("outcome"),
            "reason": payload.get("reason"), "ts": payload.get("ts"),
            "dup": bool(msg.dup), "retain": bool(msg.retain),
            "payload": payload,
        }
        self.results.write(json.dumps(rec, sort_keys=True) + "\n")

    def state_text(self):
        """What the soak script waits on, one fact per line."""
        lines = [
            f"connected {int(self.connected)}",
            f"gateway {self.gateway}",
            f"messages {self.messages}",
            f"out_of_order {len(self.out_of_order)}",
        ]
        for drive, state in sorted(self.drive_state.items()):
            mine = [s for topic, s in self.stale.items() if topic.startswith(self.prefix + drive + "/")]
            lines.append(f"drive {drive} {state} {sum(mine)}/{len(mine)}")
        return "\n".join(lines) + "\n"

    def summary(self):
        return {
            "messages": self.messages,
            "by_kind": self.by_kind,
            "connects": self.connects,
            "gateway": self.gateway,
            "out_of_order": self.out_of_order,
            "topics": self.topics,
        }


def cmd_watch(args):
    watch = Watch(args.dir, args.prefix)
    client = mqtt_client(f"drivebus-soak-watch-{os.getpid()}", clean=False)
    client.on_connect = watch.on_connect
    client.on_disconnect = watch.on_disconnect
    client.on_message = watch.on_message
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    client.connect_async(args.host, args.port, keepalive=10)
    client.loop_start()
    state = os.path.join(args.dir, "state.txt")
    while not stop.is_set():
        with watch.lock:
            if watch.dirty:
                write_atomically(state, watch.state_text())
                watch.dirty = False
        stop.wait(0.2)
    # Whatever is still in flight gets a moment, then the books are closed.
    time.sleep(0.5)
    client.disconnect()
    client.loop_stop()
    with watch.lock:
        write_atomically(state, watch.state_text())
        write_atomically(os.path.join(args.dir, "watch.json"), json.dumps(watch.summary(), indent=1))
    watch.note("stopped")


# Values each writable parameter of the example plant takes (in its unit), and one it refuses
# (out of its range): a burst mixes in a few of those, so refusals are answered too.
VALUES = {
    "P130": ([1.0, 1.5, 2.0, 2.5, 3.0], 5000.0),  # ramp t11 up [s], 0–2000 s
    "P131": ([1.0, 1.5, 2.0, 2.5, 3.0], 5000.0),  # ramp t11 down [s]
    "P160": ([100.0, 150.0, 200.0, 300.0], 9999.0),  # internal setpoint n11 [1/min], ±5000
    "P161": ([100.0, 150.0, 200.0, 300.0], 9999.0),  # internal setpoint n12 [1/min]
    "P102": ([1.5, 2.0, 3.5, 7.5], 1000.0),  # NORD acceleration time [s], 0–320 s
    "P112": ([100, 120, 150, 200], 1000),  # NORD torque current limit [%], 25–401 %
    "481": ([5.0, 10.0, 12.5, 20.0], 1e12),  # Bonfiglioli fixed frequency 2 [Hz], 32 bits
}


def cmd_burst(args):
    points = [p for p in writable_points(args.config) if p[3] in VALUES]
    if not points:
        sys.exit("soak.py burst: the config has no writable point this script has values for")
    client = mqtt_client(f"drivebus-soak-burst-{os.getpid()}", clean=True)
    connected = threading.Event()
    client.on_connect = lambda c, u, f, rc: rc == 0 and connected.set()
    client.connect(args.host, args.port, keepalive=10)
    client.loop_start()
    if not connected.wait(args.timeout):
        client.loop_stop()
        sys.exit(f"soak.py burst: no connection to {args.host}:{args.port} within {args.timeout} s")
    rng = random.Random(args.tag)
    sent = []
    for i in range(args.count):
        bus, drive, point, param = points[i % len(points)]
        good, bad = VALUES[param]
        value = bad if rng.random() < args.bad else rng.choice(good)
        ident = f"{args.tag}-{i}"
        topic = f"{args.prefix}/{bus}/{drive}/{point}/set"
        body = json.dumps({"value": value, "ts": now_ms(), "id": ident})
        info = client.publish(topic, body, qos=1, retain=False)
        sent.append({"id": ident, "topic": topic, "value": value, "t": now_ms(), "info": info})
    deadline = time.monotonic() + args.timeout
    for s in sent:
        s["info"].wait_for_publish(max(0.0, deadline - time.monotonic()))
    acked = 0
    with open(os.path.join(args.dir, "sent.jsonl"), "a") as f:
        for s in sent:
            ok = s.pop("info").is_published()
            acked += ok
            s["acked"] = ok
            f.write(json.dumps(s, sort_keys=True) + "\n")
    client.disconnect()
    client.loop_stop()
    print(f"burst {args.tag}: {acked} of {len(sent)} sets taken by the broker")
    sys.exit(0 if acked == len(sent) else 3)


# ---------------------------------------------------------------------------------------------
# The report


def read_jsonl(path):
    if not os.path.exists(path):
        return []
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def median_of(rows, key):
    vals = [float(r[key]) for r in rows if r.get(key) not in (None, "")]
    return statistics.median(vals) if vals else None


class Verdicts:
    def __init__(self):
        self.failed = 0

    def check(self, ok, name, figures):
        print(f"{'PASS' if ok else 'FAIL'}  {name}: {figures}")
        self.failed += not ok


def flat(v, rows, key, label, unit, limit):
    """One "stays flat" check: the median of the tail's samples (the fault-free end) against
    the median of the baseline's (the fault-free minute from minute 2 or a sixth of the run)."""
    base_rows = [r for r in rows if r["phase"] == "baseline"]
    end_rows = [r for r in rows if r["phase"] == "tail"]
    base, end = median_of(base_rows, key), median_of(end_rows, key)
    if base is None or end is None or base <= 0:
        v.check(False, label, f"not enough samples (baseline {len(base_rows)}, tail {len(end_rows)})")
        return
    span = lambda rs: f"{float(rs[0]['elapsed_s']):.0f}–{float(rs[-1]['elapsed_s']):.0f} s"  # noqa: E731
    growth = (end - base) / base * 100
    values = [float(r[key]) for r in rows if r.get(key)]
    v.check(
        growth < limit,
        label,
        f"{growth:+.2f} % (median {end:g} {unit} over the tail's {len(end_rows)} samples, "
        f"{span(end_rows)}, against {base:g} {unit} over the baseline's {len(base_rows)}, "
        f"{span(base_rows)}; first sample {values[0]:g}, min {min(values):g}, max {max(values):g}; "
        f"limit < {limit:g} %)",
    )


def cmd_report(args):
    d = args.dir
    v = Verdicts()
    with open(os.path.join(d, "samples.csv")) as f:
        rows = [r for r in csv.DictReader(f) if r.get("rss_kb")]
    if not rows:
        v.check(False, "samples", "none recorded")
        return sys.exit(1)
    length = float(rows[-1]["elapsed_s"])
    # "After the first minutes": the baseline is the fault-free minute the schedule keeps from
    # minute 2 or a sixth of the run (the later), after the start-up and fault cycles; the end is the fault-free
    # tail, the last 10 % of the run. In both every port is open and the broker up.
    print(f"run: {length:.0f} s, {len(rows)} samples every {args.interval} s")
    flat(v, rows, "rss_kb", "memory flat (VmRSS)", "kB", 1.0)
    flat(v, rows, "fds", "descriptors flat (/proc/PID/fd)", "fds", 1.0)
    # The runtime's tasks and the gateway's own: a task left behind by a reconnection, a port
    # reopened or a set would climb.
    flat(v, rows, "tasks", "tasks flat (drivebus_runtime_tasks)", "tasks", 1.0)
    # The curve: VmRSS at the end of every tenth of the run (a leak climbs on steadily, a
    # warm-up flattens out).
    for key, what in (("rss_kb", "VmRSS"), ("rss_anon_kb", "RssAnon"), ("rss_file_kb", "RssFile")):
        tenths = []
        for i in range(1, 11):
            upto = [r for r in rows if float(r["elapsed_s"]) <= length * i / 10 and r.get(key)]
            if upto:
                tenths.append(upto[-1][key])
        print(f"info  {what} (kB) at each tenth of the run: {' '.join(tenths)}")
    ints = lambda k: [int(r[k]) for r in rows if r.get(k, "").lstrip("-").isdigit()]  # noqa: E731
    for key, what in (("threads", "threads"), ("tasks", "runtime tasks (drivebus_runtime_tasks)")):
        xs = ints(key)
        if xs:
            print(f"info  {what}: first {xs[0]}, last {xs[-1]}, min {min(xs)}, max {max(xs)}")
    fds = ints("fds")
    if fds:
        print(f"info  descriptors: first {fds[0]}, last {fds[-1]}, min {min(fds)}, max {max(fds)}")

    # Every set answered exactly once, by id.
    sent = read_jsonl(os.path.join(d, "sent.jsonl"))
    results = read_jsonl(os.path.join(d, "results.jsonl"))
    acked = {s["id"]: s for s in sent if s.get("acked")}
    unacked = [s["id"] for s in sent if not s.get("acked")]
    by_id = {}
    for r in results:
        by_id.setdefault(json.dumps(r["id"]), []).append(r)
    missing = [i for i in acked if json.dumps(i) not in by_id]
    # When the gateway's connection was down (drivebus_broker_connected 0, sampled every 2 s;
    # the broker's outages last 5 s or more).
    outages = [int(r["time"]) for r in rows if r.get("broker_connected") == "0"]
    redelivered, republished, duplicates, unexpected = 0, 0, [], []
    for key, rs in by_id.items():
        if json.loads(key) not in acked:
            unexpected.append(rs[0])
            continue
        first, again = rs[0], rs[1:]
        for r in again:
            if r["payload"] != first["payload"]:
                # Another answer to the same set: executed or answered twice.
                duplicates.append(r)
            elif r["dup"]:
                # The broker re-sent its copy to the observer (dup flag): the observer's QoS 1.
                redelivered += 1
            elif any(first["arrived"] < t < r["arrived"] for t in outages):
                # The same result (its `ts` too) published again after the gateway's connection
                # died before the broker's PUBACK came (QoS 1: gateway.md, "a result the broker
                # had not acknowledged ... is published again"); the broker passes it on as a
                # new message, without the dup flag.
                republished += 1
            else:
                duplicates.append(r)
    outcomes = {}
    for rs in by_id.values():
        o = rs[0]["outcome"] if rs[0]["outcome"] != "refused" else f"refused:{rs[0]['reason']}"
        outcomes[o] = outcomes.get(o, 0) + 1
    # The gateway's own count (drivebus_sets_total) at the last sample, taken after the tail.
    counted = next((int(r["sets"]) for r in reversed(rows) if r.get("sets", "").isdigit()), -1)
    v.check(
        not missing and not duplicates and not unexpected and counted == len(acked),
        "every set answered exactly once",
        f"{len(acked)} sent (taken by the broker), {counted} counted by the gateway "
        f"(drivebus_sets_total), {len(acked) - len(missing)} answered, "
        f"{len(missing)} missing, {len(duplicates)} duplicate, {len(unexpected)} unasked-for; "
        f"{redelivered} redelivered copies to the observer (dup flag) and {republished} "
        f"published again after a lost connection (same payload and ts, unacknowledged "
        f"when the connection died) not counted; "
        f"outcomes {json.dumps(dict(sorted(outcomes.items())))}"
        + (f"; {len(unacked)} not taken by the broker, not counted" if unacked else ""),
    )
    for i in missing[:10]:
        print(f"      missing: {acked[i]}")
    for r in (duplicates + unexpected)[:10]:
        print(f"      duplicate/unexpected: {json.dumps(r)}")

    # No value out of order; messages per topic.
    with open(os.path.join(d, "watch.json")) as f:
        watch = json.load(f)
    ooo = watch["out_of_order"]
    by_kind = {}
    for r in ooo:
        by_kind[r["kind"]] = by_kind.get(r["kind"], 0) + 1
    topics = watch["topics"]
    checked = [t for t in topics.values() if t["kind"] in ("value", "pd", "drive_status", "bus_status")]
    v.check(
        not ooo,
        "no value published out of order",
        f"{len(ooo)} backward `ts` steps {json.dumps(by_kind)} over {len(checked)} topics "
        f"({sum(t['messages'] for t in checked)} messages with a `ts`)",
    )
    for r in ooo[:10]:
        print(f"      {json.dumps(r)}")
    print(f"info  messages: {watch['messages']} {json.dumps(dict(sorted(watch['by_kind'].items())))}, "
          f"observer connections {watch['connects']}")
    with open(os.path.join(d, "topics.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["topic", "kind", "messages", "backwards", "redelivered"])
        for name, t in sorted(topics.items()):
            w.writerow([name, t["kind"], t["messages"], t["backwards"], t["redelivered"]])
    per_kind = {}
    for t in topics.values():
        per_kind.setdefault(t["kind"], []).append(t["messages"])
    for kind, counts in sorted(per_kind.items()):
        print(f"info  per {kind} topic: {len(counts)} topics, messages min {min(counts)}, "
              f"median {statistics.median(counts):g}, max {max(counts)}")
    print(f"info  messages per topic: {os.path.join(d, 'topics.csv')}")
    sys.exit(1 if v.failed else 0)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("plant")
    p.add_argument("config")
    for name in ("watch", "burst"):
        p = sub.add_parser(name)
        p.add_argument("--dir", required=True)
        p.add_argument("--host", default="127.0.0.1")
        p.add_argument("--port", type=int, required=True)
        p.add_argument("--prefix", required=True, help="<prefix>/<gateway name>")
        if name == "burst":
            p.add_argument("--config", required=True)
            p.add_argument("--count", type=int, default=50)
            p.add_argument("--tag", required=True, help="the ids are TAG-0, TAG-1, …")
            p.add_argument("--bad", type=float, default=0.1, help="share of out-of-range values")
            p.add_argument("--timeout", type=float, default=20)
    p = sub.add_parser("report")
    p.add_argument("--dir", required=True)
    p.add_argument("--interval", default="?")
    args = ap.parse_args()
    {"plant": cmd_plant, "watch": cmd_watch, "burst": cmd_burst, "report": cmd_report}[args.cmd](args)


if __name__ == "__main__":
    main()
