//! What is known of one parameter: what the family's table says, what the drive says of it
//! beyond its value, and the drive's value for every selector asked (set, element, data set),
//! each with the drive's typed refusal. [`Info::json`] is the `info --json` object of every
//! family.

use bonfiglioli_modbus::slave::Width;
use drive_profile::{Access, bonfiglioli, nord};
use serde_json::{Value, json};

use crate::client::{ClientError, DeviceError, DeviceErrorKind, ParamClient};
use crate::meaning::{Device, param_json, target_json, value_json, value_json_in};
use crate::sew::{Description, SewLink, describe, raw_of};
use crate::target::Target;

/// The drive's answer for one target: its raw value, or its refusal.
#[derive(Debug, Clone)]
pub struct Reading {
    /// What was read.
    pub target: Target,
    /// The raw value, or the drive's refusal.
    pub value: Result<i64, DeviceError>,
}

/// A link failure (not a drive's refusal) while reading `target`: the work stops there.
#[derive(Debug, thiserror::Error)]
#[error("{error}")]
pub struct Failed {
    /// The target being read.
    pub target: Target,
    /// What failed.
    #[source]
    pub error: ClientError,
}

/// Read every target, in order: a drive's refusal is kept for its target, a link failure stops.
pub async fn read_each<P: ParamClient>(
    client: &mut P,
    targets: &[Target],
) -> Result<Vec<Reading>, Failed> {
    let mut all = Vec::with_capacity(targets.len());
    for t in targets {
        all.push(read_one(client, t).await?);
    }
    Ok(all)
}

/// Read one target: a drive's refusal is a [`Reading`] too, a link failure is [`Failed`].
pub async fn read_one<P: ParamClient>(client: &mut P, t: &Target) -> Result<Reading, Failed> {
    match client.read(t).await {
        Ok(raw) => Ok(Reading {
            target: *t,
            value: Ok(raw),
        }),
        Err(ClientError::Device(d)) => Ok(Reading {
            target: *t,
            value: Err(d),
        }),
        Err(error) => Err(Failed { target: *t, error }),
    }
}

/// What the drive says of a parameter beside its values, per family.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum FromDrive {
    /// SEW: minimum, maximum, default, scale and attributes, read from the drive.
    Sew(Description),
    /// NORD: the drive's own number of array elements (AK 9), asked for an array.
    Nord {
        /// `None`: not asked (no array).
        count: Option<Result<u16, DeviceError>>,
    },
    /// Bonfiglioli: the width the parameter was read with (given, from the table or found by
    /// trying) and what is known of the drive (its variant).
    Bonfiglioli {
        /// `None`: not known (nothing answered either width).
        width: Option<Width>,
        /// The drive's variant, for the meanings.
        device: Device,
    },
}

/// One parameter described: the table's entry (through [`Target::param`]), the drive's
/// description and its value for every selector asked.
#[derive(Debug, Clone)]
pub struct Info {
    /// The parameter, as the first selector names it.
    pub target: Target,
    /// What the drive says beside its values.
    pub drive: FromDrive,
    /// The drive's value for every selector asked.
    pub current: Vec<Reading>,
}

/// A width for a person: `16 bit (FC 3/6)`, `32 bit (FC 100/101)`.
pub fn width_text(w: Width) -> &'static str {
    match w {
        Width::Word => "16 bit (FC 3/6)",
        Width::Long => "32 bit (FC 100/101)",
    }
}

/// `info` of a MOVIDRIVE parameter: its description and value, as the drive answers them.
pub async fn sew<L: SewLink>(link: &mut L, target: Target) -> Result<Info, ClientError> {
    let d = describe(link, target.index).await?;
    Ok(Info {
        target,
        current: vec![Reading {
            target,
            value: Ok(raw_of(&target, d.current)),
        }],
        drive: FromDrive::Sew(d),
    })
}

/// `info` of the NORD parameter `target`: the value of every one of `targets` (its sets and
/// elements), and with `count` the drive's own number of elements (AK 9).
pub async fn nord<C: ctt2_uss::client::ParameterChannel>(
    client: &mut crate::nord::NordParamClient<'_, C>,
    target: Target,
    targets: &[Target],
    count: bool,
) -> Result<Info, Failed> {
    let current = read_each(client, targets).await?;
    let count = if count {
        match client.element_count(target.index).await {
            Ok(n) => Some(Ok(n)),
            Err(ClientError::Device(d)) => Some(Err(d)),
            Err(error) => return Err(Failed { target, error }),
        }
    } else {
        None
    };
    Ok(Info {
        target,
        drive: FromDrive::Nord { count },
        current,
    })
}

