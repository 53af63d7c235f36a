//! A `[[bus.drive.param]]` checked against its family's table: the parameter, only the
//! selectors the table gives it (NORD parameter set and array element, Bonfiglioli data set),
//! the bus width where the manual gives no data type, and whether it may be written at all.
//! Every refusal names the config key and its line, never a command-line option.

use bonfiglioli_modbus::slave::Width;
use ctt2_uss::uss::pkw::{Ind, IndLayout};
use drive_profile::Family;
use toml::Spanned;

use super::{Fault, ParamFile, Protocol};
use drive_client::target::{Target, nord_sub};

/// A point's parameter as the bus reads and writes it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Resolved {
    /// The parameter with its selector (IND word, data set).
    pub target: Target,
    /// Bonfiglioli: the width the config gives for a parameter without a data type.
    pub width: Option<Width>,
}

/// The value of an optional key.
fn value<T: Copy>(k: &Option<Spanned<T>>) -> Option<T> {
    k.as_ref().map(|s| *s.get_ref())
}

/// Where an optional key is, else `or`.
fn place<T>(k: &Option<Spanned<T>>, or: usize) -> usize {
    k.as_ref().map_or(or, |s| s.span().start)
}

/// The parameter as a person knows it: `P102 Acceleration time`, `index 9999` outside the
/// table.
fn label(t: &Target) -> String {
    t.param
        .map_or_else(|| t.label(), |p| format!("{} {}", p.label(), p.name_en()))
}

/// The indices each protocol's link is set up with (address, baud rate, timeouts): the
/// gateway never writes them, as it refuses them at a `set`.
fn link_settings(protocol: Protocol) -> &'static [u16] {
    match protocol {
        Protocol::Movilink => drive_client::sew::movilink::LINK_SETTINGS,
        Protocol::Sbus => drive_client::sew::sbus::LINK_SETTINGS,
        Protocol::ModbusRtu | Protocol::ModbusAscii => drive_client::bonfiglioli::LINK_SETTINGS,
        Protocol::Uss | Protocol::Ctt2 => &[],
    }
}

/// A family's own key: its name, where and what it says when given, and the family.
type Foreign<'a> = (&'a str, Option<(usize, u8)>, Family);

