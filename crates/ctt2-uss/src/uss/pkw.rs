//! The USS parameter channel (PKW: PKE, IND, PWE1, PWE2), BU 0255 section 4.6.1.
//!
//! * [`Pkw`]: the four raw words as they travel, big-endian (8 bytes; the serial framing may also
//!   carry the 3-word form without PWE1, see [`crate::serial::telegram`]).
//! * [`Pke`] (AK bits 12–15, SPM bit 11, PNU bits 0–10) and [`Ind`] (array element bits 10–15,
//!   parameter set bits 8–9; bits 8–15 as one sub-index for parameters without sets).
//! * [`Order`]: a typed master order (AK 0–14) and [`Reply`]: a typed drive answer (AK 0, 1, 2,
//!   4, 5, 6 and 7 with the PWE2 error number).
//! * [`Order::check`]: the plausibility check of section 4.6.1.1. The drive keeps sending the
//!   answer to the previous order until the new one is done, so an answer is taken only when its
//!   AK is one of the order's positive answers (or 7) and PNU and IND are the order's.
//!
//! Values: a word travels in PWE2 with PWE1 = 0000h, or FFFFh for a negative value (section
//! 4.6.1.3: "bei negativen Werten müssen die High-Bytes mit FFh aufgefüllt werden"); a double
//! word has its high word in PWE1.

use core::fmt;

use drive_profile::nord::{self, AkRequestKind, PweError, Width};

/// Length of the 4-word parameter channel in bytes.
pub const PKW_LEN: usize = 8;

/// The highest parameter number (PNU is 11 bits).
pub const PNU_MAX: u16 = 0x07FF;

/// Parameter identifier PKE: AK (bits 12–15), SPM (bit 11), PNU (bits 0–10).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Pke(pub u16);

impl Pke {
    /// PKE from an AK (0–15) and a PNU (0–2047); `None` when either does not fit.
    pub const fn new(ak: u8, pnu: u16) -> Option<Pke> {
        if ak > 15 || pnu > PNU_MAX {
            return None;
        }
        Some(Pke(((ak as u16) << 12) | pnu))
    }

    /// The order or response ID (bits 12–15).
    pub const fn ak(self) -> u8 {
        (self.0 >> 12) as u8
    }

    /// The toggle bit for spontaneous messages (bit 11; the drive does not support them).
    pub const fn spm(self) -> bool {
        self.0 & 0x0800 != 0
    }

    /// The parameter number (bits 0–10).
    pub const fn pnu(self) -> u16 {
        self.0 & PNU_MAX
    }
}

impl fmt::Debug for Pke {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "Pke(0x{:04X}: AK {}, PNU {}",
            self.0,
            self.ak(),
            self.pnu()
        )?;
        if self.spm() {
            f.write_str(", SPM")?;
        }
        f.write_str(")")
    }
}

/// How IND addresses a parameter's values (section 4.6.1.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum IndLayout {
    /// A parameter with parameter sets: the set in bits 8–9, an array element in bits 10–15.
    ParameterSets,
    /// A parameter without parameter sets: bits 8–15 are one sub-index (the array element).
    Subindex,
}

impl IndLayout {
    /// The layout of parameter `pnu` by the table: [`IndLayout::ParameterSets`] for a
    /// parameter with parameter sets, else [`IndLayout::Subindex`] (also for a PNU that is not in
    /// the table).
    pub fn of_pnu(pnu: u16) -> IndLayout {
        if nord::by_index(pnu).is_some_and(|p| p.parameter_set) {
            IndLayout::ParameterSets
        } else {
            IndLayout::Subindex
        }
    }
}

/// Parameter index IND (section 4.6.1.2).
///
/// For parameters with parameter sets, bits 8–9 select the set (0 = set 1 … 3 = set 4) and
/// bits 10–15 an array element (0 = element [-01] … 63 = [-64]); for parameters without sets
/// bits 8–15 form one sub-index, the array element ([`IndLayout`]). A sub-index takes effect
/// only with the array orders (AK 6, 7, 8, 11, 12). Bits 0–7 carry no information and are 0.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Ind(pub u16);

impl Ind {
    /// IND 0: element [-01], parameter set 1.
    pub const ZERO: Ind = Ind(0);

