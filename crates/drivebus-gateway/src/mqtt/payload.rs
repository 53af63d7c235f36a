//! The JSON the gateway publishes, and the `set` messages it takes (`docs/gateway.md`, "MQTT").

use std::time::{SystemTime, UNIX_EPOCH};

use serde_json::{Map, Number, Value, json};

use super::super::model::{BusFigures, DriveStatus, SetOutcome, SetValue};
use drive_client::meaning::Device;
use drive_client::target::Target;

/// The largest `set` payload taken (bytes).
pub const MAX_SET_PAYLOAD: usize = 4096;

/// Milliseconds since the Unix epoch (0 before it: a clock set that wrong shows in every `ts`).
pub fn millis(t: SystemTime) -> u64 {
    t.duration_since(UNIX_EPOCH)
        .map(|d| u64::try_from(d.as_millis()).unwrap_or(u64::MAX))
        .unwrap_or(0)
}

/// A float as JSON with at most `decimals` places (`null` if not finite).
fn rounded(v: f64, decimals: u8) -> Value {
    if decimals == 0 && v.is_finite() && v.abs() < 9.0e15 {
        return json!(v.round() as i64);
    }
    let d = usize::from(decimals);
    format!("{v:.d$}")
        .parse::<f64>()
        .ok()
        .and_then(Number::from_f64)
        .map_or(Value::Null, Value::Number)
}

/// `value` (scaled with the parameter's table), `unit` (null where the table has none) and
/// `text` (a value-list entry's English name, or the decoded meaning of a status word or fault,
/// only where there is one) of `raw`.
fn value_fields(t: &Target, raw: i64, device: &Device, m: &mut Map<String, Value>) {
    match t.param {
        Some(p) => {
            m.insert("value".into(), rounded(p.to_physical(raw), p.decimals()));
            let unit = p.unit();
            m.insert(
                "unit".into(),
                if unit.is_empty() || unit == "-" {
                    Value::Null
                } else {
                    json!(unit)
                },
            );
            // A value-list entry's name, else what the value means (a status word's bits, a
            // fault's name), as `drivectl read` shows it.
            if let Some(n) = p.value_name(raw) {
                m.insert("text".into(), json!(n.en));
            } else if let Some(meaning) = drive_client::meaning::meaning_in(t, raw, device) {
                m.insert("text".into(), json!(meaning.text));
            }
        }
        None => {
            m.insert("value".into(), json!(raw));
            m.insert("unit".into(), Value::Null);
        }
    }
}

/// `{"value":…,"unit":…,"raw":N,"ts":…}` (+ `"text"`), the meaning for what is known of the
/// drive (`device`: a Bonfiglioli variant).
pub fn value(t: &Target, raw: i64, ts: u64, device: &Device) -> String {
    value_json(t, raw, ts, device).to_string()
}

/// [`value`] as a JSON value (the browser page's).
pub fn value_json(t: &Target, raw: i64, ts: u64, device: &Device) -> Value {
    let mut m = Map::new();
    value_fields(t, raw, device, &mut m);
    m.insert("raw".into(), json!(raw));
    m.insert("ts".into(), json!(ts));
    Value::Object(m)
}

/// A retained payload (a value, process data, a drive's status, a bus's figures) marked stale
/// since `since` (ms): `"stale": true, "stale_since": …` added, everything else (the value,
/// its unit, raw value and read time `ts`) kept. `None` if it is not a JSON object.
pub fn stale(payload: &str, since: u64) -> Option<String> {
    let mut v: Value = serde_json::from_str(payload).ok()?;
    let m = v.as_object_mut()?;
    m.insert("stale".into(), json!(true));
    m.insert("stale_since".into(), json!(since));
    Some(v.to_string())
}

/// The gateway's status topic while it runs: `{"state":"online","config":{"file":…,
/// "generation":N,"loaded":ms,"last_reload":null|{"ok":bool,"at":ms,"error":null|"…"}},"ts":…}`.
pub fn gateway_online(config: &crate::model::ConfigStatus, ts: u64) -> String {
    let last = config
        .last_reload
        .as_ref()
        .map(|(at, error)| json!({"ok": error.is_none(), "at": at, "error": error}));
    json!({
        "state": "online",
        "config": {
            "file": config.file,
            "generation": config.generation,
            "loaded": config.loaded,
            "last_reload": last,
        },
        "ts": ts,
    })
    .to_string()
}