/// `info` of a Bonfiglioli parameter in every data set of `subs`, over a client whose variant
/// is found (for the meanings) and which probes a width the table does not give.
pub async fn bonfiglioli<IO: bonfiglioli_modbus::driver::CharIo>(
    client: &mut crate::bonfiglioli::BonfiglioliClient<'_, IO>,
    target: Target,
    subs: &[u16],
) -> Result<Info, Failed> {
    let targets: Vec<Target> = subs.iter().map(|s| Target { sub: *s, ..target }).collect();
    let device = client.device();
    let current = read_each(client, &targets).await?;
    Ok(Info {
        target,
        drive: FromDrive::Bonfiglioli {
            width: client.width_of(&target),
            device,
        },
        current,
    })
}

impl Info {
    /// The targets the drive refused, which fail the command: every refusal, except the
    /// "not readable" of a Bonfiglioli parameter its table calls write-only.
    pub fn refused(&self) -> Vec<&Target> {
        let write_only = matches!(self.drive, FromDrive::Bonfiglioli { .. })
            && self
                .target
                .param
                .and(bonfiglioli::by_index(self.target.index))
                .is_some_and(|p| !p.is_readable());
        self.current
            .iter()
            .filter(|r| match &r.value {
                Ok(_) => false,
                Err(d) => !(write_only && d.kind == DeviceErrorKind::Absent),
            })
            .map(|r| &r.target)
            .collect()
    }

    fn physical(&self, raw: i64) -> f64 {
        self.target.param.map_or(raw as f64, |p| p.to_physical(raw))
    }

    fn range_json(&self, range: Option<(i64, i64)>) -> Value {
        range.map_or(Value::Null, |(lo, hi)| {
            json!({"min": lo, "max": hi, "min_value": self.physical(lo), "max_value": self.physical(hi)})
        })
    }

    /// The `info --json` object: what names the target ([`target_json`]; NORD: one target's
    /// label and selector, or the parameter's when several), the family's description (the
    /// keys of `params --json` where they mean the same, raw values plain and physical ones as
    /// `*_value` in the table's unit), and `current`: the drive's values as `read --json` shows
    /// them, a refusal with its `error`.
    pub fn json(&self) -> Value {
        let t = &self.target;
        let fields = match &self.drive {
            FromDrive::Sew(d) => {
                let (min, max, def) = (
                    raw_of(t, d.minimum),
                    raw_of(t, d.maximum),
                    raw_of(t, d.default),
                );
                let attributes = d.attribute.attributes;
                json!({
                    "range": self.range_json(Some((min, max))),
                    "default": def, "default_value": self.physical(def),
                    "size_index": d.scale.size_index, "conversion_index": d.scale.conversion_index,
                    "quantity": drive_profile::sew::size_name(d.scale.size_index).unwrap_or("unknown quantity"),
                    "next_index": d.attribute.next_index, "attributes": attributes,
                    "access": Access::from_bits_truncate(attributes as u8).to_string(),
                    "current": [value_json(t, raw_of(t, d.current))],
                })
            }
            FromDrive::Nord { count } => return self.nord_json(count.as_ref()),
            FromDrive::Bonfiglioli { width, device } => {
                let table = t.param.and(bonfiglioli::by_index(t.index));
                let row = t.param.map(|p| param_json(p));
                let col = |k: &str| {
                    row.as_ref()
                        .and_then(|r| r.get(k).cloned())
                        .unwrap_or(Value::Null)
                };
                let default = t.param.and_then(|p| p.default_raw());
                let values: Vec<Value> = self
                    .current
                    .iter()
                    .map(|r| match &r.value {
                        Ok(raw) => value_json_in(&r.target, *raw, device),
                        Err(e) => json!({"label": r.target.label(),
                            "selector": r.target.selector_json(), "error": e.message}),
                    })
                    .collect();
                json!({
                    "range": self.range_json(t.param.and_then(|p| p.raw_range())),
                    "default": default,
                    "default_value": default.map(|d| self.physical(d)),
                    "access": t.param.map(|p| p.access().to_string()),
                    "decimals": col("decimals"),
                    "data_type": col("data_type"),
                    "type_source": col("type_source"),
                    "bits": table.and_then(|p| p.data_type.bits()),
                    "width": width.map(width_text),
                    "data_sets": col("data_set"),
                    "ram_only": col("ram_only"),
                    "not_in_operation": col("not_in_operation"),
                    "bus_only": col("bus_only"),
                    "bus_access": col("bus_access"),
                    "values": col("values"),
                    "chapters": col("chapters"),
                    "current": values,
                })
            }
        };
        let mut m = target_json(t);
        if let Value::Object(f) = fields {
            m.extend(f);
        }
        Value::Object(m)
    }

