//! A payload from and to bytes: [`decode`] with its limits, [`encode_into`] a reused buffer.

use crate::proto::Payload;
use alloc::vec::Vec;
use prost::Message;

/// The largest payload [`decode`] takes: 256 KiB. A command or a birth of a drive with all its
/// parameters is a few KiB; the limit bounds what one received message may cost.
pub const MAX_PAYLOAD: usize = 256 * 1024;

/// The most metrics [`decode`] takes in one payload: those of the payload and, at any depth,
/// those inside template values, counted before anything is decoded.
pub const MAX_METRICS: usize = 4096;

/// Why [`decode`] refused a payload.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum DecodeError {
    /// The payload is longer than [`MAX_PAYLOAD`].
    #[error("payload of {len} bytes is over the limit of {max} bytes")]
    TooLarge {
        /// The payload's length in bytes.
        len: usize,
        /// The limit, [`MAX_PAYLOAD`].
        max: usize,
    },
    /// The payload has more than [`MAX_METRICS`] metrics.
    #[error("payload has more than {max} metrics")]
    TooManyMetrics {
        /// The limit, [`MAX_METRICS`].
        max: usize,
    },
    /// The bytes are not a valid Sparkplug B payload (prost's reason: a truncated or invalid
    /// field, a string that is not UTF-8, nesting too deep, …).
    #[error("not a valid Sparkplug B payload: {0}")]
    Protobuf(prost::DecodeError),
}

/// Decode a received payload (NCMD, DCMD; STATE messages are JSON and not decoded here).
///
/// Refuses more than [`MAX_PAYLOAD`] bytes or [`MAX_METRICS`] metrics before decoding, and
/// whatever prost refuses. Fields the schema does not have are skipped. Never panics, whatever
/// the bytes.
pub fn decode(bytes: &[u8]) -> Result<Payload, DecodeError> {
    if bytes.len() > MAX_PAYLOAD {
        return Err(DecodeError::TooLarge {
            len: bytes.len(),
            max: MAX_PAYLOAD,
        });
    }
    let mut budget = MAX_METRICS;
    if count(bytes, Kind::Payload, 0, &mut budget).is_err() {
        return Err(DecodeError::TooManyMetrics { max: MAX_METRICS });
    }
    Payload::decode(bytes).map_err(DecodeError::Protobuf)
}

/// Encode `payload` into `buf`, which is cleared first (its capacity is kept: the gateway
/// publishes many DDATA messages through one buffer).
pub fn encode_into(payload: &Payload, buf: &mut Vec<u8>) {
    buf.clear();
    buf.reserve(payload.encoded_len());
    // prost refuses only a buffer without room for the message; a `Vec` grows.
    let encoded = payload.encode(buf);
    debug_assert!(encoded.is_ok(), "a Vec has room: {encoded:?}");
}

/// The messages of the schema that hold metrics, directly or through a template.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// `Payload`: field 2 is a metric.
    Payload,
    /// `Payload.Metric`: field 18 is a template value.
    Metric,
    /// `Payload.Template`: field 2 is a member metric.
    Template,
}

/// The metric budget ran out.
struct TooMany;

/// Deeper than this the count stops: prost refuses nesting past 100 messages anyway.
const MAX_DEPTH: u32 = 128;

/// Count the metrics of an encoded message of `kind` against `budget`, down through template values,
/// reading only the protobuf wire format (keys, varints, lengths) and allocating nothing.
/// Malformed bytes end the count early: prost's decode then says what is wrong with them.
fn count(bytes: &[u8], kind: Kind, depth: u32, budget: &mut usize) -> Result<(), TooMany> {
    let mut wire = Wire { rest: bytes };
    while !wire.rest.is_empty() {
        let Some(key) = wire.varint() else {
            return Ok(());
        };
        let field = key >> 3;
        let body = match key & 7 {
            0 => wire.varint().map(|_| None),
            1 => wire.take(8).map(|_| None),
            2 => wire
                .varint()
                .and_then(|len| usize::try_from(len).ok())
                .and_then(|len| wire.take(len))
                .map(Some),
            3 => wire.skip_group(field).map(|()| None),
            5 => wire.take(4).map(|_| None),
            // An end of group without its start, or wire types 6 and 7: invalid.
            _ => None,
        };
        let Some(body) = body else {
            return Ok(());
        };
        let child = match (kind, field) {
            (Kind::Payload | Kind::Template, 2) => Kind::Metric,
            (Kind::Metric, 18) => Kind::Template,
            _ => continue,
        };
        let Some(body) = body else {
            // The field has the wrong wire type: prost refuses it.
            return Ok(());
        };
        if child == Kind::Metric {
            *budget = budget.checked_sub(1).ok_or(TooMany)?;
        }
        if depth < MAX_DEPTH {
            count(body, child, depth + 1, budget)?;
        }
    }
    Ok(())
}

/// A reader of the protobuf wire format.
struct Wire<'a> {
    rest: &'a [u8],
}

impl<'a> Wire<'a> {
    /// A base-128 varint of at most ten bytes.
    fn varint(&mut self) -> Option<u64> {
        let mut value = 0u64;
        for i in 0..10 {
            let (&byte, rest) = self.rest.split_first()?;
            self.rest = rest;
            value |= u64::from(byte & 0x7F) << (7 * i);
            if byte & 0x80 == 0 {
                return Some(value);
            }
        }
        None
    }

