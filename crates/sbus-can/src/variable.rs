//! Variable telegrams (manual ch. 5.5): IPOS^plus variables on freely chosen identifiers.
//!
//! A variable object is a standard identifier 0–2047 (the *object number*) and 0–8 data bytes
//! carrying up to two 32-bit IPOS variables: *DataLow* (the variable at `DPointer`) and
//! *DataHigh* (`DPointer + 1`). The `Len` word of the IPOS command structures gives the length
//! in bits 0–3 (0–8) and the byte order in bit 8 ([`Len::from_word`]: `0h…8h` MOTOROLA,
//! `100h…108h` INTEL; anything else is refused).
//!
//! **Byte order.** The manual's tables are the vectors: DataLow 11223344h and DataHigh
//! 55667788h go on the wire as `55 66 77 88 11 22 33 44` (MOTOROLA) and
//! `44 33 22 11 88 77 66 55` (INTEL). Both are the 64-bit number DataHigh:DataLow, MOTOROLA
//! most significant byte first, INTEL least significant byte first. **Shorter lengths**
//! (drivebus's interpretation; the manual only says "the second variable is used only for a
//! length > 4"): a frame of `n` bytes carries the `n` least significant bytes of that 64-bit
//! number, in the same order. So `n ≤ 4` carries only (the low bytes of) DataLow, in both
//! formats, and DataHigh's low `n − 4` bytes join it above 4. Bytes not carried read as 0
//! (no sign extension), and a receive object with `n ≤ 4` leaves its DataHigh as it was.
//! (The INTEL table labels its bytes 0–3 "H21 = DPointer"; they are H20 = DPointer, erratum
//! SB-E10.)
//!
//! **Objects** ([`VariableNode`]): cyclic transmit objects (cycle 1–9 ms in 1 ms steps, at
//! most 5, or 10–65530 ms in 10 ms steps, at most 10; the two limits are separate pools, so a
//! node holds up to 15), receive objects (at most 32) and acyclic transmit objects (the manual
//! gives no limit; drivebus holds 8). Setting up a cyclic object answers the manual's
//! `Result`: the free bus capacity in % from the [bus-load model](crate::busload), or −1 wrong
//! cycle time, −2 too many objects, −3 bus overload ([`SetupResult`]).
//!
//! Nothing here allocates or panics, whatever arrives.
//!
//! ```
//! use sbus_can::variable::{Format, Len, ObjectNo, Variables, decode, encode};
//!
//! let vars = Variables { low: 0x1122_3344, high: 0x5566_7788 };
//! let len = Len::from_word(0x108).unwrap(); // 8 bytes, INTEL
//! let f = encode(ObjectNo::new(1024).unwrap(), len, vars);
//! assert_eq!(f.to_string(), "400#4433221188776655");
//! assert_eq!(decode(&f, len), Ok(vars));
//! ```

use core::fmt;

use drive_core::Instant;
use drive_core::can::{Bitrate, CanEndpoint, CanFrame, Frame, Id, StandardId};

use crate::busload::BusLoad;
use crate::ids::{Kind, SlaveIds};

// ---------------------------------------------------------------------------------------------
// Len word, object numbers, variables
// ---------------------------------------------------------------------------------------------

/// The byte order of a variable telegram (bit 8 of the `Len` word).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Format {
    /// Bit 8 = 0: most significant byte first.
    #[default]
    Motorola,
    /// Bit 8 = 1: least significant byte first.
    Intel,
}

/// The `Len` word of an IPOS variable object: 0–8 data bytes and a [`Format`].
///
/// ```
/// use sbus_can::variable::{Format, Len};
/// let len = Len::from_word(0x104).unwrap();
/// assert_eq!((len.bytes(), len.format()), (4, Format::Intel));
/// assert_eq!(len.to_word(), 0x104);
/// assert!(Len::from_word(0x9).is_err());   // 9 bytes
/// assert!(Len::from_word(0x208).is_err()); // bit 9
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Len {
    bytes: u8,
    format: Format,
}

/// A `Len` word that is none of `0h…8h`, `100h…108h`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct LenError {
    /// The word as given.
    pub word: u32,
}

impl fmt::Display for LenError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "Len word {:X}h is none of 0h…8h (MOTOROLA) and 100h…108h (INTEL)",
            self.word
        )
    }
}

impl core::error::Error for LenError {}

impl Len {
    /// Eight bytes, MOTOROLA (`8h`).
    pub const MOTOROLA_8: Len = Len {
        bytes: 8,
        format: Format::Motorola,
    };
    /// Eight bytes, INTEL (`108h`).
    pub const INTEL_8: Len = Len {
        bytes: 8,
        format: Format::Intel,
    };

    /// `bytes` data bytes (0–8) in `format`; `None` above 8.
    pub const fn new(bytes: u8, format: Format) -> Option<Len> {
        if bytes > 8 {
            None
        } else {
            Some(Len { bytes, format })
        }
    }