/// The gateway's status topic once it no longer publishes: `{"state":"offline","reason":…}`
/// (`stopped` with the time at a clean stop; `connection lost`, without a time, as the last
/// will the broker publishes when the connection dies).
pub fn gateway_offline(reason: &str, ts: Option<u64>) -> String {
    match ts {
        Some(ts) => json!({"state": "offline", "reason": reason, "ts": ts}).to_string(),
        None => json!({"state": "offline", "reason": reason}).to_string(),
    }
}

/// `{"state":…,"text":…,"ts":…}`.
pub fn status(s: &DriveStatus, ts: u64) -> String {
    status_json(s, ts).to_string()
}

/// [`status`] as a JSON value.
pub fn status_json(s: &DriveStatus, ts: u64) -> Value {
    let text = match s {
        DriveStatus::Fault(t) => json!(t),
        _ => Value::Null,
    };
    json!({"state": s.state(), "text": text, "ts": ts})
}

/// The bus status topic's figures.
pub fn figures(f: &BusFigures, ts: u64) -> String {
    figures_json(f, ts).to_string()
}

/// [`figures`] as a JSON value.
pub fn figures_json(f: &BusFigures, ts: u64) -> Value {
    json!({
        "utilisation": rounded(f.utilisation, 4),
        "demand": rounded(f.demand, 4),
        "transactions": f.transactions,
        "timeouts": f.timeouts,
        "retries": f.retries,
        "late_polls": f.late_polls,
        "ts": ts,
    })
}

/// `{"in":[…],"out":[…],"ts":…}`.
pub fn process_data(inputs: &[u16], outputs: &[u16], ts: u64) -> String {
    json!({"in": inputs, "out": outputs, "ts": ts}).to_string()
}

/// The `…/result` of a `set`.
pub fn result(outcome: &SetOutcome, t: &Target, id: Option<&Value>, ts: u64) -> String {
    let (ok, name, reason, message, raw) = match outcome {
        // The drive holds another value than the one sent: still written, and the message
        // says what it holds and why.
        SetOutcome::Written { raw, differs } => (
            true,
            "written",
            None,
            differs.as_ref().map(|(_, m)| m.as_str()),
            Some(*raw),
        ),
        SetOutcome::Refused { reason, message } => (
            false,
            "refused",
            Some(*reason),
            Some(message.as_str()),
            None,
        ),
        SetOutcome::DeviceRefused { message } => {
            (false, "device_refused", None, Some(message.as_str()), None)
        }
        SetOutcome::LinkFailed { message } => {
            (false, "link_failed", None, Some(message.as_str()), None)
        }
    };
    let mut m = Map::new();
    m.insert("ok".into(), json!(ok));
    m.insert("outcome".into(), json!(name));
    m.insert("reason".into(), json!(reason));
    m.insert("message".into(), json!(message));
    m.insert("raw".into(), json!(raw));
    if let SetOutcome::Written { differs, .. } = outcome {
        // `sent`: the raw value sent, where the drive holds another (`raw`).
        m.insert("differs".into(), json!(differs.is_some()));
        m.insert("sent".into(), json!(differs.as_ref().map(|(s, _)| *s)));
    }
    match raw {
        Some(r) => {
            let mut v = Map::new();
            value_fields(t, r, &Device::default(), &mut v);
            m.insert("value".into(), v.remove("value").unwrap_or(Value::Null));
            if let Some(text) = v.remove("text") {
                m.insert("text".into(), text);
            }
        }
        None => {
            m.insert("value".into(), Value::Null);
        }
    }
    m.insert("id".into(), id.cloned().unwrap_or(Value::Null));
    m.insert("ts".into(), json!(ts));
    Value::Object(m).to_string()
}

/// A `set` message as sent.
#[derive(Debug, Clone, PartialEq)]
pub struct SetMessage {
    /// The value or raw value.
    pub value: SetValue,
    /// `ts`: when it was sent (ms since the epoch).
    pub ts: Option<i64>,
    /// `id`, echoed on the result.
    pub id: Option<Value>,
}

/// Why a `set` payload is refused as `bad_request`, with the `id` when one could be read.
#[derive(Debug, Clone, PartialEq)]
pub struct BadSet {
    /// For a person.
    pub message: String,
    /// The `id` of the message, when it is JSON with one.
    pub id: Option<Value>,
}