    /// IND for array element `element` (0-based, 0–63) in parameter set `set` (0-based, 0–3);
    /// `None` when either does not fit.
    pub const fn new(element: u8, set: u8) -> Option<Ind> {
        if element > 63 || set > 3 {
            return None;
        }
        Some(Ind(((element as u16) << 10) | ((set as u16) << 8)))
    }

    /// IND with sub-index `sub` in bits 8–15 (parameters without parameter sets).
    pub const fn subindex(sub: u8) -> Ind {
        Ind((sub as u16) << 8)
    }

    /// IND for array element `element` (0-based) in parameter set `set` (0-based) of a
    /// parameter with `layout`; `None` when they do not fit it (a set other than 0 without
    /// parameter sets, an element above 63 with them).
    pub const fn address(layout: IndLayout, element: u8, set: u8) -> Option<Ind> {
        match layout {
            IndLayout::ParameterSets => Ind::new(element, set),
            IndLayout::Subindex if set == 0 => Some(Ind::subindex(element)),
            IndLayout::Subindex => None,
        }
    }

    /// The array element and parameter set (both 0-based) this IND addresses in a parameter
    /// with `layout`, for an array order (`array`) or not: without an array order the element
    /// is 0 whatever the IND says.
    pub const fn split(self, layout: IndLayout, array: bool) -> (u8, u8) {
        match (layout, array) {
            (IndLayout::ParameterSets, true) => (self.element(), self.set()),
            (IndLayout::ParameterSets, false) => (0, self.set()),
            (IndLayout::Subindex, true) => (self.sub(), 0),
            (IndLayout::Subindex, false) => (0, 0),
        }
    }

    /// The array element field (bits 10–15, 0-based).
    pub const fn element(self) -> u8 {
        (self.0 >> 10) as u8
    }

    /// The parameter set field (bits 8–9, 0-based: 0 = set 1).
    pub const fn set(self) -> u8 {
        ((self.0 >> 8) & 3) as u8
    }

    /// Bits 8–15 as one sub-index (parameters without sets).
    pub const fn sub(self) -> u8 {
        (self.0 >> 8) as u8
    }

    /// Bits 0–7, which should be 0.
    pub const fn low_byte(self) -> u8 {
        self.0 as u8
    }
}

impl fmt::Debug for Ind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "Ind(0x{:04X}: element [-{:02}], set {})",
            self.0,
            self.element() + 1,
            self.set() + 1
        )
    }
}

/// The raw parameter channel: four words.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Pkw {
    /// Parameter identifier.
    pub pke: Pke,
    /// Parameter index.
    pub ind: Ind,
    /// Parameter value, high word.
    pub pwe1: u16,
    /// Parameter value, low word (a 16-bit value is here).
    pub pwe2: u16,
}

/// Why bytes or words are not a valid parameter channel, order or answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum PkwError {
    /// Fewer bytes than the channel needs.
    #[error("parameter channel needs {needed} bytes, got {got}")]
    Truncated {
        /// Bytes needed.
        needed: u8,
        /// Bytes present.
        got: u8,
    },
    /// The output buffer is too small.
    #[error("output buffer of {got} bytes is too small for {needed}")]
    BufferTooSmall {
        /// Bytes needed.
        needed: u8,
        /// Bytes available.
        got: u8,
    },
    /// An order ID the manual marks reserved (4, 5, 10) or does not define (15).
    #[error("order ID {0} is reserved")]
    ReservedOrder(u8),
    /// A response ID the manual does not define (3, 8–15).
    #[error("response ID {0} is not defined")]
    UnknownResponse(u8),
    /// A 16-bit value whose PWE1 is neither 0000h nor FFFFh.
    #[error("word value with PWE1 = {pwe1:#06x} (must be 0000h, or FFFFh for a negative value)")]
    BadWordHigh {
        /// The PWE1 received.
        pwe1: u16,
    },
    /// A word write of a value that does not fit 16 bits (signed or unsigned).
    #[error("{0} does not fit a 16-bit word")]
    WordOverflow(i64),
    /// A parameter number above 2047.
    #[error("parameter number {0} does not fit the 11-bit PNU (0 to 2047)")]
    BadPnu(u16),
    /// An array element or parameter set IND cannot carry for the parameter (0-based: element
    /// 0–63 and set 0–3 with parameter sets; element 0–255 and set 0 without).
    #[error(
        "array element {element} / parameter set {set} (0-based) do not fit IND: 0 to 63 / 0 to 3 \
         for a parameter with parameter sets, 0 to 255 / 0 without"
    )]
    BadIndex {
        /// The element asked for.
        element: u8,
        /// The set asked for.
        set: u8,
    },
}

