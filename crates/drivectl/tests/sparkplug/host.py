"""A Sparkplug B host application for the gateway's tests, built on software nobody here wrote.

Payloads are decoded and encoded by pysparkplug (PyPI), topics parsed by it, and the MQTT
connection is paho-mqtt's: nothing of drivebus is used. scripts/setup-sparkplug installs the
pinned versions into target/sparkplug/venv; crates/drivectl/tests/common/spb_host.rs runs this
file with that venv's python.

    host.py BROKER_HOST BROKER_PORT GROUP_ID [--client-id ID] [--will-host HOST_ID]

It subscribes to spBv1.0/GROUP_ID/# and spBv1.0/STATE/# and prints one JSON object per line on
standard output:

    {"ready": true}                       once both subscriptions are acknowledged
    {"topic": ..., "type": "NBIRTH", "group": ..., "node": ..., "device": ... | null,
     "seq": ... | null, "expected_seq": ... | null, "timestamp": ... | null, "retained": ...,
     "metrics": [{"name": ... | null, "birth_name": ... | null, "alias": ... | null,
                  "datatype": "Int16", "datatype_sent": true, "value": ..., "is_null": ...,
                  "timestamp": ... | null, "properties": {key: value},
                  "property_types": {key: "String"}}]}
    {"topic": ..., "type": "STATE", "host": ..., "online": ..., "timestamp": ..., "retained": ...}
    {"topic": ..., "error": "..."}        a message pysparkplug cannot decode

`name` is the name as it came on the wire (null for a metric sent by alias only), `birth_name`
the name a host knows it by: the wire name, else the name its alias has in the last birth of
that node or device. `datatype` is the one pysparkplug decoded the value with (sent, or known
from the birth); `datatype_sent` says whether the message itself carried it. `expected_seq` is
the sequence number this host expected from that edge node (the previous one + 1, modulo 256;
0 for an NBIRTH; null when it has seen nothing before), so that a test sees a gap.

It reads one JSON command per line on standard input:

    {"cmd": "DCMD", "node": ..., "device": ..., "metrics": [{"name"|"alias": ...,
                    "datatype": "Int16" (optional), "value": ...}]}
    {"cmd": "NCMD", "node": ..., "metrics": [...]}
    {"cmd": "STATE", "host": ..., "online": true|false}
    {"cmd": "raw", "topic": ..., "hex": "..."}
    {"cmd": "encode", "type": "NBIRTH"|..., "seq": ..., "metrics": [...]}
    {"cmd": "quit"}

A DCMD or NCMD metric with a `datatype` carries it on the wire; without one it is sent without
(the value encoded as the datatype the last birth gave that metric, else as the JSON value's
kind: Boolean, Int64, Double or String). Each published command is answered with
{"published": topic, "hex": "..."}, an encode with {"encoded": "hex"}, a bad command with
{"command_error": "..."}. Optional keys: "group" (another group id), "timestamp" (the payload's),
"retain" and "qos" (DCMD/NCMD: false and 0, STATE: true and 1, raw: false and 0). An encode's
metrics may carry "properties": {key: {"datatype": "String", "value": ...}} and "timestamp".
STATE is the primary host's retained spBv1.0/STATE/HOST_ID {"online": ..., "timestamp": ...};
--will-host sets the connection's will to that host's STATE offline (Sparkplug 3.0, 7.2).

Known gaps of pysparkplug 0.6.1 that this file works around, each with the library's own
protobuf classes (pysparkplug._protobuf, generated from the Sparkplug B .proto by protoc):
its Metric has no properties (read and written here on its protobuf messages), and its NDeath
drops a timestamp that is present (read here from the protobuf message).
"""

import argparse
import datetime
import json
import math
import os
import sys
import threading

import paho.mqtt.client as mqtt

import pysparkplug
from pysparkplug import DataType, Metric, MessageType, Topic
from pysparkplug import _protobuf as pb  # the library's generated protobuf classes

# The datatype names of the Sparkplug B specification ("Int16", "UInt64", "Boolean"...), as the
# library's generated protobuf enum spells them.
_PB_DATATYPE = pb.DataType


def datatype_name(dt):
    try:
        return _PB_DATATYPE.Name(int(dt))
    except ValueError:
        return f"Unknown({int(dt)})"


def datatype_from_name(name):
    try:
        return DataType(_PB_DATATYPE.Value(name))
    except ValueError:
        raise ValueError(f"no Sparkplug datatype {name!r}") from None


def now_ms():
    return pysparkplug.get_current_timestamp()