    /// The `Len` word of the IPOS structures (a 32-bit IPOS variable): length in bits 0–3,
    /// format in bit 8, every other bit 0.
    pub const fn from_word(word: u32) -> Result<Len, LenError> {
        let bytes = word & 0xF;
        if word & !0x10F != 0 || bytes > 8 {
            return Err(LenError { word });
        }
        let format = if word & 0x100 != 0 {
            Format::Intel
        } else {
            Format::Motorola
        };
        Ok(Len {
            bytes: bytes as u8,
            format,
        })
    }

    /// The `Len` word.
    pub const fn to_word(self) -> u32 {
        self.bytes as u32
            | match self.format {
                Format::Motorola => 0,
                Format::Intel => 0x100,
            }
    }

    /// The number of data bytes, 0–8.
    pub const fn bytes(self) -> usize {
        self.bytes as usize
    }

    /// The byte order.
    pub const fn format(self) -> Format {
        self.format
    }

    /// Whether the second variable (DataHigh) is on the wire: a length above 4.
    pub const fn uses_high(self) -> bool {
        self.bytes > 4
    }
}

/// An object number: the standard CAN identifier of a variable object, 0–2047.
///
/// ```
/// use sbus_can::variable::ObjectNo;
/// assert_eq!(ObjectNo::new(2047).map(ObjectNo::get), Some(2047));
/// assert!(ObjectNo::new(2048).is_none());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct ObjectNo(u16);

impl ObjectNo {
    /// Object number `n`, `None` above 2047.
    pub const fn new(n: u16) -> Option<ObjectNo> {
        if n <= crate::ids::MAX_STANDARD_ID {
            Some(ObjectNo(n))
        } else {
            None
        }
    }

    /// The number.
    pub const fn get(self) -> u16 {
        self.0
    }

    /// The identifier.
    pub fn id(self) -> StandardId {
        StandardId::new(self.0).unwrap_or(StandardId::ZERO)
    }
}

impl fmt::Display for ObjectNo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// The two IPOS variables of a variable object: the 32 bits of each IPOS `long` (take
/// `as i32` for its signed value).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Variables {
    /// DataLow: the variable at `DPointer`.
    pub low: u32,
    /// DataHigh: the variable at `DPointer + 1`, on the wire only for a length above 4.
    pub high: u32,
}

impl Variables {
    /// The 64-bit number DataHigh:DataLow.
    pub const fn to_u64(self) -> u64 {
        (self.high as u64) << 32 | self.low as u64
    }

    /// The variables of the 64-bit number `v` (DataHigh:DataLow).
    pub const fn from_u64(v: u64) -> Variables {
        Variables {
            low: v as u32,
            high: (v >> 32) as u32,
        }
    }
}

/// The data bytes of a variable telegram (the first [`Len::bytes`] are sent; the rest are 0).
///
/// ```
/// use sbus_can::variable::{Len, Variables, to_bytes};
/// let v = Variables { low: 0x1122_3344, high: 0x5566_7788 };
/// // The manual's MOTOROLA table: bytes 0–3 DataHigh, 4–7 DataLow, MSB first.
/// assert_eq!(to_bytes(Len::MOTOROLA_8, v), [0x55, 0x66, 0x77, 0x88, 0x11, 0x22, 0x33, 0x44]);
/// ```
#[inline]
pub const fn to_bytes(len: Len, vars: Variables) -> [u8; 8] {
    let v = vars.to_u64();
    let n = len.bytes as u32;
    match len.format {
        // The n low bytes, most significant first: shift them to the top.
        Format::Motorola => {
            if n == 0 {
                [0; 8]
            } else {
                (v << (64 - 8 * n)).to_be_bytes()
            }
        }
        // The n low bytes, least significant first; clear the rest.
        Format::Intel => {
            if n == 8 {
                v.to_le_bytes()
            } else {
                (v & ((1u64 << (8 * n)) - 1)).to_le_bytes()
            }
        }
    }
}

/// The variables of `data` (0–8 bytes) in `format`, `None` for more than 8 bytes. Bytes not
/// carried read as 0.
#[inline]
pub fn from_bytes(data: &[u8], format: Format) -> Option<Variables> {
    let n = data.len();
    if n > 8 {
        return None;
    }
    let mut buf = [0u8; 8];
    let v = match format {
        Format::Motorola => {
            buf.get_mut(8 - n..)?.copy_from_slice(data);
            u64::from_be_bytes(buf)
        }
        Format::Intel => {
            buf.get_mut(..n)?.copy_from_slice(data);
            u64::from_le_bytes(buf)
        }
    };
    Some(Variables::from_u64(v))
}

