//! Family-independent parameter metadata: access flags, value lists and the [`ParamMeta`] view
//! that `drivectl`, the simulated drives and the write guard use for every family.

use core::fmt;

use crate::columns::FieldSink;

/// The drive families drivebus knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Family {
    /// SEW MOVIDRIVE (MOVILINK, SBus).
    Movidrive,
    /// NORD NORDAC LINK (CTT2 over AS-i, USS).
    Nord,
    /// Bonfiglioli ACTIVE / ACTIVE Cube (Modbus).
    Bonfiglioli,
}

impl Family {
    /// Every family, in a stable order.
    pub const ALL: [Family; 3] = [Family::Movidrive, Family::Nord, Family::Bonfiglioli];

    /// The lowercase name used on the command line.
    pub const fn name(self) -> &'static str {
        match self {
            Family::Movidrive => "movidrive",
            Family::Nord => "nord",
            Family::Bonfiglioli => "bonfiglioli",
        }
    }

    /// Parse a command-line name (case-insensitive; `sew` is accepted for MOVIDRIVE).
    pub fn parse(s: &str) -> Option<Family> {
        let eq = |a: &str| s.eq_ignore_ascii_case(a);
        if eq("movidrive") || eq("sew") {
            Some(Family::Movidrive)
        } else if eq("nord") {
            Some(Family::Nord)
        } else if eq("bonfiglioli") || eq("act") || eq("acu") {
            Some(Family::Bonfiglioli)
        } else {
            None
        }
    }
}

impl fmt::Display for Family {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Access attributes of a parameter, as flags.
///
/// SEW's table prints them as `S`, `RO`, `R`, `RW`, `N` joined by `/`; the other families map
/// their own attributes onto the same flags.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Access(u8);

impl Access {
    /// No flag.
    pub const NONE: Access = Access(0);
    /// `S`: may be stored even while the parameter lock is active.
    pub const STORE_LOCKED: Access = Access(1 << 0);
    /// `RO`: read-only.
    pub const READ_ONLY: Access = Access(1 << 1);
    /// `R`: writing needs controller inhibit (drive not enabled).
    pub const NEEDS_INHIBIT: Access = Access(1 << 2);
    /// `RW`: read/write.
    pub const READ_WRITE: Access = Access(1 << 3);
    /// `N`: the value is copied from EEPROM into RAM at restart (non-volatile).
    pub const NON_VOLATILE: Access = Access(1 << 4);
    /// Bonfiglioli: not writable while the drive is running.
    pub const NOT_IN_OPERATION: Access = Access(1 << 5);
    /// Bonfiglioli: exists once per data set (1…4).
    pub const DATA_SET: Access = Access(1 << 6);

    const NAMES: [(Access, &'static str); 7] = [
        (Access::NON_VOLATILE, "N"),
        (Access::STORE_LOCKED, "S"),
        (Access::NEEDS_INHIBIT, "R"),
        (Access::READ_ONLY, "RO"),
        (Access::READ_WRITE, "RW"),
        (Access::NOT_IN_OPERATION, "NOP"),
        (Access::DATA_SET, "DS"),
    ];

    /// The raw bits.
    pub const fn bits(self) -> u8 {
        self.0
    }

    /// Build from raw bits (unknown bits are dropped).
    pub const fn from_bits_truncate(bits: u8) -> Access {
        Access(bits & 0x7f)
    }

    /// Both flag sets combined.
    #[must_use]
    pub const fn union(self, other: Access) -> Access {
        Access(self.0 | other.0)
    }

    /// Whether every flag of `other` is set.
    pub const fn contains(self, other: Access) -> bool {
        self.0 & other.0 == other.0
    }

    /// Whether the parameter can be written at all.
    pub const fn is_writable(self) -> bool {
        self.contains(Access::READ_WRITE) && !self.contains(Access::READ_ONLY)
    }

    /// Parse SEW's notation, e.g. `N/R/RW` (also `NOP` and `DS` for the other families).
    pub fn parse(s: &str) -> Option<Access> {
        let mut acc = Access::NONE;
        for part in s.split('/') {
            let part = part.trim();
            let flag = Access::NAMES.iter().find(|(_, n)| *n == part)?.0;
            acc = acc.union(flag);
        }
        Some(acc)
    }
}

impl fmt::Debug for Access {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Access({self})")
    }
}

impl fmt::Display for Access {
    /// SEW notation, e.g. `N/R/RW`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut first = true;
        for (flag, name) in Access::NAMES {
            if self.contains(flag) {
                if !first {
                    f.write_str("/")?;
                }
                f.write_str(name)?;
                first = false;
            }
        }
        Ok(())
    }
}