def jsonable(value):
    """A decoded value as JSON: bytes as hex, times as epoch ms, non-finite floats as text."""
    if isinstance(value, bool) or value is None or isinstance(value, (int, str)):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    if isinstance(value, (bytes, bytearray)):
        return bytes(value).hex()
    if isinstance(value, datetime.datetime):
        return int(value.timestamp() * 1000)
    if isinstance(value, (tuple, list)):
        return [jsonable(v) for v in value]
    return str(value)


_out_lock = threading.Lock()


def emit(obj):
    line = json.dumps(obj, allow_nan=False)
    with _out_lock:
        sys.stdout.write(line + "\n")
        sys.stdout.flush()


# --- decoding --------------------------------------------------------------------------------


def property_value(pv):
    """A protobuf PropertyValue as (value, datatype name), decoded the way the library decodes
    metric values (its DataType's field and decoder)."""
    if pv.is_null:
        return None, datatype_name(pv.type)
    if pv.WhichOneof("value") == "propertyset_value":
        return property_set(pv.propertyset_value)[0], datatype_name(pv.type)
    dt = DataType(pv.type)
    return jsonable(dt.decode(getattr(pv, dt.field))), datatype_name(dt)


def property_set(ps):
    if len(ps.keys) != len(ps.values):
        raise ValueError(f"a property set with {len(ps.keys)} keys and {len(ps.values)} values")
    values, types = {}, {}
    for key, pv in zip(ps.keys, ps.values):
        values[key], types[key] = property_value(pv)
    return values, types


