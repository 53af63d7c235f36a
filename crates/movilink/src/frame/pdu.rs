//! The PDU type byte (TYP) (manual ch. 4.2, "PDU-Typ").

use core::fmt;

/// A known PDU type: the 7 standard layouts, each cyclic (0x00–0x06) or acyclic (0x80–0x86).
///
/// | TYP | name | PDU bytes | telegram bytes |
/// |---|---|---|---|
/// | 0x00 / 0x80 | PARAM + 1PD | 10 | 14 |
/// | 0x01 / 0x81 | 1PD | 2 | 6 |
/// | 0x02 / 0x82 | PARAM + 2PD | 12 | 16 |
/// | 0x03 / 0x83 | 2PD | 4 | 8 |
/// | 0x04 / 0x84 | PARAM + 3PD | 14 | 18 |
/// | 0x05 / 0x85 | 3PD | 6 | 10 |
/// | 0x06 / 0x86 | PARAM + 0PD | 8 | 12 |
///
/// Bit 7 set = acyclic: the drive does not monitor the link (no P812 timeout) and executes the
/// parameter channel of every request. Cyclic: the drive monitors the link and executes a
/// parameter service only when the handshake bit toggles.
///
/// ```
/// use movilink::PduType;
/// let t = PduType::new(0x84).unwrap();
/// assert_eq!(t, PduType::PARAM_3PD_ACYCLIC);
/// assert!(!t.is_cyclic() && t.has_param());
/// assert_eq!((t.pd_words(), t.pdu_len(), t.telegram_len()), (3, 14, 18));
/// assert_eq!(PduType::new(0x07), None);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct PduType(u8);

/// Bit 7 of the TYP byte: acyclic transmission.
const ACYCLIC_BIT: u8 = 0x80;

impl PduType {
    /// 0x00: parameter channel + 1 process data word, cyclic.
    pub const PARAM_1PD: Self = Self(0x00);
    /// 0x01: 1 process data word, cyclic.
    pub const PD1: Self = Self(0x01);
    /// 0x02: parameter channel + 2 process data words, cyclic.
    pub const PARAM_2PD: Self = Self(0x02);
    /// 0x03: 2 process data words, cyclic.
    pub const PD2: Self = Self(0x03);
    /// 0x04: parameter channel + 3 process data words, cyclic.
    pub const PARAM_3PD: Self = Self(0x04);
    /// 0x05: 3 process data words, cyclic.
    pub const PD3: Self = Self(0x05);
    /// 0x06: parameter channel only, cyclic.
    pub const PARAM_0PD: Self = Self(0x06);
    /// 0x80: parameter channel + 1 process data word, acyclic.
    pub const PARAM_1PD_ACYCLIC: Self = Self(0x80);
    /// 0x81: 1 process data word, acyclic.
    pub const PD1_ACYCLIC: Self = Self(0x81);
    /// 0x82: parameter channel + 2 process data words, acyclic.
    pub const PARAM_2PD_ACYCLIC: Self = Self(0x82);
    /// 0x83: 2 process data words, acyclic.
    pub const PD2_ACYCLIC: Self = Self(0x83);
    /// 0x84: parameter channel + 3 process data words, acyclic.
    pub const PARAM_3PD_ACYCLIC: Self = Self(0x84);
    /// 0x85: 3 process data words, acyclic.
    pub const PD3_ACYCLIC: Self = Self(0x85);
    /// 0x86: parameter channel only, acyclic. Every drive supports READ in this type.
    pub const PARAM_0PD_ACYCLIC: Self = Self(0x86);

    /// All 14 PDU types, cyclic first.
    pub const ALL: [Self; 14] = [
        Self::PARAM_1PD,
        Self::PD1,
        Self::PARAM_2PD,
        Self::PD2,
        Self::PARAM_3PD,
        Self::PD3,
        Self::PARAM_0PD,
        Self::PARAM_1PD_ACYCLIC,
        Self::PD1_ACYCLIC,
        Self::PARAM_2PD_ACYCLIC,
        Self::PD2_ACYCLIC,
        Self::PARAM_3PD_ACYCLIC,
        Self::PD3_ACYCLIC,
        Self::PARAM_0PD_ACYCLIC,
    ];

    /// The PDU type of the TYP byte `raw`, `None` for unknown or special types.
    pub const fn new(raw: u8) -> Option<Self> {
        if raw & !ACYCLIC_BIT <= 0x06 {
            Some(Self(raw))
        } else {
            None
        }
    }

