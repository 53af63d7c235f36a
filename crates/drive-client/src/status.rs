//! A drive's status and fault memory as typed readings: NORD's status word with its state and
//! parameter set, the actual values with their P543 functions (scaled by P105 and P112) and the
//! P700 elements; Bonfiglioli's status word 411 for the drive's variant, fault 260 and
//! warnings 270.

use bonfiglioli_modbus::driver::{CharIo, ModbusDriver};
use bonfiglioli_modbus::frame::{Address, DataSet};
use bonfiglioli_modbus::slave::Width;
use drive_profile::Family;
use drive_profile::bonfiglioli::{self as bprofile, Variant};
use drive_profile::nord::{self as nprofile, StatusWord};
use serde_json::{Value, json};

use crate::client::{ClientError, ParamClient};
use crate::front::FrontEnd;
use crate::info::{Failed, Reading, read_one};
use crate::meaning::{Device, KnownVariant, Meaning, meaning_in, meaning_of};
use crate::nord::param as nparam;
use crate::target::Target;

/// A NORD drive's status: what its status word says and what the parameters it points at hold.
#[derive(Debug, Clone)]
pub struct NordStatus {
    /// The status word (process data).
    pub status: StatusWord,
    /// P105 maximum frequency in the status word's parameter set: the 100 % of frequencies.
    pub max_frequency: Reading,
    /// P112 current limit in that set: the 100 % of current.
    pub current_limit: Reading,
    /// The actual values IW1–IW3 with what P543 says each carries.
    pub actuals: Vec<Actual>,
    /// P700 [-01] present fault, [-02] present warning, [-03] reason for switch-on disabled.
    pub present: Vec<Reading>,
}

/// One actual value word with its P543 element.
#[derive(Debug, Clone)]
pub struct Actual {
    /// The word, 4000h = 100 %.
    pub word: u16,
    /// P543 [-n]: its function.
    pub function: Reading,
}

/// An actual value as far as it is known: in %, and where P543 names a frequency or current,
/// in its unit.
#[derive(Debug, Clone, PartialEq)]
pub struct ActualValue {
    /// The word.
    pub word: u16,
    /// In % of its 100 %.
    pub percent: f64,
    /// The P543 function, `None` when unreadable.
    pub function: Option<i64>,
    /// The function's English name, where the table names it.
    pub function_name: Option<&'static str>,
    /// The physical value, where the function and its 100 % are known.
    pub value: Option<f64>,
    /// The unit of a frequency or current function.
    pub unit: Option<&'static str>,
}

/// The names of the P700 elements.
pub const PRESENT_NAMES: [&str; 3] = [
    "present fault",
    "present warning",
    "reason for switch-on disabled",
];

fn nord_target(number: u16, element: Option<u8>, set: Option<u8>) -> Result<Target, Failed> {
    crate::nord::resolve(&number.to_string(), element, set, false)
        .ok()
        .and_then(|v| v.into_iter().next())
        .ok_or_else(|| Failed {
            target: Target {
                family: Family::Nord,
                index: number,
                sub: 0,
                param: None,
            },
            error: ClientError::Request(format!("P{number} is not in the NORD table")),
        })
}

/// Read what the NORD status word `status` and the actual values `actuals` point at: P105 and
/// P112 in its parameter set, P543 per actual value, P700. A refusal is kept as its reading; a
/// link failure stops.
pub async fn nord<P: ParamClient>(
    client: &mut P,
    status: StatusWord,
    actuals: &[u16],
) -> Result<NordStatus, Failed> {
    let set = Some(status.parameter_set());
    let max_frequency =
        read_one(client, &nord_target(nparam::MAXIMUM_FREQUENCY, None, set)?).await?;
    let current_limit = read_one(client, &nord_target(nparam::CURRENT_LIMIT, None, set)?).await?;
    let mut all = Vec::with_capacity(actuals.len());
    for (i, word) in (1u8..).zip(actuals) {
        let t = nord_target(nparam::BUS_ACTUAL_VALUE, Some(i), None)?;
        all.push(Actual {
            word: *word,
            function: read_one(client, &t).await?,
        });
    }
    let mut present = Vec::with_capacity(3);
    for e in 1..=3 {
        present.push(read_one(client, &nord_target(nparam::PRESENT_FAULT, Some(e), None)?).await?);
    }
    Ok(NordStatus {
        status,
        max_frequency,
        current_limit,
        actuals: all,
        present,
    })
}

fn physical(r: &Reading) -> Option<f64> {
    r.value
        .as_ref()
        .ok()
        .and_then(|raw| r.target.param.map(|p| p.to_physical(*raw)))
}

impl NordStatus {
    /// Every refusal, in the order read.
    pub fn refusals(&self) -> impl Iterator<Item = &Reading> {
        [&self.max_frequency, &self.current_limit]
            .into_iter()
            .chain(self.actuals.iter().map(|a| &a.function))
            .chain(&self.present)
            .filter(|r| r.value.is_err())
    }

    /// P105 in Hz, `None` when refused.
    pub fn max_frequency_hz(&self) -> Option<f64> {
        physical(&self.max_frequency)
    }