impl Pkw {
    /// The four words, most significant first.
    pub const fn words(&self) -> [u16; 4] {
        [self.pke.0, self.ind.0, self.pwe1, self.pwe2]
    }

    /// The channel from four words.
    pub const fn from_words(w: [u16; 4]) -> Pkw {
        Pkw {
            pke: Pke(w[0]),
            ind: Ind(w[1]),
            pwe1: w[2],
            pwe2: w[3],
        }
    }

    /// The 8 bytes, each word high byte first.
    pub const fn to_bytes(&self) -> [u8; PKW_LEN] {
        let [a, b] = self.pke.0.to_be_bytes();
        let [c, d] = self.ind.0.to_be_bytes();
        let [e, f] = self.pwe1.to_be_bytes();
        let [g, h] = self.pwe2.to_be_bytes();
        [a, b, c, d, e, f, g, h]
    }

    /// The channel from exactly 8 bytes.
    pub const fn from_array(b: &[u8; PKW_LEN]) -> Pkw {
        Pkw {
            pke: Pke(u16::from_be_bytes([b[0], b[1]])),
            ind: Ind(u16::from_be_bytes([b[2], b[3]])),
            pwe1: u16::from_be_bytes([b[4], b[5]]),
            pwe2: u16::from_be_bytes([b[6], b[7]]),
        }
    }

    /// The channel from the first 8 bytes of `bytes`.
    pub fn decode(bytes: &[u8]) -> Result<Pkw, PkwError> {
        match bytes.first_chunk::<PKW_LEN>() {
            Some(b) => Ok(Pkw::from_array(b)),
            None => Err(PkwError::Truncated {
                needed: PKW_LEN as u8,
                got: bytes.len().min(255) as u8,
            }),
        }
    }

    /// Write the 8 bytes to the front of `out`; returns 8.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, PkwError> {
        let Some(dst) = out.first_chunk_mut::<PKW_LEN>() else {
            return Err(PkwError::BufferTooSmall {
                needed: PKW_LEN as u8,
                got: out.len().min(255) as u8,
            });
        };
        *dst = self.to_bytes();
        Ok(PKW_LEN)
    }

    /// The value as a signed 32-bit number: PWE1 high, PWE2 low.
    pub const fn value32(&self) -> i32 {
        (((self.pwe1 as u32) << 16) | self.pwe2 as u32) as i32
    }
}

/// The value of a word parameter as it travels: PWE1 = 0 (or FFFFh if negative), PWE2 = the
/// word. Accepts −32768…65535 (signed and unsigned words).
pub fn word_pwe(value: i64) -> Result<(u16, u16), PkwError> {
    match value {
        0..=0xFFFF => Ok((0, value as u16)),
        -0x8000..=-1 => Ok((0xFFFF, value as u16)),
        _ => Err(PkwError::WordOverflow(value)),
    }
}

/// The PWE words of a double-word value (PWE1 high word, PWE2 low word).
pub const fn double_pwe(value: i32) -> (u16, u16) {
    ((value as u32 >> 16) as u16, value as u16)
}

/// What a master asks the drive for: one order (section 4.6.1.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Order {
    /// The order ID, 0–14 (never a reserved one).
    ak: u8,
    /// The parameter number.
    pnu: u16,
    /// The index.
    ind: Ind,
    /// PWE1 and PWE2.
    pwe: (u16, u16),
}