/// Where a write goes: the volatile service (RAM only, lost at restart: MOVILINK "write
/// volatile", USS "without EEPROM", Bonfiglioli data sets 5–9) or the non-volatile one (RAM and,
/// where the parameter has EEPROM backing, EEPROM, which wears out).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Persistence {
    /// RAM only; lost at restart.
    Volatile,
    /// RAM and EEPROM (counted as EEPROM wear).
    NonVolatile,
}

/// One entry of a parameter's value list (e.g. P870 `9 = STEUERWORT 1` / control word 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ValueName {
    /// The raw value.
    pub value: i64,
    /// The manual's German text.
    pub de: &'static str,
    /// The English text.
    pub en: &'static str,
}

/// What 32 bits carry when the sign is not known: `i32::MIN ..= u32::MAX` (a value is sent as
/// its low 32 bits, read by the device as signed or unsigned).
pub const WIRE_32: (i64, i64) = (i32::MIN as i64, u32::MAX as i64);

/// What a 16-bit word carries when the sign is not known: `i16::MIN ..= u16::MAX`.
pub const WIRE_16: (i64, i64) = (i16::MIN as i64, u16::MAX as i64);

/// A family-independent view of one parameter's metadata.
///
/// Implemented by each family's generated parameter type. All methods are cheap and do not
/// allocate; `to_physical` / `from_physical` apply the family's scaling.
pub trait ParamMeta {
    /// The family this parameter belongs to.
    fn family(&self) -> Family;
    /// The number shown to users: SEW menu number (`P813` → 813), NORD `P102` → 102,
    /// Bonfiglioli parameter number. `None` for SEW rows without a menu number.
    fn number(&self) -> Option<u16>;
    /// The address used on the bus: SEW index, NORD PNU, Bonfiglioli parameter number.
    fn bus_index(&self) -> u16;
    /// Array / sub-index, where the family has one (NORD arrays, Bonfiglioli data set 0).
    fn sub_index(&self) -> Option<u16> {
        None
    }
    /// German name as printed in the manual.
    fn name_de(&self) -> &'static str;
    /// English name.
    fn name_en(&self) -> &'static str;
    /// Unit the physical value is shown in (may be empty).
    fn unit(&self) -> &'static str;
    /// Access flags.
    fn access(&self) -> Access;
    /// Default (factory setting) as a raw value, where the manual gives one.
    fn default_raw(&self) -> Option<i64>;
    /// Smallest and largest raw value, where the manual gives a range.
    fn raw_range(&self) -> Option<(i64, i64)>;
    /// Range / meaning text as printed (German).
    fn range_de(&self) -> &'static str;
    /// Range / meaning text in English.
    fn range_en(&self) -> &'static str;
    /// Value list, where the manual gives one (empty otherwise).
    fn values(&self) -> &'static [ValueName] {
        &[]
    }
    /// Decimal places worth showing for the physical value.
    fn decimals(&self) -> u8;
    /// Raw bus value → physical value in [`ParamMeta::unit`].
    fn to_physical(&self, raw: i64) -> f64;
    /// Physical value in [`ParamMeta::unit`] → raw bus value (rounded to the nearest step).
    #[allow(clippy::wrong_self_convention)]
    fn from_physical(&self, value: f64) -> Result<i64, crate::scaling::ScaleError>;

    /// Write a one-line, family-specific description of the scaling, e.g.
    /// `size index 11 (speed), conversion index 66 (A = 1.667e-5, B = 0)` or
    /// `resolution 0.01 s` or `2 decimals, Int`.
    fn describe_scaling(&self, f: &mut dyn fmt::Write) -> fmt::Result {
        let _ = f;
        Ok(())
    }

    /// Every table column of the row as a typed value, keyed by names from
    /// [`COLUMN_KEYS`](crate::columns::COLUMN_KEYS): first the columns every family has
    /// ([`common_columns`](crate::columns::common_columns)), then
    /// [`ParamMeta::family_columns`]. Each key is emitted at most once; keys the family has no
    /// column for are left out. Does not allocate.
    ///
    /// Implementors override [`ParamMeta::family_columns`], not this.
    fn columns(&self, out: &mut FieldSink<'_>) {
        crate::columns::common_columns(self, out);
        self.family_columns(out);
    }

    /// The family's own columns (everything the row type has beyond the [`ParamMeta`]
    /// methods), plus `table_min` / `table_max`: the range ends as the table gives them. Keys
    /// must come from [`COLUMN_KEYS`](crate::columns::COLUMN_KEYS) and not repeat a common key.
    /// Default: none.
    fn family_columns(&self, out: &mut FieldSink<'_>) {
        let _ = out;
    }

    /// Whether `raw` lies within [`ParamMeta::raw_range`] (true when no range is known).
    fn in_range(&self, raw: i64) -> bool {
        self.raw_range()
            .is_none_or(|(lo, hi)| raw >= lo && raw <= hi)
    }

    /// Whether `term` occurs in the German or English name, ignoring case.
    fn name_matches(&self, term: &str) -> bool {
        contains_ignore_case(self.name_de(), term) || contains_ignore_case(self.name_en(), term)
    }

    /// The value list entry for `raw`, if any.
    fn value_name(&self, raw: i64) -> Option<&'static ValueName> {
        self.values().iter().find(|v| v.value == raw)
    }

    /// Whether the value list is the parameter's whole domain, so that a value outside it is
    /// invalid (SEW rows with a value list and no printed range). False where the list only
    /// names some values of a range.
    fn value_list_exhaustive(&self) -> bool {
        false
    }

    /// The smallest and largest raw value the parameter's bus width can carry (its data type,
    /// not its range): a value outside is never sent, whatever the caller forces. Default:
    /// [`WIRE_32`], where the table does not say more.
    fn wire_range(&self) -> (i64, i64) {
        WIRE_32
    }

    /// The label users know the parameter by: `P813` (SEW), `P102` or `P700[-02]` (NORD),
    /// `1376` (Bonfiglioli).
    fn label(&self) -> Label {
        match (self.family(), self.number()) {
            (Family::Movidrive, Some(n)) => Label::new(format_args!("P{n:03}")),
            (Family::Nord, Some(n)) => Label::new(format_args!("P{n}")),
            (_, Some(n)) => Label::new(format_args!("{n}")),
            (_, None) => Label::new(format_args!("#{}", self.bus_index())),
        }
    }
}