/// The frame of variable object `object` with length and format `len`.
#[inline]
pub fn encode(object: ObjectNo, len: Len, vars: Variables) -> CanFrame {
    CanFrame::from_array(object.id().into(), to_bytes(len, vars), len.bytes())
}

/// Why a frame is not the variable telegram an object expects.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum VariableError {
    /// An extended (29-bit) identifier: variable objects are standard identifiers.
    ExtendedId {
        /// The identifier.
        id: u32,
    },
    /// A remote frame: it carries no variables.
    Remote {
        /// The identifier.
        id: u16,
    },
    /// The frame's length is not the object's.
    Length {
        /// The identifier.
        id: u16,
        /// The object's length.
        expected: usize,
        /// The frame's length.
        got: usize,
    },
}

impl fmt::Display for VariableError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            VariableError::ExtendedId { id } => write!(
                f,
                "extended identifier {id:08X}h: variable objects use 11-bit identifiers"
            ),
            VariableError::Remote { id } => {
                write!(
                    f,
                    "remote frame on identifier {id}: it carries no variables"
                )
            }
            VariableError::Length { id, expected, got } => write!(
                f,
                "variable telegram {id} with {got} data bytes, the object has {expected}"
            ),
        }
    }
}

impl core::error::Error for VariableError {}

/// The variables of `frame` for an object of length and format `len`: the frame must be a
/// standard data frame of exactly that length (a different length could only be read as a
/// wrong value). The identifier is the caller's to match.
#[inline]
pub fn decode(frame: &CanFrame, len: Len) -> Result<Variables, VariableError> {
    let id = match frame.id() {
        Id::Standard(s) => s.as_raw(),
        Id::Extended(e) => return Err(VariableError::ExtendedId { id: e.as_raw() }),
    };
    if frame.is_remote_frame() {
        return Err(VariableError::Remote { id });
    }
    let data = frame.data();
    let length = VariableError::Length {
        id,
        expected: len.bytes(),
        got: data.len(),
    };
    if data.len() != len.bytes() {
        return Err(length);
    }
    from_bytes(data, len.format).ok_or(length)
}

// ---------------------------------------------------------------------------------------------
// Object parameters, results and return codes
// ---------------------------------------------------------------------------------------------

/// The two classes of cyclic transmit objects, each with its own maximum (the table of
/// `SCD_TRCYCL`; drivebus reads them as separate pools, see `docs/protocols/sbus.md`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CycleClass {
    /// Cycle 1–9 ms: at most [`MAX_FAST`].
    Fast,
    /// Cycle 10–65530 ms: at most [`MAX_SLOW`].
    Slow,
}

impl CycleClass {
    /// The most objects of the class a device holds.
    pub const fn max(self) -> usize {
        match self {
            CycleClass::Fast => MAX_FAST,
            CycleClass::Slow => MAX_SLOW,
        }
    }
}

impl fmt::Display for CycleClass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            CycleClass::Fast => "cycle 1–9 ms",
            CycleClass::Slow => "cycle 10–65530 ms",
        })
    }
}

/// At most 5 cyclic transmit objects with a cycle of 1–9 ms.
pub const MAX_FAST: usize = 5;
/// At most 10 cyclic transmit objects with a cycle of 10–65530 ms.
pub const MAX_SLOW: usize = 10;
/// At most 32 receive objects.
pub const MAX_RECEIVE: usize = 32;
/// Acyclic transmit objects a [`VariableNode`] holds (the manual gives no limit).
pub const MAX_ACYCLIC: usize = 8;

/// The cycle time and offset of a cyclic transmit object, checked: cycle 1–9 ms (1 ms steps)
/// with offset 0–65534 ms (1 ms steps), or cycle 10–65530 ms (10 ms steps) with offset
/// 0–65530 ms (10 ms steps).
///
/// ```
/// use sbus_can::variable::{CyclicTiming, SetupError};
/// assert!(CyclicTiming::new(100, 0).is_ok());
/// assert!(CyclicTiming::new(5, 65534).is_ok());
/// assert_eq!(CyclicTiming::new(15, 0), Err(SetupError::WrongCycleTime { cycle_ms: 15 }));
/// assert_eq!(CyclicTiming::new(20, 5), Err(SetupError::WrongOffset { offset_ms: 5, cycle_ms: 20 }));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct CyclicTiming {
    cycle_ms: u16,
    offset_ms: u16,
}

impl CyclicTiming {
    /// Cycle `cycle_ms` and offset `offset_ms`, checked as above.
    pub const fn new(cycle_ms: u32, offset_ms: u32) -> Result<CyclicTiming, SetupError> {
        let cycle_ok = matches!(cycle_ms, 1..=9)
            || (cycle_ms >= 10 && cycle_ms <= 65530 && cycle_ms.is_multiple_of(10));
        if !cycle_ok {
            return Err(SetupError::WrongCycleTime { cycle_ms });
        }
        let offset_ok = if cycle_ms < 10 {
            offset_ms <= 65534
        } else {
            offset_ms <= 65530 && offset_ms.is_multiple_of(10)
        };
        if !offset_ok {
            return Err(SetupError::WrongOffset {
                offset_ms,
                cycle_ms,
            });
        }
        Ok(CyclicTiming {
            cycle_ms: cycle_ms as u16,
            offset_ms: offset_ms as u16,
        })
    }