    /// The actual values as far as they are known (the simulator's subset of the public NORD
    /// documentation's P543 list; 4000h = 100 % of P105 for frequencies, of P112 for current).
    pub fn actual_values(&self) -> Vec<ActualValue> {
        let (hz, current) = (self.max_frequency_hz(), physical(&self.current_limit));
        self.actuals
            .iter()
            .map(|a| {
                let function = a.function.value.as_ref().ok().copied();
                let function_name = function.and_then(|f| {
                    nprofile::by_index(nparam::BUS_ACTUAL_VALUE)
                        .and_then(|p| p.values.iter().find(|v| v.value == f))
                        .map(|v| v.en)
                });
                let (value, unit) = match function {
                    Some(1 | 8) => (
                        hz.map(|r| nprofile::word_to_physical(a.word, r)),
                        Some("Hz"),
                    ),
                    // The current's 100 % is P112 (itself in % of the rated current).
                    Some(3) => (
                        current.map(|r| nprofile::word_to_physical(a.word, r)),
                        Some("% of rated current"),
                    ),
                    _ => (None, None),
                };
                ActualValue {
                    word: a.word,
                    percent: nprofile::percent_from_word(a.word),
                    function,
                    function_name,
                    value,
                    unit,
                }
            })
            .collect()
    }

    /// The P700 elements' meanings (`no fault`), `None` where refused; `Some(None)`: a value
    /// without a meaning.
    pub fn present_texts(&self) -> Vec<Option<(i64, Option<String>)>> {
        self.present
            .iter()
            .map(|r| {
                r.value
                    .as_ref()
                    .ok()
                    .map(|raw| (*raw, meaning_of(&r.target, *raw).map(|m| m.text)))
            })
            .collect()
    }

    /// The `status --json` object.
    pub fn json(&self) -> Value {
        let sw = self.status;
        let state = sw.state();
        let actuals: Vec<Value> = self
            .actual_values()
            .iter()
            .map(|v| {
                json!({"word": v.word, "hex": format!("0x{:04X}", v.word), "percent": v.percent,
                       "function": v.function, "function_name": v.function_name,
                       "value": v.value, "unit": v.unit})
            })
            .collect();
        let p = |i: usize| {
            self.present
                .get(i)
                .and_then(|r| r.value.as_ref().ok().copied())
        };
        let bits: Vec<&str> = sw.set_bits().map(|b| b.name_en).collect();
        json!({
            "status_word": sw.0, "hex": format!("0x{:04X}", sw.0),
            "state": nprofile::state_info(state).map(|i| i.letter.to_string()),
            "state_en": state.name_en(), "state_de": state.name_de(),
            "bits": bits, "parameter_set": sw.parameter_set(),
            "p105_hz": self.max_frequency_hz(), "actuals": actuals,
            "fault": p(0), "warning": p(1), "switch_on_disabled_reason": p(2),
        })
    }
}

/// A Bonfiglioli drive's status: 411, 260 and 270, for its variant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BonfiglioliStatus {
    /// The drive's address.
    pub address: u8,
    /// The variant given or found (`None`: neither; 411 decoded for what both share).
    pub variant: Option<KnownVariant>,
    /// 411 status word.
    pub status_word: u16,
    /// 260 current fault.
    pub fault: u16,
    /// 270 warnings.
    pub warnings: u16,
}

/// Read one 16-bit word of a Bonfiglioli drive (data set 0).
pub async fn bonfiglioli_word<IO: CharIo>(
    m: &mut ModbusDriver<IO>,
    addr: Address,
    number: u16,
    front: &dyn FrontEnd,
) -> Result<u16, Failed> {
    let target = crate::bonfiglioli::target(number, 0).map_err(|error| Failed {
        target: Target {
            family: Family::Bonfiglioli,
            index: number,
            sub: 0,
            param: None,
        },
        error,
    })?;
    m.read(addr, number, DataSet::ALL, Width::Word)
        .await
        .map(|v| v as u16)
        .map_err(|e| Failed {
            target,
            error: crate::bonfiglioli::client_error(Width::Word, e, front),
        })
}

/// Read 411, 260 and 270 of the drive at `addr`, whose variant is `variant`.
pub async fn bonfiglioli<IO: CharIo>(
    m: &mut ModbusDriver<IO>,
    addr: Address,
    variant: Option<KnownVariant>,
    front: &dyn FrontEnd,
) -> Result<BonfiglioliStatus, Failed> {
    use crate::bonfiglioli::param;
    Ok(BonfiglioliStatus {
        address: addr.get(),
        variant,
        status_word: bonfiglioli_word(m, addr, param::STATUS_WORD, front).await?,
        fault: bonfiglioli_word(m, addr, param::CURRENT_FAULT, front).await?,
        warnings: bonfiglioli_word(m, addr, param::WARNINGS, front).await?,
    })
}

impl BonfiglioliStatus {
    /// The meaning of `raw` of `number` for this drive.
    fn meaning(&self, number: u16, raw: u16) -> Option<Meaning> {
        let t = crate::bonfiglioli::target(number, 0).ok()?;
        let device = Device {
            bonfiglioli: self.variant,
        };
        meaning_in(&t, i64::from(raw), &device)
    }