    /// The next `n` bytes.
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let (taken, rest) = self.rest.split_at_checked(n)?;
        self.rest = rest;
        Some(taken)
    }

    /// Skip a group (wire type 3, started by `field`) up to its end, nested groups included.
    fn skip_group(&mut self, field: u64) -> Option<()> {
        let mut open = Vec::new();
        open.push(field);
        while let Some(&inner) = open.last() {
            let key = self.varint()?;
            match key & 7 {
                0 => {
                    self.varint()?;
                }
                1 => {
                    self.take(8)?;
                }
                2 => {
                    let len = usize::try_from(self.varint()?).ok()?;
                    self.take(len)?;
                }
                3 => open.push(key >> 3),
                4 if key >> 3 == inner => {
                    open.pop();
                }
                5 => {
                    self.take(4)?;
                }
                _ => return None,
            }
            if open.len() > MAX_DEPTH as usize {
                return None;
            }
        }
        Some(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::payload::{Metric, Template, metric};
    use alloc::vec;

    fn metric(name: &str) -> Metric {
        Metric {
            name: Some(name.into()),
            ..Metric::default()
        }
    }

    fn encoded(payload: &Payload) -> Vec<u8> {
        let mut buf = vec![0xAA; 3];
        encode_into(payload, &mut buf);
        buf
    }

    #[test]
    fn encode_into_clears_the_buffer_first() {
        let payload = Payload {
            seq: Some(3),
            ..Payload::default()
        };
        // Field 3 (seq), varint: key 0x18, value 3.
        assert_eq!(encoded(&payload), [0x18, 0x03]);
    }

    #[test]
    fn a_payload_of_max_metrics_decodes_and_one_more_is_refused() {
        let mut payload = Payload {
            metrics: (0..MAX_METRICS).map(|_| Metric::default()).collect(),
            ..Payload::default()
        };
        let bytes = encoded(&payload);
        assert_eq!(decode(&bytes).unwrap().metrics.len(), MAX_METRICS);
        payload.metrics.push(Metric::default());
        assert_eq!(
            decode(&encoded(&payload)),
            Err(DecodeError::TooManyMetrics { max: MAX_METRICS })
        );
    }

    #[test]
    fn metrics_inside_templates_count_too() {
        // One metric holding a template of MAX_METRICS members: MAX_METRICS + 1 in all.
        let template = Template {
            metrics: (0..MAX_METRICS).map(|_| metric("m")).collect(),
            ..Template::default()
        };
        let payload = Payload {
            metrics: vec![Metric {
                value: Some(metric::Value::TemplateValue(template)),
                ..metric("t")
            }],
            ..Payload::default()
        };
        assert_eq!(
            decode(&encoded(&payload)),
            Err(DecodeError::TooManyMetrics { max: MAX_METRICS })
        );
    }

    #[test]
    fn metrics_after_an_unknown_group_field_are_counted() {
        // Field 20 as a group (start 0xA3 0x01, a varint field inside, end 0xA4 0x01), then
        // MAX_METRICS + 1 empty metrics (field 2, length 0: 0x12 0x00).
        let mut bytes = vec![0xA3, 0x01, 0x08, 0x01, 0xA4, 0x01];
        for _ in 0..=MAX_METRICS {
            bytes.extend([0x12, 0x00]);
        }
        assert_eq!(
            decode(&bytes),
            Err(DecodeError::TooManyMetrics { max: MAX_METRICS })
        );
        // With MAX_METRICS of them, prost skips the group and decodes the rest.
        bytes.truncate(bytes.len() - 2);
        assert_eq!(decode(&bytes).unwrap().metrics.len(), MAX_METRICS);
    }

    #[test]
    fn a_payload_over_max_payload_is_refused_before_decoding() {
        let bytes = vec![0u8; MAX_PAYLOAD + 1];
        assert_eq!(
            decode(&bytes),
            Err(DecodeError::TooLarge {
                len: MAX_PAYLOAD + 1,
                max: MAX_PAYLOAD
            })
        );
        // The largest allowed: a body field of MAX_PAYLOAD - 4 bytes (key 0x2A, 3-byte length).
        let payload = Payload {
            body: Some(vec![7; MAX_PAYLOAD - 4]),
            ..Payload::default()
        };
        let bytes = encoded(&payload);
        assert_eq!(bytes.len(), MAX_PAYLOAD);
        assert_eq!(decode(&bytes).unwrap(), payload);
    }

    #[test]
    fn invalid_bytes_are_prost_errors() {
        // A metric (field 2) whose length says 5 bytes with 1 left.
        let err = decode(&[0x12, 0x05, 0x00]).unwrap_err();
        assert!(matches!(err, DecodeError::Protobuf(_)), "{err:?}");
        // A metric name that is not UTF-8.
        let err = decode(&[0x12, 0x03, 0x0A, 0x01, 0xFF]).unwrap_err();
        assert!(
            err.to_string()
                .starts_with("not a valid Sparkplug B payload: "),
            "{err}"
        );
    }
}