/// The [`ParamMeta`] accessors that return a field of the same name, written once for every
/// family's row type: `field_accessors!(name_de: &'static str, name_en: &'static str, …)` inside
/// the `impl ParamMeta` block.
macro_rules! field_accessors {
    ($($field:ident: $ty:ty),* $(,)?) => {
        $(
            fn $field(&self) -> $ty {
                self.$field
            }
        )*
    };
}

pub(crate) use field_accessors;

/// Whether `needle` occurs in `haystack`, the way a parameter name search should match:
/// ignoring case (Unicode simple lowercase) and German spelling variants, without allocation.
///
/// Both sides are folded the same way, so a term typed on a keyboard without umlauts finds the
/// manual's name and vice versa:
///
/// * `ß` (and capital `ẞ`) is `ss`;
/// * `ä`, `ö`, `ü` (any case) in a name match `ä`/`ae`, `ö`/`oe`, `ü`/`ue` in the term, and
///   also the base letter `a`, `o`, `u`: `ueberwachung`, `uberwachung` and `ÜBERWACHUNG` all
///   find "Überwachung", and `Kuehlkoerper` finds "Kühlkörper". One term uses one of the two
///   spellings throughout (`uberwachung` or `ueberwachung`, not `kuhlkoerper`).
/// * An umlaut in the term asks for an umlaut (or its transliteration): `ü` finds "ü" and "ue",
///   never a plain "u".
///
/// The base-letter form can match a little more than intended (`mutter` finds "Mütter"); for a
/// name search that is the kinder mistake.
pub fn contains_ignore_case(haystack: &str, needle: &str) -> bool {
    if needle.is_empty() {
        return true;
    }
    contains_folded(
        fold(haystack, Umlaut::Transliterate),
        fold(needle, Umlaut::Transliterate),
    ) || contains_folded(
        fold(haystack, Umlaut::BaseLetter),
        fold(needle, Umlaut::Keep),
    )
}

/// How [`fold`] spells `ä`, `ö` and `ü`.
#[derive(Clone, Copy)]
enum Umlaut {
    /// `ae`, `oe`, `ue`.
    Transliterate,
    /// `a`, `o`, `u`.
    BaseLetter,
    /// Unchanged (lowercase `ä`, `ö`, `ü`).
    Keep,
}

/// The folded form of `s`: lowercase, `ß` → `ss`, umlauts per `umlaut`.
fn fold(s: &str, umlaut: Umlaut) -> impl Iterator<Item = char> + Clone + '_ {
    s.chars().flat_map(char::to_lowercase).flat_map(move |c| {
        let (first, second) = match (c, umlaut) {
            ('ß', _) => ('s', Some('s')),
            ('ä', Umlaut::Transliterate) => ('a', Some('e')),
            ('ö', Umlaut::Transliterate) => ('o', Some('e')),
            ('ü', Umlaut::Transliterate) => ('u', Some('e')),
            ('ä', Umlaut::BaseLetter) => ('a', None),
            ('ö', Umlaut::BaseLetter) => ('o', None),
            ('ü', Umlaut::BaseLetter) => ('u', None),
            (c, _) => (c, None),
        };
        core::iter::once(first).chain(second)
    })
}