    fn nord_json(&self, count: Option<&Result<u16, DeviceError>>) -> Value {
        let first = &self.target;
        let p = first.param.and_then(|_| nord::by_index(first.index));
        let one = self.current.len() == 1;
        let values: Vec<Value> = self
            .current
            .iter()
            .map(|r| {
                let mut v = value_json(&r.target, *r.value.as_ref().unwrap_or(&0));
                if let (Value::Object(m), Err(e)) = (&mut v, &r.value) {
                    for k in ["raw", "value", "meaning", "decoded"] {
                        m.insert(k.into(), Value::Null);
                    }
                    m.insert("error".into(), e.message.clone().into());
                }
                v
            })
            .collect();
        json!({
            "index": first.index,
            "number": p.map(|q| q.label().to_string()),
            // One target: its label and selector; several (every set or element): the
            // parameter, each one's in `current`.
            "label": if one { first.label() } else {
                p.map_or_else(|| first.label(), |q| q.label().to_string())
            },
            "selector": if one { first.selector_json() } else { Value::Null },
            "name_de": p.map(|q| q.name_de), "name_en": p.map(|q| q.name_en),
            "unit": p.map(|q| q.unit),
            "range": self.range_json(p.and_then(|q| q.raw_range)),
            "default": p.and_then(|q| q.default_raw),
            "default_value": p.and_then(|q| q.default_raw).map(|d| self.physical(d)),
            "resolution": p.and_then(|q| q.resolution).map(|r| json!({
                "step": r.step, "decimals": r.decimals, "text": r.text,
            })),
            "access": p.map(|q| q.access.to_string()),
            "parameter_set": p.map(|q| q.parameter_set),
            "array_len": p.and_then(|q| q.array_len),
            "array_len_drive": count.and_then(|c| c.as_ref().ok().copied()),
            "limits_from": p.map(|_| "table"),
            "current": values,
            "values": p.map(|q| q.values.iter().map(|v| json!({
                "value": v.value, "de": v.de, "en": v.en,
            })).collect::<Vec<_>>()),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::client::DeviceCode;
    use drive_profile::Family;
    use drive_profile::sew::{AttributeInfo, ScaleInfo};

    fn refusal(kind: DeviceErrorKind) -> DeviceError {
        DeviceError {
            kind,
            code: DeviceCode::None,
            message: "not readable".into(),
        }
    }

    #[test]
    fn a_write_only_parameter_that_is_not_readable_is_no_refusal_of_the_command() {
        let t = crate::bonfiglioli::target(484, 0).unwrap();
        assert!(!bonfiglioli::by_index(484).unwrap().is_readable());
        let info = |kind| Info {
            target: t,
            drive: FromDrive::Bonfiglioli {
                width: Some(Width::Word),
                device: Device::default(),
            },
            current: vec![Reading {
                target: t,
                value: Err(refusal(kind)),
            }],
        };
        assert!(info(DeviceErrorKind::Absent).refused().is_empty());
        // Any other refusal fails it, and the JSON keeps the drive's answer.
        let refused = info(DeviceErrorKind::Refused);
        assert_eq!(refused.refused().len(), 1);
        let v = refused.json();
        assert_eq!(v["current"][0]["error"], "not readable");
        assert_eq!(v["width"], "16 bit (FC 3/6)");
        assert_eq!(v["index"], 484);
    }

    #[test]
    fn nord_info_of_every_set_names_the_parameter_and_each_value_its_set() {
        let sets: Vec<Target> = (1..=2)
            .map(|s| crate::nord::resolve("P102", None, Some(s), false).unwrap()[0])
            .collect();
        let info = Info {
            target: sets[0],
            drive: FromDrive::Nord { count: None },
            current: vec![
                Reading {
                    target: sets[0],
                    value: Ok(200),
                },
                Reading {
                    target: sets[1],
                    value: Err(refusal(DeviceErrorKind::Refused)),
                },
            ],
        };
        let v = info.json();
        assert_eq!(v["label"], "P102");
        assert!(v["selector"].is_null() && v["array_len_drive"].is_null());
        assert_eq!(v["range"]["max_value"], 320.0);
        assert_eq!(v["current"][0]["raw"], 200);
        assert_eq!(v["current"][1]["selector"]["set"], 2);
        assert!(v["current"][1]["raw"].is_null());
        assert_eq!(v["current"][1]["error"], "not readable");
        let refused: Vec<String> = info.refused().iter().map(|t| t.label()).collect();
        assert_eq!(refused, ["P102 set 2"]);
    }

    #[test]
    fn sew_info_shows_what_the_drive_said_scaled_by_the_table() {
        let t = Target::resolve(Family::Movidrive, "P130", 0..=0xFFFF).unwrap();
        let info = Info {
            target: t,
            drive: FromDrive::Sew(Description {
                minimum: 0,
                maximum: 2_000_000,
                default: 2000,
                scale: ScaleInfo {
                    size_index: 4,
                    conversion_index: -3,
                },
                attribute: AttributeInfo {
                    next_index: 8471,
                    attributes: 0x18,
                },
                current: 1500,
            }),
            current: Vec::new(),
        };
        let v = info.json();
        assert_eq!(v["range"]["max_value"], 2000.0);
        assert_eq!(v["default_value"], 2.0);
        assert_eq!(v["quantity"], "time");
        assert_eq!(v["access"], "N/RW");
        assert_eq!(v["current"][0]["raw"], 1500);
        assert!(info.refused().is_empty());
    }
}