/// Parse a `set` payload: a JSON object with exactly one of `value` (number or value-list
/// text) and `raw` (integer), optional `ts` (integer ms) and `id` (echoed; any JSON value).
pub fn parse_set(payload: &[u8]) -> Result<SetMessage, BadSet> {
    let bad = |message: String, id: Option<Value>| BadSet { message, id };
    if payload.len() > MAX_SET_PAYLOAD {
        return Err(bad(
            format!(
                "payload of {} bytes: a set takes at most {MAX_SET_PAYLOAD}",
                payload.len()
            ),
            None,
        ));
    }
    let v: Value = serde_json::from_slice(payload).map_err(|e| {
        bad(
            format!(
                "not JSON ({e}); send {{\"value\": …}} or {{\"raw\": …}}, optionally with \
                 \"ts\" (ms) and \"id\""
            ),
            None,
        )
    })?;
    let Value::Object(mut m) = v else {
        return Err(bad(
            "not a JSON object; send {\"value\": …} or {\"raw\": …}".into(),
            None,
        ));
    };
    let id = m.remove("id");
    let ts = match m.remove("ts") {
        None | Some(Value::Null) => None,
        Some(Value::Number(n)) if n.as_i64().is_some() => n.as_i64(),
        Some(other) => {
            return Err(bad(
                format!("\"ts\": {other}: give milliseconds since the Unix epoch (an integer)"),
                id,
            ));
        }
    };
    let value = match (m.remove("value"), m.remove("raw")) {
        (Some(_), Some(_)) => {
            return Err(bad(
                "both \"value\" and \"raw\": send one of them".into(),
                id,
            ));
        }
        (None, None) => {
            return Err(bad(
                "neither \"value\" nor \"raw\": send {\"value\": …} (in the parameter's unit) or \
                 {\"raw\": N}"
                    .into(),
                id,
            ));
        }
        (Some(v @ (Value::Number(_) | Value::String(_))), None) => SetValue::Value(v),
        (Some(other), None) => {
            return Err(bad(
                format!(
                    "\"value\": {other}: give a number in the parameter's unit or a value name"
                ),
                id,
            ));
        }
        (None, Some(r)) => match r.as_i64() {
            Some(n) => SetValue::Raw(n),
            None => {
                return Err(bad(format!("\"raw\": {r}: give an integer raw value"), id));
            }
        },
    };
    if let Some(k) = m.keys().next() {
        return Err(bad(
            format!("unknown key {k:?}: a set takes value or raw, ts and id"),
            id,
        ));
    }
    Ok(SetMessage { value, ts, id })
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_profile::Family;

    fn target(key: &str) -> Target {
        Target::resolve(Family::Movidrive, key, 0..=u16::MAX).unwrap()
    }

    #[test]
    fn value_json_scaled_with_unit_and_text() {
        let v: Value =
            serde_json::from_str(&value(&target("P130"), 2500, 7, &Device::default())).unwrap();
        assert_eq!(v, json!({"value": 2.5, "unit": "s", "raw": 2500, "ts": 7}));
        let v: Value =
            serde_json::from_str(&value(&target("P700"), 11, 8, &Device::default())).unwrap();
        assert_eq!(v["value"], json!(11));
        assert_eq!(v["text"], json!("CFC"));
        assert_eq!(v["unit"], Value::Null);
        // A status word: its bits decoded, as `drivectl read` shows them.
        let v: Value =
            serde_json::from_str(&value(&target("P010"), 0x0407, 9, &Device::default())).unwrap();
        assert_eq!(v["raw"], json!(0x0407));
        let text = v["text"].as_str().unwrap();
        assert!(
            text.contains("ready") && text.contains("unit status 4"),
            "{text}"
        );
        let raw = Target {
            family: Family::Movidrive,
            index: 60000,
            sub: 0,
            param: None,
        };
        let v: Value = serde_json::from_str(&value(&raw, -3, 9, &Device::default())).unwrap();
        assert_eq!(v, json!({"value": -3, "unit": null, "raw": -3, "ts": 9}));
    }

    #[test]
    fn issue18_bonfiglioli_411_carries_its_meaning_for_the_configured_variant() {
        use drive_client::meaning::Device;
        use drive_profile::bonfiglioli::Variant;
        let t = Target::resolve(Family::Bonfiglioli, "411", 0..=1599).unwrap();
        let text = |d: &Device| -> String {
            let v: Value = serde_json::from_str(&value(&t, 0x23, 1, d)).unwrap();
            v["text"].as_str().unwrap_or_default().to_owned()
        };
        let shared = text(&Device::default());
        assert!(shared.contains("switched on"), "{shared}");
        let acu = text(&Device::bonfiglioli(Variant::Acu, "given"));
        assert!(
            acu.contains("ACU") && acu.contains("mains voltage"),
            "{acu}"
        );
        let act = text(&Device::bonfiglioli(Variant::Act, "given"));
        assert!(act.contains("ACT") && !act.contains("mains"), "{act}");
    }

    #[test]
    fn status_figures_pd_result() {
        let s: Value =
            serde_json::from_str(&status(&DriveStatus::Fault("F07 DC link".into()), 1)).unwrap();
        assert_eq!(s, json!({"state": "fault", "text": "F07 DC link", "ts": 1}));
        let s: Value = serde_json::from_str(&status(&DriveStatus::Timeout, 2)).unwrap();
        assert_eq!(s, json!({"state": "timeout", "text": null, "ts": 2}));
        let f = BusFigures {
            utilisation: 0.421_234_5,
            demand: 0.4,
            transactions: 10,
            timeouts: 1,
            retries: 2,
            late_polls: 3,
        };
        let f: Value = serde_json::from_str(&figures(&f, 3)).unwrap();
        assert_eq!(
            f,
            json!({"utilisation": 0.4212, "demand": 0.4, "transactions": 10, "timeouts": 1,
                   "retries": 2, "late_polls": 3, "ts": 3})
        );
        let p: Value = serde_json::from_str(&process_data(&[1, 2], &[6, 1500], 4)).unwrap();
        assert_eq!(p, json!({"in": [1, 2], "out": [6, 1500], "ts": 4}));
        let r: Value = serde_json::from_str(&result(
            &SetOutcome::Written {
                raw: 3000,
                differs: None,
            },
            &target("P130"),
            Some(&json!("a1")),
            5,
        ))
        .unwrap();
        assert_eq!(
            r,
            json!({"ok": true, "outcome": "written", "reason": null, "message": null,
                   "raw": 3000, "value": 3.0, "id": "a1", "ts": 5, "differs": false,
                   "sent": null})
        );
        // Issue 18 B10: a write the drive holds differently says so on result.
        let r: Value = serde_json::from_str(&result(
            &SetOutcome::Written {
                raw: 66000,
                differs: Some((65536, "P130 was written with raw 65536 …".into())),
            },
            &target("P130"),
            None,
            6,
        ))
        .unwrap();
        assert_eq!(
            (&r["ok"], &r["differs"], &r["sent"], &r["raw"]),
            (&json!(true), &json!(true), &json!(65536), &json!(66000))
        );
        assert!(r["message"].as_str().unwrap().contains("65536"), "{r}");
        let r: Value = serde_json::from_str(&result(
            &SetOutcome::Refused {
                reason: "range",
                message: "too big".into(),
            },
            &target("P130"),
            None,
            6,
        ))
        .unwrap();
        assert_eq!(
            r,
            json!({"ok": false, "outcome": "refused", "reason": "range", "message": "too big",
                   "raw": null, "value": null, "id": null, "ts": 6})
        );
    }

    #[test]
    fn set_payloads() {
        assert_eq!(
            parse_set(br#"{"value": 1.5, "ts": 12, "id": 7}"#).unwrap(),
            SetMessage {
                value: SetValue::Value(json!(1.5)),
                ts: Some(12),
                id: Some(json!(7))
            }
        );
        assert_eq!(
            parse_set(br#"{"raw": -4}"#).unwrap().value,
            SetValue::Raw(-4)
        );
        assert_eq!(
            parse_set(br#"{"value": "CFC"}"#).unwrap().value,
            SetValue::Value(json!("CFC"))
        );
        let big = format!("{{\"raw\": 1, \"id\": \"{}\"}}", "x".repeat(5000));
        for (bad, says, id) in [
            (&b"garbage"[..], "not JSON", None),
            (b"", "not JSON", None),
            (b"\xff\xfe", "not JSON", None),
            (b"[1]", "not a JSON object", None),
            (b"5", "not a JSON object", None),
            (
                br#"{"value": 1, "raw": 1, "id": "q"}"#,
                "both",
                Some(json!("q")),
            ),
            (br#"{"id": 3}"#, "neither", Some(json!(3))),
            (br#"{"raw": 1.5}"#, "integer raw", None),
            (br#"{"raw": 99999999999999999999999}"#, "integer raw", None),
            (br#"{"value": null}"#, "\"value\": null", None),
            (br#"{"value": [1]}"#, "\"value\"", None),
            (br#"{"raw": 1, "ts": "now"}"#, "\"ts\"", None),
            (br#"{"raw": 1, "ts": 1.5}"#, "\"ts\"", None),
            (br#"{"raw": 1, "extra": 1}"#, "unknown key", None),
            (big.as_bytes(), "at most 4096", None),
        ] {
            let e = parse_set(bad).unwrap_err();
            assert!(
                e.message.contains(says),
                "{:?}: {}",
                String::from_utf8_lossy(bad),
                e.message
            );
            assert_eq!(e.id, id);
        }
    }
}