/// AK codes of the orders.
pub mod ak {
    /// No order.
    pub const NONE: u8 = 0;
    /// Request parameter value.
    pub const READ: u8 = 1;
    /// Change parameter value (word).
    pub const WRITE_WORD: u8 = 2;
    /// Change parameter value (double word).
    pub const WRITE_DOUBLE: u8 = 3;
    /// Request parameter value (array).
    pub const READ_ARRAY: u8 = 6;
    /// Change parameter value (array, word).
    pub const WRITE_ARRAY_WORD: u8 = 7;
    /// Change parameter value (array, double word).
    pub const WRITE_ARRAY_DOUBLE: u8 = 8;
    /// Request the number of array elements.
    pub const COUNT: u8 = 9;
    /// Change parameter value (array, double word) without writing to EEPROM.
    pub const WRITE_ARRAY_DOUBLE_RAM: u8 = 11;
    /// Change parameter value (array, word) without writing to EEPROM.
    pub const WRITE_ARRAY_WORD_RAM: u8 = 12;
    /// Change parameter value (double word) without writing to EEPROM.
    pub const WRITE_DOUBLE_RAM: u8 = 13;
    /// Change parameter value (word) without writing to EEPROM.
    pub const WRITE_WORD_RAM: u8 = 14;
    /// Response: parameter value (word).
    pub const REPLY_WORD: u8 = 1;
    /// Response: parameter value (double word).
    pub const REPLY_DOUBLE: u8 = 2;
    /// Response: parameter value (array, word).
    pub const REPLY_ARRAY_WORD: u8 = 4;
    /// Response: parameter value (array, double word).
    pub const REPLY_ARRAY_DOUBLE: u8 = 5;
    /// Response: number of array elements.
    pub const REPLY_COUNT: u8 = 6;
    /// Response: the order cannot be executed (error number in PWE2).
    pub const REPLY_ERROR: u8 = 7;
}

/// Where an order's value goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Storage {
    /// RAM and, if P560 says so, EEPROM (AK 2, 3, 7, 8).
    Eeprom,
    /// RAM only (AK 11–14).
    Ram,
}

/// What an order does, decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum OrderKind {
    /// AK 0.
    None,
    /// Read a value (AK 1, or AK 6 with `array`).
    Read {
        /// Whether the IND sub-index addresses an array element (AK 6).
        array: bool,
    },
    /// Write a value.
    Write {
        /// Word or double word.
        width: Width,
        /// Whether the IND sub-index addresses an array element (AK 7, 8, 11, 12).
        array: bool,
        /// EEPROM or RAM only.
        storage: Storage,
        /// The value (a word sign-extended from PWE1/PWE2).
        value: i32,
    },
    /// Read the number of array elements (AK 9).
    Count,
}

impl Order {
    fn make(ak: u8, pnu: u16, ind: Ind, pwe: (u16, u16)) -> Result<Order, PkwError> {
        if pnu > PNU_MAX {
            return Err(PkwError::BadPnu(pnu));
        }
        Ok(Order { ak, pnu, ind, pwe })
    }

    /// AK 0: no order (keeps the channel quiet; the drive answers AK 0).
    pub const fn none() -> Order {
        Order {
            ak: 0,
            pnu: 0,
            ind: Ind::ZERO,
            pwe: (0, 0),
        }
    }

    /// AK 1: read parameter `pnu` with `ind` (parameter set in bits 8–9).
    pub fn read(pnu: u16, ind: Ind) -> Result<Order, PkwError> {
        Self::make(ak::READ, pnu, ind, (0, 0))
    }

    /// AK 6: read array element `ind.element()` of `pnu`.
    pub fn read_array(pnu: u16, ind: Ind) -> Result<Order, PkwError> {
        Self::make(ak::READ_ARRAY, pnu, ind, (0, 0))
    }

    /// AK 9: read the number of array elements of `pnu`.
    pub fn count(pnu: u16, ind: Ind) -> Result<Order, PkwError> {
        Self::make(ak::COUNT, pnu, ind, (0, 0))
    }

    /// A write of `value` with the AK that `width`, `array` and `storage` select
    /// (2, 3, 7, 8, 11, 12, 13, 14). A word must fit −32768…65535, a double word −2³¹…2³²−1.
    pub fn write(
        pnu: u16,
        ind: Ind,
        width: Width,
        array: bool,
        storage: Storage,
        value: i64,
    ) -> Result<Order, PkwError> {
        let code = match (width, array, storage) {
            (Width::Word, false, Storage::Eeprom) => ak::WRITE_WORD,
            (Width::DoubleWord, false, Storage::Eeprom) => ak::WRITE_DOUBLE,
            (Width::Word, true, Storage::Eeprom) => ak::WRITE_ARRAY_WORD,
            (Width::DoubleWord, true, Storage::Eeprom) => ak::WRITE_ARRAY_DOUBLE,
            (Width::Word, false, Storage::Ram) => ak::WRITE_WORD_RAM,
            (Width::DoubleWord, false, Storage::Ram) => ak::WRITE_DOUBLE_RAM,
            (Width::Word, true, Storage::Ram) => ak::WRITE_ARRAY_WORD_RAM,
            (Width::DoubleWord, true, Storage::Ram) => ak::WRITE_ARRAY_DOUBLE_RAM,
        };
        let pwe = match width {
            Width::Word => word_pwe(value)?,
            Width::DoubleWord => {
                if !(i64::from(i32::MIN)..=i64::from(u32::MAX)).contains(&value) {
                    return Err(PkwError::WordOverflow(value));
                }
                double_pwe(value as u32 as i32)
            }
        };
        Self::make(code, pnu, ind, pwe)
    }