    /// The cycle time in ms.
    pub const fn cycle_ms(self) -> u32 {
        self.cycle_ms as u32
    }

    /// The offset in ms.
    pub const fn offset_ms(self) -> u32 {
        self.offset_ms as u32
    }

    /// The class the cycle belongs to.
    pub const fn class(self) -> CycleClass {
        if self.cycle_ms < 10 {
            CycleClass::Fast
        } else {
            CycleClass::Slow
        }
    }

    const fn cycle_ns(self) -> u64 {
        self.cycle_ms as u64 * 1_000_000
    }

    const fn offset_ns(self) -> u64 {
        self.offset_ms as u64 * 1_000_000
    }
}

/// The `Result` of setting up a cyclic transmit object (`_SBusCommDef(SCD_TRCYCL, …)`).
///
/// ```
/// use sbus_can::variable::SetupResult;
/// assert_eq!(SetupResult::from_code(99), Some(SetupResult::FreeCapacity(99)));
/// assert_eq!(SetupResult::BusOverload.to_code(), -3);
/// assert_eq!(SetupResult::from_code(-4), None);
/// assert_eq!(SetupResult::from_code(101), None);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SetupResult {
    /// ≥ 0: set up; the free bus capacity in % (0–100).
    FreeCapacity(u8),
    /// −1: wrong cycle time.
    WrongCycleTime,
    /// −2: too many objects set up.
    TooManyObjects,
    /// −3: bus overload.
    BusOverload,
}

impl SetupResult {
    /// The value of the IPOS `Result` variable.
    pub const fn to_code(self) -> i32 {
        match self {
            SetupResult::FreeCapacity(p) => p as i32,
            SetupResult::WrongCycleTime => -1,
            SetupResult::TooManyObjects => -2,
            SetupResult::BusOverload => -3,
        }
    }

    /// The result of an IPOS `Result` value; `None` for anything but 0–100 and −1…−3.
    pub const fn from_code(code: i32) -> Option<SetupResult> {
        Some(match code {
            0..=100 => SetupResult::FreeCapacity(code as u8),
            -1 => SetupResult::WrongCycleTime,
            -2 => SetupResult::TooManyObjects,
            -3 => SetupResult::BusOverload,
            _ => return None,
        })
    }
}

impl fmt::Display for SetupResult {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SetupResult::FreeCapacity(p) => write!(f, "{p} % bus capacity free"),
            SetupResult::WrongCycleTime => f.write_str("wrong cycle time (-1)"),
            SetupResult::TooManyObjects => f.write_str("too many objects (-2)"),
            SetupResult::BusOverload => f.write_str("bus overload (-3)"),
        }
    }
}

/// Why an object was not set up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum SetupError {
    /// The cycle time is not 1–9 ms or a multiple of 10 in 10–65530 ms (Result −1).
    WrongCycleTime {
        /// The cycle time given.
        cycle_ms: u32,
    },
    /// The offset is out of 0–65534 ms (cycle < 10 ms) or not a multiple of 10 in 0–65530 ms
    /// (cycle ≥ 10 ms). The manual has no code for it; drivebus answers −1, the code of the
    /// time settings.
    WrongOffset {
        /// The offset given.
        offset_ms: u32,
        /// The cycle time given.
        cycle_ms: u32,
    },
    /// The device already holds the most objects of this kind (Result −2).
    TooManyObjects {
        /// Which limit: `Some` for cyclic objects, `None` for receive or acyclic objects.
        class: Option<CycleClass>,
        /// The limit.
        max: usize,
    },
    /// The device's cyclic objects would load the bus above 100 % (Result −3).
    BusOverload {
        /// The load with the new object.
        load: BusLoad,
    },
    /// The `Len` word is invalid (no Result code in the manual).
    Len(LenError),
    /// The device already uses the object number for another variable object.
    DuplicateObject {
        /// The object number.
        object: ObjectNo,
    },
    /// The device uses the identifier for MOVILINK (rule 2 of ch. 5.5): `kind` is the
    /// MOVILINK telegram, `None` the SYNC telegram (P817).
    MovilinkId {
        /// The object number.
        object: ObjectNo,
        /// The telegram the device uses it for.
        kind: Option<Kind>,
    },
    /// An acyclic object is asked to send again while its telegram is still waiting.
    Busy {
        /// The object number.
        object: ObjectNo,
    },
}