/// Substring search on folded forms (naive, fine for names).
fn contains_folded(
    haystack: impl Iterator<Item = char> + Clone,
    needle: impl Iterator<Item = char> + Clone,
) -> bool {
    // Try every folded position, so a term may also start in the second half of an expanded
    // character (`ß` → `ss`).
    let mut rest = haystack;
    loop {
        let mut h = rest.clone();
        if needle.clone().all(|n| h.next() == Some(n)) {
            return true;
        }
        if rest.next().is_none() {
            return false;
        }
    }
}

/// A fixed-capacity label such as `P813` or `P080.3`, built without allocation.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Label {
    buf: [u8; 16],
    len: u8,
}

impl Label {
    /// Format `args` into a label (truncated at 16 bytes, on a character boundary).
    pub fn new(args: fmt::Arguments<'_>) -> Label {
        let mut l = Label {
            buf: [0; 16],
            len: 0,
        };
        let _ = fmt::write(&mut l, args);
        l
    }

    /// The label text.
    pub fn as_str(&self) -> &str {
        let bytes = self.buf.get(..usize::from(self.len)).unwrap_or(&[]);
        core::str::from_utf8(bytes).unwrap_or("")
    }
}

impl fmt::Write for Label {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for c in s.chars() {
            let mut tmp = [0u8; 4];
            let enc = c.encode_utf8(&mut tmp).as_bytes();
            let start = usize::from(self.len);
            let end = start + enc.len();
            match self.buf.get_mut(start..end) {
                Some(dst) => {
                    dst.copy_from_slice(enc);
                    self.len = end as u8;
                }
                None => return Err(fmt::Error),
            }
        }
        Ok(())
    }
}

impl fmt::Display for Label {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl fmt::Debug for Label {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn access_round_trips_sew_notation() {
        for s in ["RO", "N/RO", "N/R/RW", "N/S/RW", "RW", "R/RW"] {
            let a = Access::parse(s).unwrap();
            assert_eq!(a.to_string(), s);
        }
        assert!(Access::parse("XX").is_none());
        assert!(Access::parse("N/RW").unwrap().is_writable());
        assert!(!Access::parse("N/RO").unwrap().is_writable());
    }

    #[test]
    fn search_ignores_case_beyond_ascii() {
        assert!(contains_ignore_case("Kühlkörpertemperatur", "KÜHL"));
        assert!(contains_ignore_case("SBus Adresse", "bus adr"));
        assert!(!contains_ignore_case("Drehzahl", "zahlen"));
        assert!(contains_ignore_case("x", ""));
    }

    #[test]
    fn search_folds_umlauts_and_sharp_s_on_both_sides() {
        // Issue 7 #18: a keyboard without umlauts finds "Überwachung".
        for term in [
            "ueberwachung",
            "UEBERWACHUNG",
            "uberwachung",
            "Überwachung",
            "ÜBERWACHUNG",
        ] {
            assert!(contains_ignore_case("Drehzahlüberwachung", term), "{term}");
        }
        // Transliterated text in the table is found with an umlaut in the term.
        assert!(contains_ignore_case("Ueberwachung", "überwachung"));
        assert!(contains_ignore_case("Kühlkörpertemperatur", "kuehlkoerper"));
        assert!(contains_ignore_case("Kühlkörpertemperatur", "kuhlkorper"));
        assert!(contains_ignore_case("Kühlkörpertemperatur", "HLK"));
        assert!(contains_ignore_case("Größe", "groesse"));
        assert!(contains_ignore_case("Größe", "GROSSE"));
        assert!(contains_ignore_case("Größe", "GRÖẞE"));
        assert!(contains_ignore_case("GROẞE", "grosse"));
        assert!(contains_ignore_case("Maße", "masse"));
        assert!(contains_ignore_case("Stoß", "ss"));
        assert!(contains_ignore_case("Stoß", "s"));
        assert!(contains_ignore_case("Fäh", "AEH"));
        // Plain ASCII still behaves as before.
        assert!(contains_ignore_case("Steuerung", "steuer"));
        assert!(!contains_ignore_case("Überwachung", "uuberwachung"));
        assert!(!contains_ignore_case("Drehzahl", "ueberwachung"));
        assert!(!contains_ignore_case("Maße", "mase"));
        // An umlaut in the term asks for an umlaut, not for its base letter.
        assert!(!contains_ignore_case("Hochlaufzeit", "ü"));
        assert!(!contains_ignore_case("Mutter", "mütter"));
        assert!(contains_ignore_case("Mütter", "mutter"));
        // One spelling per term.
        assert!(!contains_ignore_case("Kühlkörper", "kuhlkoerper"));
    }

    #[test]
    fn labels_format_without_allocation() {
        let l = Label::new(format_args!("P{:03}", 13));
        assert_eq!(l.as_str(), "P013");
        let long = Label::new(format_args!("{}", "abcdefghijklmnopqrstuvwxyz"));
        assert_eq!(long.as_str(), "abcdefghijklmnop");
    }
}
