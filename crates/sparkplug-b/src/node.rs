//! What the specification fixes for an edge node's side (ch. 5 and 6), as pure logic: the
//! metric names, the `bdSeq` metric and the NDEATH payload, the rebirth request, and the rule
//! for a primary host application's STATE messages.

use crate::proto::payload::{Metric, metric};
use crate::proto::{DataType, Payload};
use crate::seq::Seq;
use alloc::vec;

/// The birth/death sequence metric of every NBIRTH and NDEATH (datatype Int64).
pub const BD_SEQ: &str = "bdSeq";

/// The metric every NBIRTH has (Boolean, false) and a host sets true in an NCMD to ask for a
/// new NBIRTH and every DBIRTH. When the node uses aliases, this metric must have none, so
/// that any host can ask without knowing them.
pub const REBIRTH: &str = "Node Control/Rebirth";

/// The node control metric a host sets to send the node to the next MQTT server.
pub const NEXT_SERVER: &str = "Node Control/Next Server";

/// The node control metric a host sets to reboot the edge node.
pub const REBOOT: &str = "Node Control/Reboot";

/// The [`BD_SEQ`] metric: Int64, the value in `long_value`, the `timestamp` given (births need
/// one; the NDEATH will may leave it out).
pub fn bd_seq_metric(bd_seq: Seq, timestamp: Option<u64>) -> Metric {
    Metric {
        name: Some(BD_SEQ.into()),
        timestamp,
        datatype: Some(DataType::Int64 as u32),
        value: Some(metric::Value::LongValue(u64::from(bd_seq.get()))),
        ..Metric::default()
    }
}

/// The NDEATH payload: the [`BD_SEQ`] metric alone and no `seq` (the specification allows
/// nothing else). It is the MQTT will of the connection whose NBIRTH carries the same `bdSeq`,
/// and what a clean stop publishes before it disconnects.
pub fn death(bd_seq: Seq, timestamp: Option<u64>) -> Payload {
    Payload {
        timestamp,
        metrics: vec![bd_seq_metric(bd_seq, timestamp)],
        ..Payload::default()
    }
}

/// Whether an NCMD metric is a rebirth request: named [`REBIRTH`], value true, and its
/// datatype Boolean when it has one. (A rebirth request comes by name: the metric has no
/// alias.)
pub fn is_rebirth(metric: &Metric) -> bool {
    metric.name.as_deref() == Some(REBIRTH)
        && metric
            .datatype
            .is_none_or(|d| d == DataType::Boolean as u32)
        && metric.is_null != Some(true)
        && metric.value == Some(metric::Value::BooleanValue(true))
}

/// What a STATE message of the primary host application means for the edge node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HostState {
    /// The host is online: the node may publish its births (and, if it waited, now should).
    Online,
    /// The host went offline: a node in a session publishes its NDEATH, disconnects and
    /// starts over (with the next server, if it has several).
    Offline,
    /// An old message (its timestamp is before the last online one): ignored.
    Stale,
}

/// The primary host application as the edge node follows it (ch. 5, "Edge Node Session
/// Establishment" and "Termination"): fed the `online` flag and `timestamp` of each STATE
/// message on `spBv1.0/STATE/<host_id>` (the JSON is the caller's to read).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PrimaryHost {
    /// The timestamp of the last STATE message taken as valid.
    last: Option<u64>,
    online: bool,
}

impl PrimaryHost {
    /// A host not heard from yet (not online).
    pub fn new() -> PrimaryHost {
        PrimaryHost::default()
    }

    /// Take a STATE message. A message counts when its timestamp is not before the last one
    /// that counted (the first always counts); an older one is [`HostState::Stale`] and
    /// changes nothing.
    pub fn on_state(&mut self, online: bool, timestamp: u64) -> HostState {
        if self.last.is_some_and(|last| timestamp < last) {
            return HostState::Stale;
        }
        self.last = Some(timestamp);
        self.online = online;
        if online {
            HostState::Online
        } else {
            HostState::Offline
        }
    }

    /// Whether the host is online (the last STATE message that counted said so).
    pub fn is_online(&self) -> bool {
        self.online
    }

    /// Forget the host's state (a new MQTT connection: wait for a STATE message again, which
    /// the broker delivers at once when it is retained). The last timestamp is kept, so an
    /// old retained message still does not count.
    pub fn reconnected(&mut self) {
        self.online = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::value::{self, Number};

    #[test]
    fn the_death_payload_is_the_bd_seq_metric_alone_without_seq() {
        let p = death(Seq::new(7), None);
        assert_eq!(p.seq, None);
        assert_eq!(p.metrics.len(), 1);
        let m = &p.metrics[0];
        assert_eq!(m.name.as_deref(), Some("bdSeq"));
        assert_eq!(m.datatype, Some(4)); // Int64
        assert_eq!(value::get(m, DataType::Int64), Ok(Number::Int(7)));
        assert_eq!(death(Seq::new(255), Some(5)).timestamp, Some(5));
    }

    #[test]
    fn a_rebirth_request_is_the_rebirth_metric_set_true() {
        // Ch. 6, NCMD example: {"name": "Node Control/Rebirth", "dataType": "Boolean", "value": true}.
        let request = Metric {
            name: Some(REBIRTH.into()),
            timestamp: Some(1_486_144_502_122),
            datatype: Some(DataType::Boolean as u32),
            value: Some(metric::Value::BooleanValue(true)),
            ..Metric::default()
        };
        assert!(is_rebirth(&request));
        assert!(is_rebirth(&Metric {
            datatype: None,
            ..request.clone()
        }));
        let no = [
            Metric {
                value: Some(metric::Value::BooleanValue(false)),
                ..request.clone()
            },
            Metric {
                value: Some(metric::Value::IntValue(1)),
                ..request.clone()
            },
            Metric {
                datatype: Some(DataType::Int32 as u32),
                ..request.clone()
            },
            Metric {
                name: Some(NEXT_SERVER.into()),
                ..request.clone()
            },
            Metric {
                name: None,
                alias: Some(0),
                ..request.clone()
            },
            Metric {
                is_null: Some(true),
                ..request.clone()
            },
        ];
        for m in &no {
            assert!(!is_rebirth(m), "{m:?}");
        }
    }

    #[test]
    fn the_primary_host_follows_the_newest_state_message() {
        let mut host = PrimaryHost::new();
        assert!(!host.is_online());
        // The first message counts whatever its timestamp.
        assert_eq!(host.on_state(false, 100), HostState::Offline);
        assert_eq!(host.on_state(true, 200), HostState::Online);
        assert!(host.is_online());
        // An old death (the host's previous session) is ignored.
        assert_eq!(host.on_state(false, 150), HostState::Stale);
        assert!(host.is_online());
        // The same timestamp counts (greater than or equal).
        assert_eq!(host.on_state(false, 200), HostState::Offline);
        assert!(!host.is_online());
        assert_eq!(host.on_state(true, 300), HostState::Online);
        host.reconnected();
        assert!(!host.is_online());
        assert_eq!(host.on_state(true, 299), HostState::Stale);
        assert_eq!(host.on_state(true, 300), HostState::Online);
    }
}
