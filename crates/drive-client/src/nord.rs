//! NORD NORDAC LINK (SK 270E-FDS, SK 280E-FDS): [`NordParamClient`], the [`ParamClient`] of a
//! drive behind `ctt2_uss`'s [`NordClient`] on any transport that carries the USS parameter
//! channel (USS on RS-485, CTT2 through an AS-i master).
//!
//! [`Target::sub`] of a NORD parameter is the IND word itself (section 4.6.1.2, see
//! [`nord_sub`]): a parameter with parameter sets carries the set in bits 8–9 and an array
//! element in bits 10–15; a parameter without sets carries its element in bits 8–15.

use std::ops::RangeInclusive;

use ctt2_uss::client::{self, NordClient, ParameterChannel};
use ctt2_uss::uss::pkw::{Ind, Order, Reply, Storage};
use drive_profile::nord::{self as profile, Width};
use drive_profile::{Family, Persistence};
use serde_json::{Map, Value};

use crate::client::{
    ClientError, DeviceCode, DeviceError, DeviceErrorKind, LinkFault, ParamClient,
};
use crate::front::{FrontEnd, Plain, Setting};
use crate::target::{Target, TargetError, nord_sub};

/// Parameter numbers outside the table that may be read and written raw: the 11 bits of the
/// PNU (PKE bits 0–10).
pub const RAW_INDICES: RangeInclusive<u16> = 0..=2047;

/// Parameter numbers (PNUs) of the table that clients and front ends use by name.
pub mod param {
    /// Maximum frequency: the 100 % of frequency setpoints and actual values.
    pub const MAXIMUM_FREQUENCY: u16 = 105;
    /// Torque current limit: the 100 % of current setpoints and actual values.
    pub const CURRENT_LIMIT: u16 = 112;
    /// Control word source (5 = AS-i).
    pub const CONTROL_WORD_SOURCE: u16 = 509;
    /// Bus actual values 1–3: what IW1–IW3 carry.
    pub const BUS_ACTUAL_VALUE: u16 = 543;
    /// Save to EEPROM (0 = RAM only, 1 = RAM and EEPROM).
    pub const SAVE_TO_EEPROM: u16 = 560;
    /// Present fault [-01], warning [-02], reason for switch-on disabled [-03].
    pub const PRESENT_FAULT: u16 = 700;
    /// Configuration level.
    pub const CONFIGURATION_LEVEL: u16 = 744;
}

/// The target of the table parameter `number` as a whole: its first array element and
/// parameter set 1 where it has them; a number outside the table is an error.
pub fn table_target(number: u16) -> Result<Target, ClientError> {
    table_entry(number)
        .ok_or_else(|| ClientError::Request(format!("P{number} is not in the NORD table")))
}

fn table_entry(number: u16) -> Option<Target> {
    let t = resolve_key(&number.to_string()).ok()?;
    let p = t.param.and_then(|_| profile::by_index(t.index))?;
    let element = p.array_len.map(|_| 1);
    let set = p.parameter_set.then_some(1);
    Some(Target {
        sub: nord_sub(t.index, element, set),
        ..t
    })
}

/// `key` in the NORD table (`P102`, `102`, `0x66`: a PNU typed as a number is the table's
/// parameter too), or a PNU outside it for raw access.
fn resolve_key(key: &str) -> Result<Target, TargetError> {
    let t = Target::resolve(Family::Nord, key, RAW_INDICES)?;
    if t.param.is_none()
        && let Some(p) = drive_profile::family::lookup(Family::Nord, &t.index.to_string())
            .filter(|p| p.bus_index() == t.index)
    {
        return Ok(Target::of(p));
    }
    Ok(t)
}