impl SetupError {
    /// The IPOS `Result` of a cyclic object set-up that fails like this, where the manual has
    /// one (−1, −2, −3).
    pub const fn result(&self) -> Option<SetupResult> {
        match self {
            SetupError::WrongCycleTime { .. } | SetupError::WrongOffset { .. } => {
                Some(SetupResult::WrongCycleTime)
            }
            SetupError::TooManyObjects { .. } => Some(SetupResult::TooManyObjects),
            SetupError::BusOverload { .. } => Some(SetupResult::BusOverload),
            _ => None,
        }
    }
}

impl fmt::Display for SetupError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SetupError::WrongCycleTime { cycle_ms } => write!(
                f,
                "wrong cycle time {cycle_ms} ms: 1–9 ms, or 10–65530 ms in steps of 10 ms"
            ),
            SetupError::WrongOffset {
                offset_ms,
                cycle_ms,
            } => {
                if *cycle_ms < 10 {
                    write!(
                        f,
                        "wrong offset {offset_ms} ms: 0–65534 ms for a cycle below 10 ms"
                    )
                } else {
                    write!(
                        f,
                        "wrong offset {offset_ms} ms: 0–65530 ms in steps of 10 ms for a cycle of {cycle_ms} ms"
                    )
                }
            }
            SetupError::TooManyObjects {
                class: Some(class),
                max,
            } => write!(f, "too many cyclic objects with {class}: at most {max}"),
            SetupError::TooManyObjects { class: None, max } => {
                write!(f, "too many objects of this kind: at most {max}")
            }
            SetupError::BusOverload { load } => {
                write!(
                    f,
                    "bus overload: the cyclic objects would load the bus {load}"
                )
            }
            SetupError::Len(e) => e.fmt(f),
            SetupError::DuplicateObject { object } => {
                write!(
                    f,
                    "object {object} is already a variable object of this device"
                )
            }
            SetupError::MovilinkId {
                object,
                kind: Some(kind),
            } => write!(
                f,
                "object {object} is this device's MOVILINK {kind} identifier (ch. 5.5 rule 2)"
            ),
            SetupError::MovilinkId { object, kind: None } => write!(
                f,
                "object {object} is this device's SYNC identifier (P817; ch. 5.5 rule 2)"
            ),
            SetupError::Busy { object } => {
                write!(f, "acyclic object {object} is still sending")
            }
        }
    }
}

impl core::error::Error for SetupError {}

impl From<LenError> for SetupError {
    fn from(e: LenError) -> Self {
        SetupError::Len(e)
    }
}

/// The return code of an acyclic transmit object (`SCD_TRACYCL`, `Returncode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AcyclicStatus {
    /// 0: ready.
    Ready,
    /// 1: sending.
    Sending,
    /// 2: sent.
    Sent,
    /// 3: sending failed.
    Failed,
}

impl AcyclicStatus {
    /// The IPOS return code, 0–3.
    pub const fn to_code(self) -> i32 {
        match self {
            AcyclicStatus::Ready => 0,
            AcyclicStatus::Sending => 1,
            AcyclicStatus::Sent => 2,
            AcyclicStatus::Failed => 3,
        }
    }

    /// The status of return code `code`, `None` outside 0–3.
    pub const fn from_code(code: i32) -> Option<AcyclicStatus> {
        Some(match code {
            0 => AcyclicStatus::Ready,
            1 => AcyclicStatus::Sending,
            2 => AcyclicStatus::Sent,
            3 => AcyclicStatus::Failed,
            _ => return None,
        })
    }
}

// ---------------------------------------------------------------------------------------------
// The node
// ---------------------------------------------------------------------------------------------

/// What a [`VariableNode`] knows of its device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct NodeConfig {
    /// P816, for the bus-load model.
    pub bitrate: Bitrate,
    /// The device's MOVILINK slave identifiers (P813, P814, P817), which its variable objects
    /// must not use (rule 2 of ch. 5.5); `None` for a node that is no SBus slave.
    pub slave: Option<SlaveIds>,
    /// Load the device's other periodic traffic puts on the bus and the bus-load model should
    /// count (e.g. a master-slave master's group telegram every 1 ms). The manual's Result 99
    /// for one 8-byte object every 100 ms counts none: the default.
    pub reserved: BusLoad,
}

impl NodeConfig {
    /// A node at `bitrate`, no MOVILINK identifiers, nothing reserved.
    pub const fn new(bitrate: Bitrate) -> NodeConfig {
        NodeConfig {
            bitrate,
            slave: None,
            reserved: BusLoad::ZERO,
        }
    }
}

/// One cyclic transmit object.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
struct Cyclic {
    object: ObjectNo,
    timing: CyclicTiming,
    len: Len,
    vars: Variables,
    /// When it is due next (set by [`VariableNode::start`]).
    next: Option<Instant>,
    sent: u32,
}