    /// The order ID.
    pub const fn ak(&self) -> u8 {
        self.ak
    }

    /// The parameter number.
    pub const fn pnu(&self) -> u16 {
        self.pnu
    }

    /// The index.
    pub const fn ind(&self) -> Ind {
        self.ind
    }

    /// What the order does.
    pub fn kind(&self) -> OrderKind {
        let value = Pkw::from_words([0, 0, self.pwe.0, self.pwe.1]).value32();
        let write = |width, array, storage| OrderKind::Write {
            width,
            array,
            storage,
            value,
        };
        match self.ak {
            ak::READ => OrderKind::Read { array: false },
            ak::READ_ARRAY => OrderKind::Read { array: true },
            ak::COUNT => OrderKind::Count,
            ak::WRITE_WORD => write(Width::Word, false, Storage::Eeprom),
            ak::WRITE_DOUBLE => write(Width::DoubleWord, false, Storage::Eeprom),
            ak::WRITE_ARRAY_WORD => write(Width::Word, true, Storage::Eeprom),
            ak::WRITE_ARRAY_DOUBLE => write(Width::DoubleWord, true, Storage::Eeprom),
            ak::WRITE_ARRAY_DOUBLE_RAM => write(Width::DoubleWord, true, Storage::Ram),
            ak::WRITE_ARRAY_WORD_RAM => write(Width::Word, true, Storage::Ram),
            ak::WRITE_DOUBLE_RAM => write(Width::DoubleWord, false, Storage::Ram),
            ak::WRITE_WORD_RAM => write(Width::Word, false, Storage::Ram),
            _ => OrderKind::None,
        }
    }

    /// The raw channel.
    pub const fn to_pkw(&self) -> Pkw {
        Pkw {
            pke: Pke(((self.ak as u16) << 12) | self.pnu),
            ind: self.ind,
            pwe1: self.pwe.0,
            pwe2: self.pwe.1,
        }
    }

    /// The order a raw channel carries (slave side). SPM is ignored (not supported); reserved
    /// order IDs are refused. A word write whose PWE1 is neither 0 nor FFFFh is refused too.
    pub fn from_pkw(pkw: &Pkw) -> Result<Order, PkwError> {
        let code = pkw.pke.ak();
        match nord::ak_request(code) {
            Some(r) if r.kind != AkRequestKind::Reserved => {
                if r.kind == AkRequestKind::Write
                    && r.width == Some(Width::Word)
                    && pkw.pwe1 != 0
                    && pkw.pwe1 != 0xFFFF
                {
                    return Err(PkwError::BadWordHigh { pwe1: pkw.pwe1 });
                }
                Ok(Order {
                    ak: code,
                    pnu: pkw.pke.pnu(),
                    ind: pkw.ind,
                    pwe: (pkw.pwe1, pkw.pwe2),
                })
            }
            _ => Err(PkwError::ReservedOrder(code)),
        }
    }

    /// The positive response IDs this order may get (section 4.6.1.1), e.g. `[1, 2]` for AK 1.
    pub fn positive_replies(&self) -> &'static [u8] {
        nord::ak_request(self.ak).map_or(&[], |r| r.responses)
    }

    /// The plausibility check of section 4.6.1.1: is `answer` the answer to this order?
    pub fn check(&self, answer: &Pkw) -> Plausibility {
        let got = answer.pke.ak();
        if answer.pke.pnu() != self.pnu || answer.ind != self.ind {
            return Plausibility::Other;
        }
        if self.ak == ak::NONE {
            return if got == 0 {
                Plausibility::Answer(Reply::None)
            } else {
                Plausibility::Other
            };
        }
        if got != ak::REPLY_ERROR && !self.positive_replies().contains(&got) {
            return Plausibility::Other;
        }
        match Reply::from_pkw(answer) {
            Ok(reply) => {
                // A write's positive answer repeats the value written.
                if let OrderKind::Write { value, .. } = self.kind()
                    && let Reply::Value { value: v, .. } = reply
                    && v != value
                {
                    return Plausibility::Other;
                }
                Plausibility::Answer(reply)
            }
            Err(e) => Plausibility::Invalid(e),
        }
    }
}