/// Why a NORD parameter cannot be reached with the array element and parameter set asked
/// for; nothing was sent. A front end says which of its options names them.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SelectorError {
    /// The key is no parameter.
    #[error(transparent)]
    Target(#[from] TargetError),
    /// A parameter set was given for a parameter without sets.
    #[error("{name} has no parameter sets; nothing was sent")]
    NoSets {
        /// The parameter (`P102 Acceleration time`).
        name: String,
    },
    /// An array element was given for a parameter that is no array.
    #[error("{name} is no array; nothing was sent")]
    NotAnArray {
        /// The parameter.
        name: String,
    },
    /// An element past the array's length.
    #[error(
        "{name} has the elements [-01]…[-{len:02}]: element {element} is none of them; nothing was sent"
    )]
    NoSuchElement {
        /// The parameter.
        name: String,
        /// Its number of elements.
        len: u8,
        /// The element asked for (1-based).
        element: u8,
    },
    /// An array without an element where one element is needed.
    #[error("{name} is an array of {len} elements: name one of them (1…{len}, [-01] = 1)")]
    WholeArray {
        /// The parameter.
        name: String,
        /// Its number of elements.
        len: u8,
    },
}

/// Resolve a NORD parameter (`P102`, `102`, a PNU outside the table for raw access) with its
/// array element and parameter set (both 1-based), checked against the table: a set only for
/// parameters with parameter sets (set 1 when none is given), an element only for arrays and
/// within their length. An array without an element is every element when `every_element`,
/// else refused. Outside the table nothing can be checked: the IND word is built as given.
pub fn resolve(
    key: &str,
    element: Option<u8>,
    set: Option<u8>,
    every_element: bool,
) -> Result<Vec<Target>, SelectorError> {
    let t = resolve_key(key)?;
    let Some(p) = t.param.and_then(|_| profile::by_index(t.index)) else {
        return Ok(vec![Target {
            sub: nord_sub(t.index, element, set),
            ..t
        }]);
    };
    let name = format!("{} {}", p.label(), p.name_en);
    if set.is_some() && !p.parameter_set {
        return Err(SelectorError::NoSets { name });
    }
    let set = p.parameter_set.then(|| set.unwrap_or(1));
    let elements: Vec<Option<u8>> = match (p.array_len, element) {
        (None, Some(_)) => return Err(SelectorError::NotAnArray { name }),
        (None, None) => vec![None],
        (Some(len), Some(k)) if k > len || k == 0 => {
            return Err(SelectorError::NoSuchElement {
                name,
                len,
                element: k,
            });
        }
        (Some(_), Some(k)) => vec![Some(k)],
        (Some(len), None) if every_element => (1..=len).map(Some).collect(),
        (Some(len), None) => return Err(SelectorError::WholeArray { name, len }),
    };
    Ok(elements
        .into_iter()
        .map(|e| Target {
            sub: nord_sub(t.index, e, set),
            ..t
        })
        .collect())
}

/// Whether `t` is an array element (AK 6, 7, 11, 12): the table says so, or `raw_array` (the
/// caller said the raw parameter is an array) outside the table.
fn is_array(t: &Target, raw_array: bool) -> bool {
    match t.param.and_then(|_| profile::by_index(t.index)) {
        Some(p) => p.array_len.is_some(),
        None => raw_array,
    }
}

/// The raw value of a value read: a word of a parameter whose range does not go below zero
/// is unsigned (whatever PWE1 says), any other keeps the sign the drive sent.
pub fn raw_of(t: &Target, value: i32, width: Width) -> i64 {
    let unsigned = t
        .param
        .and_then(|p| p.raw_range())
        .is_some_and(|(lo, _)| lo >= 0);
    match (width, unsigned) {
        (Width::Word, true) => i64::from(value as u16),
        (Width::DoubleWord, true) => i64::from(value as u32),
        _ => i64::from(value),
    }
}

/// The order reading `t`: AK 1, or AK 6 for an array element.
fn read_order(t: &Target, raw_array: bool) -> Result<Order, ClientError> {
    let ind = Ind(t.sub);
    if is_array(t, raw_array) {
        Order::read_array(t.index, ind)
    } else {
        Order::read(t.index, ind)
    }
    .map_err(|e| ClientError::Request(e.to_string()))
}

/// The order writing `raw` to `t` as a word: AK 2/7 to EEPROM (as P560 says) or AK 14/12 to
/// RAM only.
fn write_order(
    t: &Target,
    raw: i64,
    persistence: Persistence,
    raw_array: bool,
) -> Result<Order, ClientError> {
    let storage = match persistence {
        Persistence::Volatile => Storage::Ram,
        Persistence::NonVolatile => Storage::Eeprom,
    };
    Order::write(
        t.index,
        Ind(t.sub),
        Width::Word,
        is_array(t, raw_array),
        storage,
        raw,
    )
    .map_err(|e| ClientError::Request(format!("{e}; nothing was sent")))
}