class Host:
    def __init__(self, group):
        self.group = group
        # The last birth per (group, node, device) (device None: the node's own), pysparkplug's
        # Birth objects: they resolve aliases and dropped datatypes of later messages.
        self.births = {}
        # The last seq seen per (group, node).
        self.seq = {}
        self.lock = threading.Lock()

    def decode(self, topic_text, raw, retained):
        try:
            topic = Topic.from_str(topic_text)
        except Exception as e:  # the library's word on a topic it cannot parse
            return {"topic": topic_text, "error": f"topic: {type(e).__name__}: {e}"}
        kind = topic.message_type
        try:
            if kind == MessageType.STATE:
                state = kind.payload.decode(raw)
                return {
                    "topic": topic_text,
                    "type": "STATE",
                    "host": topic.sparkplug_host_id,
                    "online": state.online,
                    "timestamp": state.timestamp,
                    "retained": retained,
                }
            return self.decode_payload(topic, topic_text, kind, raw, retained)
        except Exception as e:
            out = {"topic": topic_text, "error": f"{type(e).__name__}: {e}"}
            if kind is not None:
                out["type"] = str(kind)
            return out

    def decode_payload(self, topic, topic_text, kind, raw, retained):
        node_key = (topic.group_id, topic.edge_node_id)
        birth_key = (topic.group_id, topic.edge_node_id, topic.device_id)
        wire = pb.Payload.FromString(raw)
        seq = wire.seq if wire.HasField("seq") else None
        in_sequence = kind not in (MessageType.NCMD, MessageType.DCMD, MessageType.NDEATH)
        with self.lock:
            # The edge node's sequence, followed from the wire also where the library then
            # refuses the payload: the message was sent all the same.
            expected = None
            if kind == MessageType.NBIRTH:
                expected = 0
            elif in_sequence and node_key in self.seq:
                expected = (self.seq[node_key] + 1) % 256
            if in_sequence and seq is not None:
                self.seq[node_key] = seq
            birth = self.births.get(birth_key)
        if birth is None and kind in (
            MessageType.NDATA,
            MessageType.DDATA,
            MessageType.NCMD,
            MessageType.DCMD,
        ):
            for w in wire.metrics:
                if not w.HasField("name") or not w.HasField("datatype"):
                    raise ValueError(
                        "a metric without its name or datatype, and no birth of this "
                        "node or device seen to resolve it"
                    )
        payload = kind.payload.decode(raw, birth=birth)
        if kind == MessageType.NDEATH:
            metrics = [payload.bd_seq_metric]
        elif kind == MessageType.DDEATH:
            metrics = []
        else:
            metrics = list(payload.metrics)
        if len(metrics) > len(wire.metrics):
            raise ValueError("decoded more metrics than the message has")
        out_metrics = []
        for m, w in zip(metrics, wire.metrics):
            props, types = ({}, {})
            if w.HasField("properties"):
                props, types = property_set(w.properties)
            out_metrics.append(
                {
                    "name": w.name if w.HasField("name") else None,
                    "birth_name": m.name,
                    "alias": m.alias,
                    "datatype": datatype_name(m.datatype),
                    "datatype_sent": w.HasField("datatype"),
                    "value": jsonable(m.value),
                    "is_null": m.is_null,
                    "timestamp": m.timestamp,
                    "properties": props,
                    "property_types": types,
                }
            )
        with self.lock:
            if kind == MessageType.NBIRTH:
                # A new session of the node: every device birth before it is void.
                for k in [k for k in self.births if k[:2] == node_key]:
                    del self.births[k]
                self.births[birth_key] = payload
            elif kind == MessageType.DBIRTH:
                self.births[birth_key] = payload
            elif kind == MessageType.NDEATH:
                for k in [k for k in self.births if k[:2] == node_key]:
                    del self.births[k]
                self.seq.pop(node_key, None)
            elif kind == MessageType.DDEATH:
                self.births.pop(birth_key, None)
        return {
            "topic": topic_text,
            "type": str(kind),
            "group": topic.group_id,
            "node": topic.edge_node_id,
            "device": topic.device_id,
            "seq": seq,
            "expected_seq": expected,
            "timestamp": wire.timestamp if wire.HasField("timestamp") else None,
            "retained": retained,
            "metrics": out_metrics,
        }

    # --- encoding ----------------------------------------------------------------------------

    def datatype_for(self, spec, birth):
        """The datatype a command metric's value is encoded as, and whether it is sent."""
        if spec.get("datatype") is not None:
            return datatype_from_name(spec["datatype"]), True
        if birth is not None:
            name = spec.get("name")
            if name is None and spec.get("alias") is not None:
                try:
                    name = birth.get_name(int(spec["alias"]))
                except KeyError:
                    name = None
            if name is not None:
                try:
                    return birth.get_dtype(name), False
                except KeyError:
                    pass
        value = spec.get("value")
        if isinstance(value, bool):
            return DataType.BOOLEAN, False
        if isinstance(value, int):
            return DataType.INT64, False
        if isinstance(value, float):
            return DataType.DOUBLE, False
        if isinstance(value, str):
            return DataType.STRING, False
        raise ValueError(f"metric {spec}: no datatype given, none in a birth, none from its value")

    def metric(self, spec, birth, default_ts):
        if not isinstance(spec, dict):
            raise ValueError(f"a metric is an object: {spec!r}")
        dt, sent = self.datatype_for(spec, birth)
        value = spec.get("value")
        if value is not None and dt in (DataType.FLOAT, DataType.DOUBLE):
            value = float(value)
        return (
            Metric(
                timestamp=spec.get("timestamp", default_ts),
                name=spec.get("name"),
                alias=spec.get("alias"),
                datatype=dt,
                value=value,
                is_null=value is None,
            ),
            sent,
        )

    def command_payload(self, kind, cmd, birth):
        ts = cmd.get("timestamp", now_ms())
        metrics, sent = [], []
        for spec in cmd.get("metrics", []):
            m, s = self.metric(spec, birth, ts)
            metrics.append(m)
            sent.append(s)
        if any(sent) and not all(sent):
            raise ValueError(
                "give a datatype for every metric of a command or for none "
                "(the library sends datatypes for a whole payload or not at all)"
            )
        payload_type = MessageType(kind).payload
        return payload_type(timestamp=ts, metrics=tuple(metrics)).encode(include_dtypes=all(sent))

    def encode(self, cmd):
        """Any payload, as the library encodes it; properties added on its protobuf message."""
        kind = MessageType(cmd["type"])
        ts = cmd.get("timestamp", now_ms())
        specs = cmd.get("metrics", [])
        metrics = [self.metric(spec, None, ts)[0] for spec in specs]
        if kind in (MessageType.NBIRTH, MessageType.DBIRTH, MessageType.NDATA, MessageType.DDATA):
            payload = kind.payload(timestamp=ts, seq=cmd.get("seq", 0), metrics=tuple(metrics))
            raw = payload.encode(include_dtypes=cmd.get("include_dtypes", True))
        elif kind in (MessageType.NCMD, MessageType.DCMD):
            payload = kind.payload(timestamp=ts, metrics=tuple(metrics))
            raw = payload.encode(include_dtypes=cmd.get("include_dtypes", True))
        elif kind == MessageType.NDEATH:
            if len(metrics) != 1:
                raise ValueError("an NDEATH has exactly one metric, bdSeq")
            raw = pysparkplug.NDeath(timestamp=ts, bd_seq_metric=metrics[0]).encode()
        elif kind == MessageType.DDEATH:
            raw = pysparkplug.DDeath(timestamp=ts, seq=cmd.get("seq", 0)).encode()
        else:
            raise ValueError(f"cannot encode a {kind}")
        if any(isinstance(s, dict) and s.get("properties") for s in specs):
            message = pb.Payload.FromString(raw)
            for spec, w in zip(specs, message.metrics):
                for key, prop in (spec.get("properties") or {}).items():
                    dt = datatype_from_name(prop["datatype"])
                    w.properties.keys.append(key)
                    pv = w.properties.values.add()
                    pv.type = int(dt)
                    if prop.get("value") is None:
                        pv.is_null = True
                    else:
                        v = prop["value"]
                        if dt in (DataType.FLOAT, DataType.DOUBLE):
                            v = float(v)
                        setattr(pv, dt.field, dt.encode(v))
            raw = message.SerializeToString()
        return raw


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("broker_host")
    ap.add_argument("broker_port", type=int)
    ap.add_argument("group")
    ap.add_argument("--client-id", default=f"drivebus-test-host-{os.getpid()}")
    ap.add_argument("--will-host", default=None)
    args = ap.parse_args()

    host = Host(args.group)
    subscriptions = [(f"spBv1.0/{args.group}/#", 1), ("spBv1.0/STATE/#", 1)]
    client = mqtt.Client(client_id=args.client_id, clean_session=True, protocol=mqtt.MQTTv311)
    if args.will_host:
        will = pysparkplug.State(timestamp=now_ms(), online=False).encode()
        client.will_set(f"spBv1.0/STATE/{args.will_host}", will, qos=1, retain=True)
    pending = {}

    def on_connect(c, _userdata, _flags, rc):
        if rc != 0:
            emit({"connect_failed": rc, "reason": mqtt.connack_string(rc)})
            return
        result, mid = c.subscribe(subscriptions)
        if result != mqtt.MQTT_ERR_SUCCESS:
            emit({"connect_failed": result, "reason": mqtt.error_string(result)})
            return
        pending["mid"] = mid

    def on_subscribe(_c, _userdata, mid, granted):
        if mid == pending.get("mid"):
            if any(q == 0x80 for q in granted):
                emit({"subscribe_failed": list(granted)})
            else:
                emit({"ready": True})

    def on_message(_c, _userdata, message):
        emit(host.decode(message.topic, message.payload, bool(message.retain)))

    def on_disconnect(_c, _userdata, rc):
        emit({"disconnected": rc})

    client.on_connect = on_connect
    client.on_subscribe = on_subscribe
    client.on_message = on_message
    client.on_disconnect = on_disconnect
    client.connect(args.broker_host, args.broker_port, keepalive=10)
    client.loop_start()

    def publish(topic, raw, qos, retain):
        info = client.publish(topic, raw, qos=qos, retain=retain)
        info.wait_for_publish(timeout=5)
        if info.rc != mqtt.MQTT_ERR_SUCCESS or not info.is_published():
            raise RuntimeError(f"publish on {topic} failed: {mqtt.error_string(info.rc)}")
        emit({"published": topic, "hex": bytes(raw).hex()})

    for line in sys.stdin:
        line = line.strip()
        if not line:
            continue
        try:
            cmd = json.loads(line)
            what = cmd.get("cmd")
            group = cmd.get("group", args.group)
            if what == "quit":
                break
            if what in ("DCMD", "NCMD"):
                node = cmd["node"]
                if what == "DCMD":
                    device = cmd["device"]
                    topic = str(Topic(group, MessageType.DCMD, node, device))
                    key = (group, node, device)
                else:
                    topic = str(Topic(group, MessageType.NCMD, node))
                    key = (group, node, None)
                with host.lock:
                    birth = host.births.get(key)
                raw = host.command_payload(what, cmd, birth)
                publish(topic, raw, cmd.get("qos", 0), cmd.get("retain", False))
            elif what == "STATE":
                topic = str(Topic(message_type=MessageType.STATE, sparkplug_host_id=cmd["host"]))
                state = pysparkplug.State(
                    timestamp=cmd.get("timestamp", now_ms()), online=bool(cmd["online"])
                )
                publish(topic, state.encode(), cmd.get("qos", 1), cmd.get("retain", True))
            elif what == "raw":
                publish(
                    cmd["topic"],
                    bytes.fromhex(cmd["hex"]),
                    cmd.get("qos", 0),
                    cmd.get("retain", False),
                )
            elif what == "encode":
                emit({"encoded": host.encode(cmd).hex()})
            else:
                raise ValueError(f"unknown cmd {what!r}")
        except Exception as e:
            emit({"command_error": f"{type(e).__name__}: {e}", "line": line})
    client.disconnect()
    client.loop_stop()


if __name__ == "__main__":
    main()