/// What a receive object has received.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Received {
    /// The variables (DataHigh only written by telegrams longer than 4 bytes).
    pub vars: Variables,
    /// Telegrams taken.
    pub count: u32,
    /// When the last one was taken.
    pub at: Option<Instant>,
    /// Telegrams refused for a wrong length (or remote frames) on the identifier.
    pub refused: u32,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
struct Receive {
    object: ObjectNo,
    len: Len,
    got: Received,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
struct Acyclic {
    object: ObjectNo,
    len: Len,
    vars: Variables,
    status: AcyclicStatus,
    /// When the send was asked for (while `Sending`).
    asked: Instant,
}

/// The variable objects of one device, as a sans-IO CAN endpoint ([`CanEndpoint`]).
///
/// Objects are set up ([`define_cyclic`](Self::define_cyclic),
/// [`define_receive`](Self::define_receive)) and then started ([`start`](Self::start), IPOS
/// `_SBusCommOn()`): a cyclic object is due at start + offset + k × cycle (a late poll sends
/// once and skips the cycles it missed), a receive object takes its telegrams from then on.
/// [`send_acyclic`](Self::send_acyclic) (IPOS `SCD_TRACYCL`) sends at once, started or not;
/// its status goes Sending → Sent when [`poll_transmit`](CanEndpoint::poll_transmit) hands the
/// frame out, or → Failed when the transport reports a failure
/// ([`transmit_failed`](Self::transmit_failed)) or the node stops. Objects are addressed by
/// their object number, which is unique within a device. Fixed capacity, no allocation.
///
/// ```
/// use drive_core::Instant;
/// use drive_core::can::{Bitrate, CanEndpoint};
/// use sbus_can::variable::*;
///
/// let mut node = VariableNode::new(NodeConfig::new(Bitrate::K500));
/// let obj = ObjectNo::new(1024).unwrap();
/// let vars = Variables { low: 0x1122_3344, high: 0x5566_7788 };
/// let timing = CyclicTiming::new(100, 0).unwrap();
/// assert_eq!(node.define_cyclic(obj, timing, Len::MOTOROLA_8, vars), Ok(SetupResult::FreeCapacity(99)));
/// node.start(Instant::ZERO);
/// let f = node.poll_transmit(Instant::ZERO).unwrap();
/// assert_eq!(f.to_string(), "400#5566778811223344");
/// assert_eq!(node.poll_timeout(), Some(Instant::from_millis(100)));
/// ```
#[derive(Debug, Clone)]
pub struct VariableNode {
    config: NodeConfig,
    cyclic: [Option<Cyclic>; MAX_FAST + MAX_SLOW],
    receive: [Option<Receive>; MAX_RECEIVE],
    acyclic: [Option<Acyclic>; MAX_ACYCLIC],
    started: Option<Instant>,
}

impl VariableNode {
    /// A node with no objects, not started.
    pub const fn new(config: NodeConfig) -> VariableNode {
        VariableNode {
            config,
            cyclic: [None; MAX_FAST + MAX_SLOW],
            receive: [None; MAX_RECEIVE],
            acyclic: [None; MAX_ACYCLIC],
            started: None,
        }
    }

    /// The configuration.
    pub const fn config(&self) -> &NodeConfig {
        &self.config
    }

    /// The load of the device's cyclic objects (and [`NodeConfig::reserved`]).
    pub fn load(&self) -> BusLoad {
        self.cyclic
            .iter()
            .flatten()
            .fold(self.config.reserved, |sum, c| {
                sum + BusLoad::cyclic_ms(c.len.bytes(), c.timing.cycle_ms(), self.config.bitrate)
            })
    }

    /// Whether the object number is in use by a variable object or by MOVILINK.
    fn check_free(&self, object: ObjectNo) -> Result<(), SetupError> {
        let used = self.cyclic.iter().flatten().any(|c| c.object == object)
            || self.receive.iter().flatten().any(|r| r.object == object)
            || self.acyclic.iter().flatten().any(|a| a.object == object);
        if used {
            return Err(SetupError::DuplicateObject { object });
        }
        if let Some(ids) = self.config.slave
            && let Some(u) = ids.uses().into_iter().find(|u| u.id == object.get())
        {
            return Err(SetupError::MovilinkId {
                object,
                kind: u.kind,
            });
        }
        Ok(())
    }