    /// 411 decoded (its meaning's `decoded` object).
    pub fn status(&self) -> Option<Meaning> {
        self.meaning(crate::bonfiglioli::param::STATUS_WORD, self.status_word)
    }

    /// 260's meaning.
    pub fn fault_meaning(&self) -> Option<Meaning> {
        self.meaning(crate::bonfiglioli::param::CURRENT_FAULT, self.fault)
    }

    /// 270's meaning.
    pub fn warnings_meaning(&self) -> Option<Meaning> {
        self.meaning(crate::bonfiglioli::param::WARNINGS, self.warnings)
    }

    /// The variant shown: the one known, else what the status word tells.
    pub fn shown_variant(&self) -> Option<Variant> {
        self.variant
            .map(|k| k.variant)
            .or(Variant::of_status_word(self.status_word))
    }

    /// One key of 411's decoded object (`state`, `variant_from`, `variant_contradicted`).
    fn decoded(&self, key: &str) -> Value {
        self.status()
            .and_then(|m| m.decoded)
            .and_then(|d| d.get(key).cloned())
            .unwrap_or(Value::Null)
    }

    /// Whether 411 contradicts the variant: bit 4 set, which an ACT never sets (ch. 9.1.3).
    pub fn contradicted(&self) -> bool {
        self.decoded("variant_contradicted") == true
    }

    /// The status word's set bits by name (`a | b`), for the variant shown (the ACT's where
    /// none is).
    pub fn bits_text(&self) -> String {
        bits_text(
            self.status_word,
            self.shown_variant().unwrap_or(Variant::Act),
        )
    }

    /// The `status --json` object.
    pub fn json(&self) -> Value {
        let text = |m: Option<Meaning>| m.map_or_else(String::new, |m| m.text);
        let warning_names: Vec<&str> = bprofile::warning_bits(self.warnings)
            .map(|w| w.name_en)
            .collect();
        json!({"address": self.address, "variant": self.shown_variant().map(Variant::key),
               "variant_from": self.decoded("variant_from"),
               "status_word": self.status_word, "state": self.decoded("state"),
               "bits": self.bits_text(),
               "decoded": self.status().and_then(|m| m.decoded).unwrap_or(Value::Null),
               "fault": self.fault, "fault_text": text(self.fault_meaning()),
               "warnings": self.warnings, "warning_names": warning_names})
    }
}

/// A Bonfiglioli status word's set bits by name, for `variant`.
pub fn bits_text(word: u16, variant: Variant) -> String {
    variant.set_bits(word).collect::<Vec<_>>().join(" | ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::client::DeviceErrorKind;
    use crate::testing::{FakeClient, refusal};

    #[test]
    fn nord_actual_values_are_scaled_by_their_p543_function_and_p105() {
        let mut c: FakeClient = FakeClient::new(|index| match index {
            105 => Ok(500),
            112 => Err(refusal(DeviceErrorKind::Refused, "no P112")),
            543 => Ok(1),
            _ => Ok(0),
        });
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        let st = rt
            .block_on(nord(&mut c, StatusWord(0x0B70), &[0x2000, 0x4000]))
            .unwrap();
        assert_eq!(st.max_frequency_hz(), Some(50.0));
        let v = st.actual_values();
        assert_eq!(v.len(), 2);
        assert_eq!(
            (v[0].percent, v[0].value, v[0].unit),
            (50.0, Some(25.0), Some("Hz"))
        );
        assert_eq!(v[1].value, Some(50.0));
        assert_eq!(v[0].function_name, Some("actual frequency"));
        // The refused P112 is said, and the rest still read.
        let refused: Vec<String> = st.refusals().map(|r| r.target.label()).collect();
        assert_eq!(refused, ["P112 set 1"]);
        assert_eq!(st.present_texts()[0], Some((0, Some("no fault".into()))));
        let j = st.json();
        assert_eq!(j["state"], "B");
        assert_eq!(j["fault"], 0);
        assert_eq!(j["actuals"][1]["hex"], "0x4000");
    }

    #[test]
    fn a_bonfiglioli_status_word_is_decoded_for_the_variant_it_shows() {
        let st = BonfiglioliStatus {
            address: 1,
            variant: None,
            status_word: 0x0023,
            fault: 0,
            warnings: 0,
        };
        // Bit 4 clear tells neither variant: decoded for what both share.
        assert_eq!(st.shown_variant(), None);
        assert!(!st.contradicted());
        let j = st.json();
        assert!(j["variant"].is_null());
        assert_eq!(j["fault_text"], "no fault");
        assert!(st.bits_text().contains("switched on"), "{}", st.bits_text());
        // An ACT given, bit 4 set: the drive contradicts it (an ACT never sets bit 4).
        let given = BonfiglioliStatus {
            variant: Some(KnownVariant {
                variant: Variant::Act,
                from: "given",
            }),
            status_word: 0x0033,
            ..st
        };
        assert_eq!(given.shown_variant(), Some(Variant::Act));
        assert!(given.contradicted());
        assert_eq!(given.json()["variant"], "act");
    }
}