/// What a PWE2 error number means for a client: 0 (no such parameter) and 3 (no such element
/// or set) are absent from this drive; everything else is a refusal.
pub fn device_error_kind(error: u16) -> DeviceErrorKind {
    match error {
        0 | 3 => DeviceErrorKind::Absent,
        _ => DeviceErrorKind::Refused,
    }
}

/// The client error of a `NordClient` error (the caller names the parameter); what to leave
/// out when the drive says a parameter is no array is named in `front`'s words.
pub fn client_error<E: std::fmt::Display>(
    e: client::ClientError<E>,
    fault: impl Fn(&E) -> Option<LinkFault>,
    front: &dyn FrontEnd,
) -> ClientError {
    match e {
        client::ClientError::Drive { order, error } => {
            let hint = match error.0 {
                1 => " (read-only: the drive does not take writes to it)".to_owned(),
                2 => " (the value is outside the drive's range)".to_owned(),
                3 => " (the drive has no such array element or parameter set)".to_owned(),
                4 => format!(
                    " (the drive says it is no array{})",
                    front
                        .name(Setting::ArrayElement)
                        .map_or_else(String::new, |w| format!(": leave out {w}"))
                ),
                _ => String::new(),
            };
            ClientError::Device(DeviceError {
                kind: device_error_kind(error.0),
                code: DeviceCode::Nord(error.0),
                message: format!(
                    "the drive refused AK {} ({}): {error}{hint}",
                    order.ak(),
                    profile::ak_request(order.ak()).map_or("order", |r| r.function_en)
                ),
            })
        }
        client::ClientError::Transport(t) => match fault(&t) {
            Some(f) => ClientError::link(f, t.to_string()),
            None => ClientError::Request(format!("{t}; nothing was sent")),
        },
        // An answer that passed the checks but cannot be decoded.
        e @ client::ClientError::Pkw(_) => ClientError::link(LinkFault::Garbled, e.to_string()),
        other => ClientError::link(LinkFault::Unexpected, other.to_string()),
    }
}

/// `NordClient` as a [`ParamClient`]: one drive behind one transport.
///
/// The drive keeps answering its previous order until the new one is done, and the
/// plausibility check cannot tell that answer from the new one's when both orders address the
/// same PNU and IND (erratum E21: AK 7 fits every order, a write's echo fits a read).
/// `NordClient` therefore sends "no order" (AK 0) before its first order — the drive may still
/// answer an order of an earlier program — and before an order on the PNU and IND of the one
/// before.
#[derive(Debug)]
pub struct NordParamClient<'a, C> {
    client: &'a mut NordClient<C>,
    key: String,
    identity: Map<String, Value>,
    raw_array: bool,
    front: &'static dyn FrontEnd,
}

impl<'a, C> NordParamClient<'a, C> {
    /// The drive behind `client`, named `key` in the EEPROM-wear log, identified in a backup by
    /// `identity` (the transport's fields: address, ID object, …).
    pub fn new(client: &'a mut NordClient<C>, key: &str, identity: Map<String, Value>) -> Self {
        Self {
            client,
            key: key.to_owned(),
            identity,
            raw_array: false,
            front: &Plain,
        }
    }

    /// Raw parameters (outside the table) are array elements (the caller named an element).
    #[must_use]
    pub fn raw_array(mut self, array: bool) -> Self {
        self.raw_array = array;
        self
    }

    /// Messages name what they point at in `front`'s words.
    #[must_use]
    pub fn with_front_end(mut self, front: &'static dyn FrontEnd) -> Self {
        self.front = front;
        self
    }
}

impl<C: ParameterChannel> NordParamClient<'_, C> {
    /// The drive's own number of elements of the array parameter `pnu` (AK 9).
    pub async fn element_count(&mut self, pnu: u16) -> Result<u16, ClientError> {
        self.client
            .count(pnu)
            .await
            .map_err(|e| client_error(e, C::link_fault, self.front))
    }
}