/// Resolve `p` on a `protocol` bus; `at` names the point in messages (`bus "b" drive "d"
/// point "p"`).
pub(super) fn resolve(protocol: Protocol, p: &ParamFile, at: &str) -> Result<Resolved, Fault> {
    let key = p.param.get_ref().as_str();
    let param_at = p.param.span().start;
    let fail = |place: usize, message: String| Fault::new(place, format!("{at}: {message}"));
    // The keys of another family first: they would be ignored, or mean something else.
    let family = protocol.family();
    let foreign: [Foreign; 4] = [
        (
            "data_set",
            p.data_set.as_ref().map(|s| (s.span().start, *s.get_ref())),
            Family::Bonfiglioli,
        ),
        (
            "width",
            p.width.as_ref().map(|s| (s.span().start, *s.get_ref())),
            Family::Bonfiglioli,
        ),
        (
            "array",
            p.array.as_ref().map(|s| (s.span().start, *s.get_ref())),
            Family::Nord,
        ),
        (
            "set",
            p.set.as_ref().map(|s| (s.span().start, *s.get_ref())),
            Family::Nord,
        ),
    ];
    for (name, given, owner) in foreign {
        if let Some((place, v)) = given
            && owner != family
        {
            let buses = match owner {
                Family::Nord => "uss",
                _ => "modbus-rtu and modbus-ascii",
            };
            return Err(fail(
                place,
                format!(
                    "{name} = {v}: {name} is for {owner} parameters only ({buses} buses); a {} \
                     bus's {family} parameters take none: leave it out",
                    protocol.name()
                ),
            ));
        }
    }
    // The family's resolvers refuse only a parameter they do not know here (the selectors are
    // checked below): said in the config's terms, not with the command line's options.
    let raw = match family {
        Family::Nord => drive_client::nord::RAW_INDICES,
        Family::Bonfiglioli => drive_client::bonfiglioli::RAW_INDICES,
        _ => drive_client::sew::RAW_INDICES,
    };
    let param_error = || {
        fail(
            param_at,
            format!(
                "param = {key:?}: no {family} parameter of that name or number; give its number \
                 as the manual prints it, or a bus index {}…{} outside the table (`drivectl \
                 params {family}` lists the table)",
                raw.start(),
                raw.end()
            ),
        )
    };
    let (target, width) = match family {
        Family::Nord => (nord(p, key, param_at, &fail, &param_error)?, None),
        Family::Bonfiglioli => bonfiglioli(p, key, param_at, &fail, &param_error)?,
        _ => (
            Target::resolve(family, key, drive_client::sew::RAW_INDICES)
                .map_err(|_| param_error())?,
            None,
        ),
    };
    if value(&p.writable) == Some(true) {
        let w = place(&p.writable, param_at);
        let name = label(&target);
        match target.param {
            None => {
                return Err(fail(
                    w,
                    format!(
                        "writable = true: {name} is not in the {family} parameter table: the \
                         gateway writes only parameters the table describes; leave writable out"
                    ),
                ));
            }
            Some(m) if !m.access().is_writable() => {
                return Err(fail(
                    w,
                    format!(
                        "writable = true: {name} is read-only in the {family} parameter table; \
                         leave writable out"
                    ),
                ));
            }
            Some(_) if link_settings(protocol).contains(&target.index) => {
                return Err(fail(
                    w,
                    format!(
                        "writable = true: {name} is a setting of the link the gateway talks \
                         over: the gateway never writes it; leave writable out"
                    ),
                ));
            }
            Some(_) => {}
        }
    }
    Ok(Resolved { target, width })
}

/// NORD: the parameter set (1–4, only where the parameter has sets; default 1) and the array
/// element (1…length, required for an array, refused otherwise) as the IND word.
fn nord(
    p: &ParamFile,
    key: &str,
    param_at: usize,
    fail: &dyn Fn(usize, String) -> Fault,
    param_error: &dyn Fn() -> Fault,
) -> Result<Target, Fault> {
    // Every element of an array: the parameter itself, its element chosen below.
    let t = drive_client::nord::resolve(key, None, None, true)
        .map_err(|_| param_error())?
        .into_iter()
        .next()
        .ok_or_else(|| fail(param_at, format!("param = {key:?}: no such parameter")))?;
    let table = t.param.and_then(|_| drive_profile::nord::by_index(t.index));
    let name = label(&t);
    let set = match (value(&p.set), table) {
        (None, Some(tp)) => tp.parameter_set.then_some(1),
        (None, None) => None,
        (Some(s), Some(tp)) if !tp.parameter_set => {
            return Err(fail(
                place(&p.set, param_at),
                format!("set = {s}: {name} has no parameter sets: leave set out"),
            ));
        }
        (Some(s), _) if !(1..=4).contains(&s) => {
            return Err(fail(
                place(&p.set, param_at),
                format!(
                    "set = {s}: {} parameter sets 1–4",
                    if table.is_some() {
                        format!("{name} has")
                    } else {
                        "the drive has".to_owned()
                    }
                ),
            ));
        }
        (Some(s), _) => Some(s),
    };
    let array_at = place(&p.array, param_at);
    let element = match (value(&p.array), table.map(|tp| tp.array_len)) {
        (None, Some(Some(n))) => {
            return Err(fail(
                param_at,
                format!(
                    "{name} is an array of {n} elements ([-01]…[-{n:02}]): give array = 1…{n} \
                     (1 is [-01])"
                ),
            ));
        }
        (None, _) => None,
        (Some(k), Some(None)) => {
            return Err(fail(
                array_at,
                format!("array = {k}: {name} is no array: leave array out"),
            ));
        }
        (Some(k), Some(Some(n))) if k == 0 || k > n => {
            return Err(fail(
                array_at,
                format!("array = {k}: {name} has the elements 1…{n} ([-01]…[-{n:02}])"),
            ));
        }
        (Some(0), None) => {
            return Err(fail(
                array_at,
                "array = 0: elements count from 1 ([-01] is 1)".to_owned(),
            ));
        }
        (Some(k), _) => Some(k),
    };
    if table.is_none() {
        // Outside the table the IND word is all there is: it must carry the selectors.
        let layout = if set.is_some() {
            IndLayout::ParameterSets
        } else {
            IndLayout::Subindex
        };
        let zero_based = |v: Option<u8>| v.unwrap_or(1).saturating_sub(1);
        if Ind::address(layout, zero_based(element), zero_based(set)).is_none() {
            return Err(fail(
                array_at,
                format!(
                    "array = {}: with a parameter set the IND word carries the elements 1…64",
                    element.unwrap_or(0)
                ),
            ));
        }
    }
    Ok(Target {
        sub: nord_sub(t.index, element, set),
        ..t
    })
}

