//! What a MOVIDRIVE's identification parameters tell about the unit: P070 "Gerätetyp" (unit
//! type, index 8301) and P071 "Gerätenennstrom" (unit rated current, index 8361).
//!
//! The serial communication manual's parameter list (ch. 7.2, group "07. Gerätedaten") gives
//! P070 as read-only, index 8301, size and conversion index 0, default 0, and leaves the
//! meaning column empty: **no manual at hand codes the value**, and none maps it to a type
//! designation such as `MDX61B0015-5A3`. So [`designation`] names no value: it returns `None`
//! rather than guess from the digits. When a manual with the coding turns up, its rows go into
//! `DESIGNATIONS`, each with a test quoting the manual.
//!
//! What the manual does give is P071, the rated current in A (0.001 A per raw unit), which a
//! tool can show next to the unnamed type number.
//!
//! ```
//! use drive_profile::sew::device;
//! // The simulated drive's P070 value is a simulator choice, not a coded type: unnamed.
//! assert_eq!(device::designation(60_001_553), None);
//! ```

/// Type designations by P070 value, from the manuals. Empty: the manuals at hand give no
/// coding of P070 (see the module documentation).
const DESIGNATIONS: &[(u32, &str)] = &[];

/// The type designation (e.g. `MDX61B0015-5A3`) of a P070 unit type value, if a manual gives
/// one; `None` for every value the manuals do not name (today: every value).
pub fn designation(unit_type: u32) -> Option<&'static str> {
    DESIGNATIONS
        .iter()
        .find(|(value, _)| *value == unit_type)
        .map(|(_, name)| *name)
}

/// Fault names the manuals at hand give (fault number, display text). The serial manual names
/// only F47 (ch. 5, P815 "SBus timeout delay": "Geräte-Fehler F47: TIMEOUT SBUS"); MOVIDRIVE's
/// fault list is in its operating instructions, which are not at hand, so every other number is
/// shown without a name rather than guessed.
const FAULTS: &[(u8, &str)] = &[(47, "TIMEOUT SBUS")];

/// The display text of MOVIDRIVE fault `number` (status word 1's high byte while bit 5 is
/// set), if a manual at hand names it.
pub fn fault_name(number: u8) -> Option<&'static str> {
    FAULTS.iter().find(|(n, _)| *n == number).map(|(_, t)| *t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_one_fault_the_serial_manual_names() {
        assert_eq!(fault_name(47), Some("TIMEOUT SBUS"));
        assert_eq!(fault_name(43), None);
        assert_eq!(fault_name(0), None);
    }
    use crate::param::{Access, ParamMeta};
    use crate::sew::{by_index, index};

    /// Manual, "070 Gerätetyp 8301 206D 0 0 RO 0" with an empty meaning column: read-only, no
    /// unit, no value list, so nothing to name a value with.
    #[test]
    fn p070_is_read_only_and_its_values_have_no_meaning_in_the_manual() {
        let p = by_index(index::UNIT_TYPE).unwrap();
        assert_eq!(p.menu_label().as_str(), "P070");
        assert_eq!(p.name_de(), "Gerätetyp");
        assert_eq!(p.access(), Access::READ_ONLY);
        assert_eq!(p.unit(), "");
        for raw in [0, 1, 61, 60_001_553, i64::from(u32::MAX)] {
            assert!(p.value_name(raw).is_none(), "{raw}");
        }
    }

    /// `designation` names a P070 value only where the manual does, and the manual's row
    /// (the generated table) names none: not 0 (the default), not the simulator's choice, not
    /// a number that merely spells a designation.
    #[test]
    fn no_value_is_named_without_a_manual_row() {
        let p = by_index(index::UNIT_TYPE).unwrap();
        for v in [0, 1, 60, 61, 60_001_553, 61_001_553, u32::MAX] {
            let named_by_the_manual = p.value_name(i64::from(v)).is_some();
            assert_eq!(designation(v).is_some(), named_by_the_manual, "{v}");
        }
    }

    /// Manual, "071 Gerätenennstrom [A] 8361 20A9 A 22 -3 RO 0": amperes, 0.001 A per raw unit.
    #[test]
    fn p071_is_the_rated_current_in_amperes() {
        let p = by_index(index::RATED_CURRENT).unwrap();
        assert_eq!(p.menu_label().as_str(), "P071");
        assert_eq!(p.access(), Access::READ_ONLY);
        assert_eq!(p.unit(), "A");
        assert!((p.to_physical(4_000) - 4.0).abs() < 1e-9);
    }
}