impl<C: ParameterChannel> ParamClient for NordParamClient<'_, C> {
    fn family(&self) -> Family {
        Family::Nord
    }

    fn stale_bytes(&self) -> u64 {
        self.client.channel().stale_bytes()
    }

    async fn drive_key(&mut self) -> Result<String, ClientError> {
        Ok(self.key.clone())
    }

    async fn read(&mut self, target: &Target) -> Result<i64, ClientError> {
        let order = read_order(target, self.raw_array)?;
        match self.client.order(order).await {
            Ok(Reply::Value { value, width, .. }) => Ok(raw_of(target, value, width)),
            Ok(reply) => Err(ClientError::link(
                LinkFault::Unexpected,
                format!("unexpected answer {reply:?} to AK {}", order.ak()),
            )),
            Err(e) => Err(client_error(e, C::link_fault, self.front)),
        }
    }

    async fn write(
        &mut self,
        target: &Target,
        raw: i64,
        persistence: Persistence,
    ) -> Result<(), ClientError> {
        let order = write_order(target, raw, persistence, self.raw_array)?;
        match self.client.order(order).await {
            Ok(Reply::Value { .. }) => Ok(()),
            Ok(reply) => Err(ClientError::link(
                LinkFault::Unexpected,
                format!("unexpected answer {reply:?} to AK {}", order.ak()),
            )),
            Err(e) => Err(client_error(e, C::link_fault, self.front)),
        }
    }

    async fn identify(&mut self) -> Result<Map<String, Value>, ClientError> {
        let mut m = self.identity.clone();
        let level = table_target(param::CONFIGURATION_LEVEL)?;
        let configuration = match self.read(&level).await {
            Ok(v) => Value::from(v),
            Err(ClientError::Device(_)) => Value::Null,
            Err(e) => return Err(e),
        };
        m.entry("device_type").or_insert(Value::Null);
        m.entry("firmware").or_insert(Value::Null);
        m.insert("configuration_level".into(), configuration);
        Ok(m)
    }
}

#[cfg(test)]
#[path = "nord_tests.rs"]
mod client_tests;

#[cfg(test)]
mod tests {
    use super::*;
    use ctt2_uss::uss::DriveError;

    #[test]
    fn the_table_targets_are_the_whole_parameter_in_set_1() {
        let t = table_target(param::SAVE_TO_EEPROM).unwrap();
        assert_eq!((t.index, t.sub), (560, 0));
        // P700 is an array: its first element.
        let t = table_target(param::PRESENT_FAULT).unwrap();
        assert_eq!(t.label(), "P700 [-01]");
        // P105 has parameter sets: set 1.
        let t = table_target(param::MAXIMUM_FREQUENCY).unwrap();
        assert_eq!(t.label(), "P105 set 1");
        assert!(table_target(1999).is_err());
    }

    #[test]
    fn a_refusal_names_no_front_ends_setting_unless_it_names_it() {
        #[derive(Debug)]
        struct Words;
        impl FrontEnd for Words {
            fn name(&self, setting: Setting) -> Option<String> {
                (setting == Setting::ArrayElement).then(|| "--array".to_owned())
            }
        }
        let e = || client::ClientError::<std::convert::Infallible>::Drive {
            order: Order::read_array(543, Ind(0)).unwrap(),
            error: DriveError(4),
        };
        let plain = client_error(e(), |_| None, &Plain).to_string();
        assert!(
            plain.ends_with("(the drive says it is no array)"),
            "{plain}"
        );
        let worded = client_error(e(), |_| None, &Words).to_string();
        assert!(
            worded.ends_with("(the drive says it is no array: leave out --array)"),
            "{worded}"
        );
    }

    #[test]
    fn a_transport_failure_is_a_link_failure_of_its_kind_or_a_request_not_sent() {
        #[derive(Debug)]
        struct Gone;
        impl std::fmt::Display for Gone {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("no answer from USS address 3")
            }
        }
        let e = || client::ClientError::Transport(Gone);
        match client_error(e(), |_| Some(LinkFault::NoAnswer), &Plain) {
            ClientError::Link(l) => {
                assert_eq!(l.fault, LinkFault::NoAnswer);
                assert_eq!(l.message, "no answer from USS address 3");
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            client_error(e(), |_| None, &Plain),
            ClientError::Request(m) if m.ends_with("nothing was sent")
        ));
    }
}