/// Bonfiglioli: the data set (0–9, where the parameter has data sets; 0 or its RAM image 5
/// where it has none), `eeprom` only with a stored data set, and the width (the table's data
/// type, else `width`).
fn bonfiglioli(
    p: &ParamFile,
    key: &str,
    param_at: usize,
    fail: &dyn Fn(usize, String) -> Fault,
    param_error: &dyn Fn() -> Fault,
) -> Result<(Target, Option<Width>), Fault> {
    let ds_at = place(&p.data_set, param_at);
    let ds = value(&p.data_set).unwrap_or(0);
    if ds > 9 {
        return Err(fail(
            ds_at,
            format!("data_set = {ds}: give 0–9 (0 all four, 1–4 one, 5–9 the RAM images of 0–4)"),
        ));
    }
    let mut t = Target::resolve(
        Family::Bonfiglioli,
        key,
        drive_client::bonfiglioli::RAW_INDICES,
    )
    .map_err(|_| param_error())?;
    t.sub = u16::from(ds);
    let table = t
        .param
        .and_then(|_| drive_profile::bonfiglioli::by_index(t.index));
    let name = label(&t);
    if !ds.is_multiple_of(5) && table.and_then(|tp| tp.data_set) == Some(false) {
        return Err(fail(
            ds_at,
            format!(
                "data_set = {ds}: {name} has no data sets: give 0 (or 5, its RAM image), or \
                 leave data_set out"
            ),
        ));
    }
    if ds >= 5 && value(&p.eeprom) == Some(true) {
        return Err(fail(
            place(&p.eeprom, ds_at),
            format!(
                "eeprom = true: data_set = {ds} is the RAM image of data set {}: give data_set \
                 = {} for EEPROM writes, or leave eeprom out",
                ds - 5,
                ds - 5
            ),
        ));
    }
    let bits = |w: Width| if w == Width::Word { 16 } else { 32 };
    let known = drive_client::bonfiglioli::table_width(&t, None);
    let width = match (value(&p.width), known) {
        (Some(w), _) if w != 16 && w != 32 => {
            return Err(fail(
                place(&p.width, param_at),
                format!("width = {w}: give 16 (FC 3/6) or 32 (FC 100/101)"),
            ));
        }
        (Some(w), Some(k)) if bits(k) != w => {
            return Err(fail(
                place(&p.width, param_at),
                format!(
                    "width = {w}: the manual gives {name} {} bits: leave width out",
                    bits(k)
                ),
            ));
        }
        (Some(16), _) => Some(Width::Word),
        (Some(_), _) => Some(Width::Long),
        (None, Some(_)) => None,
        (None, None) => {
            return Err(fail(
                param_at,
                format!(
                    "the manual gives no data type for {name}: give width = 16 (FC 3/6) or \
                     width = 32 (FC 100/101); nothing is guessed"
                ),
            ));
        }
    };
    // The table's width is the bus's anyway: only an unknown one is carried.
    Ok((t, width.filter(|_| known.is_none())))
}