/// The result of [`Order::check`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Plausibility {
    /// The answer to this order.
    Answer(Reply),
    /// An answer to some other order (typically the previous one, still repeated while the drive
    /// works on this one): ask again.
    Other,
    /// An answer with this order's AK, PNU and IND that cannot be decoded.
    Invalid(PkwError),
}

/// A drive's answer on the parameter channel, decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Reply {
    /// AK 0: no answer.
    None,
    /// AK 1, 2, 4, 5: a value.
    Value {
        /// Word or double word.
        width: Width,
        /// Whether it is an array element (AK 4, 5).
        array: bool,
        /// The value (a word sign-extended by its PWE1).
        value: i32,
    },
    /// AK 6: the number of array elements (in PWE2).
    Count(u16),
    /// AK 7: the order cannot be executed.
    Error(DriveError),
}

/// The error number a drive puts into PWE2 with AK 7.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct DriveError(pub u16);

impl DriveError {
    /// The manual's meaning, if the number is in its table.
    pub fn meaning(self) -> Option<&'static PweError> {
        nord::pwe_error(self.0)
    }
}

impl fmt::Debug for DriveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "DriveError({self})")
    }
}

impl fmt::Display for DriveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.meaning() {
            Some(m) => write!(f, "{m}"),
            None => write!(f, "error {} (not in the manual's table)", self.0),
        }
    }
}

impl Reply {
    /// The answer a raw channel carries.
    pub fn from_pkw(pkw: &Pkw) -> Result<Reply, PkwError> {
        let word = |array| {
            if pkw.pwe1 != 0 && pkw.pwe1 != 0xFFFF {
                Err(PkwError::BadWordHigh { pwe1: pkw.pwe1 })
            } else {
                Ok(Reply::Value {
                    width: Width::Word,
                    array,
                    value: pkw.value32(),
                })
            }
        };
        let double = |array| Reply::Value {
            width: Width::DoubleWord,
            array,
            value: pkw.value32(),
        };
        match pkw.pke.ak() {
            0 => Ok(Reply::None),
            ak::REPLY_WORD => word(false),
            ak::REPLY_DOUBLE => Ok(double(false)),
            ak::REPLY_ARRAY_WORD => word(true),
            ak::REPLY_ARRAY_DOUBLE => Ok(double(true)),
            ak::REPLY_COUNT => Ok(Reply::Count(pkw.pwe2)),
            ak::REPLY_ERROR => Ok(Reply::Error(DriveError(pkw.pwe2))),
            other => Err(PkwError::UnknownResponse(other)),
        }
    }

    /// The raw channel of this answer to parameter `pnu` with `ind` (slave side).
    pub fn to_pkw(&self, pnu: u16, ind: Ind) -> Pkw {
        let pnu = pnu & PNU_MAX;
        let (code, (pwe1, pwe2)) = match *self {
            Reply::None => (0, (0, 0)),
            Reply::Value {
                width: Width::Word,
                array,
                value,
            } => (
                if array {
                    ak::REPLY_ARRAY_WORD
                } else {
                    ak::REPLY_WORD
                },
                if value < 0 {
                    (0xFFFF, value as u16)
                } else {
                    (0, value as u16)
                },
            ),
            Reply::Value {
                width: Width::DoubleWord,
                array,
                value,
            } => (
                if array {
                    ak::REPLY_ARRAY_DOUBLE
                } else {
                    ak::REPLY_DOUBLE
                },
                double_pwe(value),
            ),
            Reply::Count(n) => (ak::REPLY_COUNT, (0, n)),
            Reply::Error(e) => (ak::REPLY_ERROR, (0, e.0)),
        };
        Pkw {
            pke: Pke((u16::from(code) << 12) | pnu),
            ind,
            pwe1,
            pwe2,
        }
    }
}