    /// Sets up a cyclic transmit object (IPOS `_SBusCommDef(SCD_TRCYCL, …)`) sending `vars`
    /// (change them with [`set_data`](Self::set_data)). `Ok` is the Result "free bus capacity";
    /// [`SetupError::result`] gives the Result code of a refusal.
    pub fn define_cyclic(
        &mut self,
        object: ObjectNo,
        timing: CyclicTiming,
        len: Len,
        vars: Variables,
    ) -> Result<SetupResult, SetupError> {
        self.check_free(object)?;
        let class = timing.class();
        let in_class = self
            .cyclic
            .iter()
            .flatten()
            .filter(|c| c.timing.class() == class)
            .count();
        if in_class >= class.max() {
            return Err(SetupError::TooManyObjects {
                class: Some(class),
                max: class.max(),
            });
        }
        let load =
            self.load() + BusLoad::cyclic_ms(len.bytes(), timing.cycle_ms(), self.config.bitrate);
        let Some(free) = load.free_capacity() else {
            return Err(SetupError::BusOverload { load });
        };
        let slot =
            self.cyclic
                .iter_mut()
                .find(|s| s.is_none())
                .ok_or(SetupError::TooManyObjects {
                    class: Some(class),
                    max: class.max(),
                })?;
        let next = self.started.map(|t| t.add_nanos(timing.offset_ns()));
        *slot = Some(Cyclic {
            object,
            timing,
            len,
            vars,
            next,
            sent: 0,
        });
        Ok(SetupResult::FreeCapacity(free))
    }

    /// [`define_cyclic`](Self::define_cyclic) from the raw IPOS structure `SCTRCYCL`
    /// (ObjectNo, CycleTime, Offset, Len), answering the IPOS `Result` value. Refusals the
    /// manual has no code for (an object number above 2047, a wrong `Len` word, an object
    /// number in use) answer `None`.
    pub fn define_cyclic_raw(
        &mut self,
        object: u32,
        cycle_ms: u32,
        offset_ms: u32,
        len_word: u32,
        vars: Variables,
    ) -> Option<SetupResult> {
        let object = ObjectNo::new(u16::try_from(object).ok()?)?;
        let timing = match CyclicTiming::new(cycle_ms, offset_ms) {
            Ok(t) => t,
            Err(e) => return e.result(),
        };
        let len = Len::from_word(len_word).ok()?;
        match self.define_cyclic(object, timing, len, vars) {
            Ok(r) => Some(r),
            Err(e) => e.result(),
        }
    }

    /// Sets up a receive object (IPOS `_SBusCommDef(SCD_REC, …)`); at most 32.
    pub fn define_receive(&mut self, object: ObjectNo, len: Len) -> Result<(), SetupError> {
        self.check_free(object)?;
        let slot =
            self.receive
                .iter_mut()
                .find(|s| s.is_none())
                .ok_or(SetupError::TooManyObjects {
                    class: None,
                    max: MAX_RECEIVE,
                })?;
        *slot = Some(Receive {
            object,
            len,
            got: Received::default(),
        });
        Ok(())
    }

    /// Sends `vars` once on acyclic object `object` (IPOS `_SBusCommDef(SCD_TRACYCL, …)`),
    /// setting it up on its first use. Refused while the object's previous telegram is still
    /// waiting ([`SetupError::Busy`]).
    pub fn send_acyclic(
        &mut self,
        object: ObjectNo,
        len: Len,
        vars: Variables,
        now: Instant,
    ) -> Result<(), SetupError> {
        let existing = self
            .acyclic
            .iter()
            .position(|a| a.is_some_and(|a| a.object == object));
        let index = match existing {
            Some(i) => i,
            None => {
                self.check_free(object)?;
                self.acyclic
                    .iter()
                    .position(Option::is_none)
                    .ok_or(SetupError::TooManyObjects {
                        class: None,
                        max: MAX_ACYCLIC,
                    })?
            }
        };
        let slot = self
            .acyclic
            .get_mut(index)
            .ok_or(SetupError::TooManyObjects {
                class: None,
                max: MAX_ACYCLIC,
            })?;
        if slot.is_some_and(|a| a.status == AcyclicStatus::Sending) {
            return Err(SetupError::Busy { object });
        }
        *slot = Some(Acyclic {
            object,
            len,
            vars,
            status: AcyclicStatus::Sending,
            asked: now,
        });
        Ok(())
    }

    /// The return code of acyclic object `object`; `None` if it was never used.
    pub fn acyclic_status(&self, object: ObjectNo) -> Option<AcyclicStatus> {
        self.acyclic
            .iter()
            .flatten()
            .find(|a| a.object == object)
            .map(|a| a.status)
    }

    /// The transport could not send the frame of acyclic object `object` (bus off, a closed
    /// interface): its status becomes Failed. Returns whether it was waiting or just sent.
    pub fn transmit_failed(&mut self, object: ObjectNo) -> bool {
        match self
            .acyclic
            .iter_mut()
            .flatten()
            .find(|a| a.object == object)
        {
            Some(a) if matches!(a.status, AcyclicStatus::Sending | AcyclicStatus::Sent) => {
                a.status = AcyclicStatus::Failed;
                true
            }
            _ => false,
        }
    }