    /// The PDU type with a parameter channel or not and `pd_words` (0–3) process data words;
    /// `None` for the combinations that do not exist (0 words without parameter channel).
    pub const fn from_layout(has_param: bool, pd_words: u8, cyclic: bool) -> Option<Self> {
        let base = match (has_param, pd_words) {
            (true, 1) => 0x00,
            (false, 1) => 0x01,
            (true, 2) => 0x02,
            (false, 2) => 0x03,
            (true, 3) => 0x04,
            (false, 3) => 0x05,
            (true, 0) => 0x06,
            _ => return None,
        };
        Some(Self(if cyclic { base } else { base | ACYCLIC_BIT }))
    }

    /// The TYP byte.
    pub const fn raw(self) -> u8 {
        self.0
    }

    /// Bit 7 clear: cyclic transmission (the drive monitors the link with P812).
    pub const fn is_cyclic(self) -> bool {
        self.0 & ACYCLIC_BIT == 0
    }

    /// The PDU carries the 8-byte parameter channel (before the process data).
    pub const fn has_param(self) -> bool {
        matches!(self.0 & !ACYCLIC_BIT, 0x00 | 0x02 | 0x04 | 0x06)
    }

    /// Number of process data words (0–3).
    pub const fn pd_words(self) -> usize {
        match self.0 & !ACYCLIC_BIT {
            0x00 | 0x01 => 1,
            0x02 | 0x03 => 2,
            0x04 | 0x05 => 3,
            _ => 0,
        }
    }

    /// PDU length in bytes.
    pub const fn pdu_len(self) -> usize {
        (if self.has_param() { 8 } else { 0 }) + 2 * self.pd_words()
    }

    /// Telegram length in bytes: SD, ADR, TYP, PDU, BCC = PDU length + 4.
    pub const fn telegram_len(self) -> usize {
        self.pdu_len() + 4
    }

    /// The same layout, cyclic.
    pub const fn to_cyclic(self) -> Self {
        Self(self.0 & !ACYCLIC_BIT)
    }

    /// The same layout, acyclic.
    pub const fn to_acyclic(self) -> Self {
        Self(self.0 | ACYCLIC_BIT)
    }
}

impl TryFrom<u8> for PduType {
    type Error = crate::DecodeError;

    fn try_from(raw: u8) -> Result<Self, Self::Error> {
        PduType::new(raw).ok_or(crate::DecodeError::UnknownPduType { pdu_type: raw })
    }
}

impl From<PduType> for u8 {
    fn from(t: PduType) -> u8 {
        t.0
    }
}

impl fmt::Display for PduType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self.0 & !ACYCLIC_BIT {
            0x00 => "PARAM+1PD",
            0x01 => "1PD",
            0x02 => "PARAM+2PD",
            0x03 => "2PD",
            0x04 => "PARAM+3PD",
            0x05 => "3PD",
            _ => "PARAM+0PD",
        };
        let kind = if self.is_cyclic() {
            "cyclic"
        } else {
            "acyclic"
        };
        write!(f, "{name} {kind} ({:#04x})", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_of_chapter_4_2() {
        // (TYP, has param, PD words, PDU length, telegram length) from the two tables.
        let table: [(u8, bool, usize, usize, usize); 7] = [
            (0x00, true, 1, 10, 14),
            (0x01, false, 1, 2, 6),
            (0x02, true, 2, 12, 16),
            (0x03, false, 2, 4, 8),
            (0x04, true, 3, 14, 18),
            (0x05, false, 3, 6, 10),
            (0x06, true, 0, 8, 12),
        ];
        for (raw, param, words, pdu, tel) in table {
            for (typ, cyclic) in [(raw, true), (raw | 0x80, false)] {
                let t = PduType::new(typ).unwrap();
                assert_eq!(t.is_cyclic(), cyclic);
                assert_eq!(t.has_param(), param);
                assert_eq!(t.pd_words(), words);
                assert_eq!(t.pdu_len(), pdu);
                assert_eq!(t.telegram_len(), tel);
                assert_eq!(PduType::from_layout(param, words as u8, cyclic), Some(t));
            }
        }
        // `ALL` holds exactly the types `new` accepts: the 14 of the manual.
        let known: Vec<PduType> = (0..=255u8).filter_map(PduType::new).collect();
        assert_eq!(known.len(), 14);
        let mut all = PduType::ALL.to_vec();
        all.sort_by_key(|t| t.raw());
        assert_eq!(all, known);
        assert_eq!(PduType::from_layout(false, 0, true), None);
        assert_eq!(PduType::PD3.to_acyclic(), PduType::PD3_ACYCLIC);
        assert_eq!(PduType::PD3_ACYCLIC.to_cyclic(), PduType::PD3);
        assert!(PduType::try_from(0x87).is_err());
    }
}