    /// Changes the variables a cyclic object sends; `false` if it is none of this node's.
    pub fn set_data(&mut self, object: ObjectNo, vars: Variables) -> bool {
        match self
            .cyclic
            .iter_mut()
            .flatten()
            .find(|c| c.object == object)
        {
            Some(c) => {
                c.vars = vars;
                true
            }
            None => false,
        }
    }

    /// What receive object `object` has received; `None` if it is none of this node's.
    pub fn received(&self, object: ObjectNo) -> Option<Received> {
        self.receive
            .iter()
            .flatten()
            .find(|r| r.object == object)
            .map(|r| r.got)
    }

    /// How many telegrams cyclic object `object` has sent.
    pub fn sent(&self, object: ObjectNo) -> Option<u32> {
        self.cyclic
            .iter()
            .flatten()
            .find(|c| c.object == object)
            .map(|c| c.sent)
    }

    /// Starts the cyclic and receive objects (IPOS `_SBusCommOn()`) at `now`. Starting a
    /// started node starts it again from `now`.
    pub fn start(&mut self, now: Instant) {
        self.started = Some(now);
        for c in self.cyclic.iter_mut().flatten() {
            c.next = Some(now.add_nanos(c.timing.offset_ns()));
        }
    }

    /// Stops every object (an IPOS program stop): nothing cyclic is sent or received, and a
    /// waiting acyclic telegram fails. The objects stay set up.
    pub fn stop(&mut self) {
        self.started = None;
        for c in self.cyclic.iter_mut().flatten() {
            c.next = None;
        }
        for a in self.acyclic.iter_mut().flatten() {
            if a.status == AcyclicStatus::Sending {
                a.status = AcyclicStatus::Failed;
            }
        }
    }

    /// Whether the node is started.
    pub const fn is_started(&self) -> bool {
        self.started.is_some()
    }

    /// Removes every object and stops.
    pub fn clear(&mut self) {
        *self = VariableNode::new(self.config);
    }
}

impl CanEndpoint for VariableNode {
    fn handle_frame(&mut self, frame: &CanFrame, now: Instant) {
        if self.started.is_none() {
            return;
        }
        let Some(id) = frame.standard_id() else {
            return;
        };
        let Some(r) = self
            .receive
            .iter_mut()
            .flatten()
            .find(|r| r.object.get() == id)
        else {
            return;
        };
        match decode(frame, r.len) {
            Ok(v) => {
                r.got.vars.low = v.low;
                if r.len.uses_high() {
                    r.got.vars.high = v.high;
                }
                r.got.count = r.got.count.wrapping_add(1);
                r.got.at = Some(now);
            }
            Err(_) => r.got.refused = r.got.refused.wrapping_add(1),
        }
    }

    fn handle_timeout(&mut self, _now: Instant) {
        // Everything due is handed out by poll_transmit.
    }

    fn poll_transmit(&mut self, now: Instant) -> Option<CanFrame> {
        // The earliest due telegram; among equal times the lower identifier (the one that
        // would win arbitration). Acyclic telegrams are due when asked for.
        let mut best: Option<(Instant, u16, bool, usize)> = None;
        for (i, a) in self.acyclic.iter().enumerate() {
            if let Some(a) = a
                && a.status == AcyclicStatus::Sending
                && a.asked <= now
            {
                let key = (a.asked, a.object.get(), true, i);
                if best.is_none_or(|b| (key.0, key.1) < (b.0, b.1)) {
                    best = Some(key);
                }
            }
        }
        for (i, c) in self.cyclic.iter().enumerate() {
            if let Some(c) = c
                && let Some(next) = c.next
                && next <= now
            {
                let key = (next, c.object.get(), false, i);
                if best.is_none_or(|b| (key.0, key.1) < (b.0, b.1)) {
                    best = Some(key);
                }
            }
        }
        let (_, _, acyclic, i) = best?;
        if acyclic {
            let a = self.acyclic.get_mut(i)?.as_mut()?;
            a.status = AcyclicStatus::Sent;
            return Some(encode(a.object, a.len, a.vars));
        }
        let c = self.cyclic.get_mut(i)?.as_mut()?;
        let next = c.next?;
        let cycle = c.timing.cycle_ns();
        // The next grid point after `now` (skipping missed cycles).
        let late = now.nanos_since(next);
        c.next = Some(next.add_nanos((late / cycle + 1) * cycle));
        c.sent = c.sent.wrapping_add(1);
        Some(encode(c.object, c.len, c.vars))
    }

    fn poll_timeout(&self) -> Option<Instant> {
        let acyclic = self
            .acyclic
            .iter()
            .flatten()
            .filter(|a| a.status == AcyclicStatus::Sending)
            .map(|a| a.asked)
            .min();
        let cyclic = self.cyclic.iter().flatten().filter_map(|c| c.next).min();
        drive_core::time::earliest(acyclic, cyclic)
    }
}

#[cfg(test)]
mod tests;
