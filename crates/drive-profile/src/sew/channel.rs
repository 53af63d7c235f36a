//! The SEW parameter channel: the 8 bytes MOVILINK (RS-485) and SBus (CAN) both carry, with its
//! services and return codes (serial communication manual ch. 4.3, 5 and 6.2; MDX60B manual
//! ch. 7.6.1). The manual says the return codes hold for every interface, so MOVILINK, SBus, the
//! simulated MOVIDRIVE and drivectl all use these types.
//!
//! | byte | 0 | 1 | 2 | 3 | 4 | 5 | 6 | 7 |
//! |---|---|---|---|---|---|---|---|---|
//! | field | management | subindex (reserved, 0) | index high | index low | data MSB | data | data | data LSB |
//!
//! Management byte: bits 0–3 service, bits 4–5 data length (00 = 1 … 11 = 4 bytes), bit 6
//! handshake (MOVILINK's cyclic handshake; SBus: answer at once or after the next SYNC), bit 7
//! status (1 = the service failed and bytes 4–7 hold a [`ReturnCode`]).

use core::fmt;

use super::{DecodedReturnCode, ReturnCodeInfo, describe_return_code, return_code_info};

/// A parameter service (bits 0–3 of the management byte).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
#[repr(u8)]
pub enum Service {
    /// 0000: no parameter service.
    NoService = 0,
    /// 0001: read the parameter value.
    Read = 1,
    /// 0010: write non-volatile (EEPROM); not for cyclic writes, EEPROMs wear out.
    Write = 2,
    /// 0011: write volatile (RAM only, lost at power-off).
    WriteVolatile = 3,
    /// 0100: read the smallest settable value.
    ReadMinimum = 4,
    /// 0101: read the largest settable value.
    ReadMaximum = 5,
    /// 0110: read the default (factory setting).
    ReadDefault = 6,
    /// 0111: read the scaling: size index and conversion index ([`ScaleInfo`]).
    ReadScale = 7,
    /// 1000: read the access attributes and the next index ([`AttributeInfo`]).
    ReadAttribute = 8,
}

impl Service {
    /// The service of the 4-bit code `code`, `None` for 9–15 (and anything above 15).
    pub const fn from_code(code: u8) -> Option<Self> {
        Some(match code {
            0 => Self::NoService,
            1 => Self::Read,
            2 => Self::Write,
            3 => Self::WriteVolatile,
            4 => Self::ReadMinimum,
            5 => Self::ReadMaximum,
            6 => Self::ReadDefault,
            7 => Self::ReadScale,
            8 => Self::ReadAttribute,
            _ => return None,
        })
    }

    /// The 4-bit service code.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// Whether the service changes the drive (write or write volatile).
    pub const fn is_write(self) -> bool {
        matches!(self, Self::Write | Self::WriteVolatile)
    }

    /// The service's English name, e.g. `write volatile`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::NoService => "no service",
            Self::Read => "read",
            Self::Write => "write",
            Self::WriteVolatile => "write volatile",
            Self::ReadMinimum => "read minimum",
            Self::ReadMaximum => "read maximum",
            Self::ReadDefault => "read default",
            Self::ReadScale => "read scale",
            Self::ReadAttribute => "read attribute",
        }
    }
}

impl fmt::Display for Service {
    /// [`Service::name`].
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The data length of the management byte (bits 4–5). SEW drives always use 4 bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum DataLength {
    /// 00: 1 byte.
    One = 0,
    /// 01: 2 bytes.
    Two = 1,
    /// 10: 3 bytes.
    Three = 2,
    /// 11: 4 bytes (the value for every SEW parameter).
    Four = 3,
}

impl DataLength {
    /// Number of bytes (1–4).
    pub const fn bytes(self) -> u8 {
        self as u8 + 1
    }

    const fn from_bits(bits: u8) -> Self {
        match bits & 0b11 {
            0 => Self::One,
            1 => Self::Two,
            2 => Self::Three,
            _ => Self::Four,
        }
    }
}

/// The management byte (byte 0) of the parameter channel, kept raw so that an unknown service
/// code received from the wire survives decoding (a drive answers it with
/// [`ReturnCode::ILLEGAL_SERVICE_CODING`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Management(u8);

impl Management {
    const SERVICE_MASK: u8 = 0x0F;
    const LENGTH_SHIFT: u8 = 4;
    const HANDSHAKE: u8 = 0x40;
    const STATUS: u8 = 0x80;

    /// Service and data length, handshake and status bits clear.
    pub const fn new(service: Service, length: DataLength) -> Self {
        Self(service.code() | ((length as u8) << Self::LENGTH_SHIFT))
    }

    /// The byte as received.
    pub const fn from_raw(raw: u8) -> Self {
        Self(raw)
    }

    /// The byte.
    pub const fn raw(self) -> u8 {
        self.0
    }

    /// The service, `None` for the undefined codes 9–15.
    pub const fn service(self) -> Option<Service> {
        Service::from_code(self.service_code())
    }

    /// Bits 0–3.
    pub const fn service_code(self) -> u8 {
        self.0 & Self::SERVICE_MASK
    }

    /// Bits 4–5.
    pub const fn data_length(self) -> DataLength {
        DataLength::from_bits(self.0 >> Self::LENGTH_SHIFT)
    }

    /// Bit 6: the handshake bit (cyclic PDU types).
    pub const fn handshake(self) -> bool {
        self.0 & Self::HANDSHAKE != 0
    }

    /// Bit 7: the status bit; set = the service failed.
    pub const fn is_error(self) -> bool {
        self.0 & Self::STATUS != 0
    }

    /// The same byte with the handshake bit `on`.
    #[must_use]
    pub const fn with_handshake(self, on: bool) -> Self {
        if on {
            Self(self.0 | Self::HANDSHAKE)
        } else {
            Self(self.0 & !Self::HANDSHAKE)
        }
    }

    /// The same byte with the status (error) bit `on`.
    #[must_use]
    pub const fn with_error(self, on: bool) -> Self {
        if on {
            Self(self.0 | Self::STATUS)
        } else {
            Self(self.0 & !Self::STATUS)
        }
    }
}

/// Answer of [`Service::ReadScale`]: bytes 6 and 7 of the data (bytes 4–5 reserved).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ScaleInfo {
    /// PNO size index (physical quantity), [`ScaleInfo::NO_SIZE_INDEX`] if none.
    pub size_index: u8,
    /// PNO conversion index: power of ten to the SI unit (e.g. -3 = milli).
    pub conversion_index: i8,
}

impl ScaleInfo {
    /// Size index 0xFF: no size index given.
    pub const NO_SIZE_INDEX: u8 = 0xFF;

    /// Decode from the 4 data bytes.
    pub const fn from_data(data: u32) -> Self {
        let [_, _, size, conv] = data.to_be_bytes();
        Self {
            size_index: size,
            conversion_index: conv as i8,
        }
    }

    /// Encode into the 4 data bytes (reserved bytes 0).
    pub const fn to_data(self) -> u32 {
        u32::from_be_bytes([0, 0, self.size_index, self.conversion_index as u8])
    }

    /// Whether a size index is given (not 0xFF).
    pub const fn has_size_index(self) -> bool {
        self.size_index != Self::NO_SIZE_INDEX
    }
}

/// Answer of [`Service::ReadAttribute`].
///
/// The MOVIDRIVE serial manual's table puts "next available index" at the MSB end (from byte
/// 4) and "access attributes" at byte 7, without drawing the boundary in between; an index is a
/// 16-bit value and the SEW unit profile (MOVITRAC B, same parameter channel) defines the
/// access attributes as a 16-bit word in bytes 6–7 (bits 0–6 access flags, bits 7–8 parameter
/// set). So: bytes 4–5 = next index, bytes 6–7 = attributes; on MOVIDRIVE byte 6 is 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct AttributeInfo {
    /// Index of the next available parameter (bytes 4–5).
    pub next_index: u16,
    /// Device-specific access attributes (bytes 6–7).
    pub attributes: u16,
}

impl AttributeInfo {
    /// Decode from the 4 data bytes.
    pub const fn from_data(data: u32) -> Self {
        Self {
            next_index: (data >> 16) as u16,
            attributes: data as u16,
        }
    }

    /// Encode into the 4 data bytes.
    pub const fn to_data(self) -> u32 {
        ((self.next_index as u32) << 16) | self.attributes as u32
    }
}

/// The parameter channel: management, subindex, index and 4 data bytes (MSB first).
///
/// The same type is used for requests and answers. Requests are built with the service
/// constructors; answers are read with [`ParamChannel::result`] and friends.
///
/// ```
/// use drive_profile::sew::{ParamChannel, ReturnCode, Service};
/// let req = ParamChannel::write_volatile(8490, 1500);
/// assert_eq!(req.to_bytes(), [0x33, 0x00, 0x21, 0x2A, 0x00, 0x00, 0x05, 0xDC]);
/// let ok = req.answer(Ok(1500));
/// assert_eq!(ok.result(), Ok(1500));
/// let err = req.answer(Err(ReturnCode::READ_ONLY));
/// assert_eq!(err.result(), Err(ReturnCode::READ_ONLY));
/// assert_eq!(err.management.service(), Some(Service::WriteVolatile));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct ParamChannel {
    /// Byte 0.
    pub management: Management,
    /// Byte 1: subindex (MOVIDRIVE B), "reserved, 0" in older manuals.
    pub subindex: u8,
    /// Bytes 2–3: the parameter index.
    pub index: u16,
    /// Bytes 4–7: data, right-aligned, MSB first.
    pub data: u32,
}

impl ParamChannel {
    /// Length on the wire.
    pub const LEN: usize = 8;

    /// A request for `service` on `index` with `data`, data length 4 bytes, subindex 0.
    pub const fn request(service: Service, index: u16, data: u32) -> Self {
        Self {
            management: Management::new(service, DataLength::Four),
            subindex: 0,
            index,
            data,
        }
    }

    /// An idle channel: no service.
    pub const fn no_service() -> Self {
        Self::request(Service::NoService, 0, 0)
    }

    /// Read the value of `index`.
    pub const fn read(index: u16) -> Self {
        Self::request(Service::Read, index, 0)
    }

    /// Write `value` to `index`, non-volatile (EEPROM).
    pub const fn write(index: u16, value: u32) -> Self {
        Self::request(Service::Write, index, value)
    }

    /// Write `value` to `index`, volatile (RAM).
    pub const fn write_volatile(index: u16, value: u32) -> Self {
        Self::request(Service::WriteVolatile, index, value)
    }

    /// Read the minimum of `index`.
    pub const fn read_minimum(index: u16) -> Self {
        Self::request(Service::ReadMinimum, index, 0)
    }

    /// Read the maximum of `index`.
    pub const fn read_maximum(index: u16) -> Self {
        Self::request(Service::ReadMaximum, index, 0)
    }

    /// Read the default of `index`.
    pub const fn read_default(index: u16) -> Self {
        Self::request(Service::ReadDefault, index, 0)
    }

    /// Read the scaling of `index`.
    pub const fn read_scale(index: u16) -> Self {
        Self::request(Service::ReadScale, index, 0)
    }

    /// Read the attributes of `index`.
    pub const fn read_attribute(index: u16) -> Self {
        Self::request(Service::ReadAttribute, index, 0)
    }

    /// The same channel with subindex `subindex`.
    #[must_use]
    pub const fn with_subindex(mut self, subindex: u8) -> Self {
        self.subindex = subindex;
        self
    }

    /// The same channel with the handshake bit `on`.
    #[must_use]
    pub const fn with_handshake(mut self, on: bool) -> Self {
        self.management = self.management.with_handshake(on);
        self
    }

    /// The service, `None` for an undefined code.
    pub const fn service(&self) -> Option<Service> {
        self.management.service()
    }

    /// The 8 bytes on the wire.
    pub const fn to_bytes(&self) -> [u8; 8] {
        let [ih, il] = self.index.to_be_bytes();
        let [d0, d1, d2, d3] = self.data.to_be_bytes();
        [self.management.raw(), self.subindex, ih, il, d0, d1, d2, d3]
    }

    /// The channel of the 8 bytes `b`.
    pub const fn from_bytes(b: [u8; 8]) -> Self {
        let [m, sub, ih, il, d0, d1, d2, d3] = b;
        Self {
            management: Management::from_raw(m),
            subindex: sub,
            index: u16::from_be_bytes([ih, il]),
            data: u32::from_be_bytes([d0, d1, d2, d3]),
        }
    }

    /// The answer's outcome: the data, or the return code if the status bit is set.
    pub const fn result(&self) -> Result<u32, ReturnCode> {
        if self.management.is_error() {
            Err(ReturnCode::from_data(self.data))
        } else {
            Ok(self.data)
        }
    }

    /// The answer of a Read Scale service.
    pub const fn scale(&self) -> Result<ScaleInfo, ReturnCode> {
        match self.result() {
            Ok(d) => Ok(ScaleInfo::from_data(d)),
            Err(e) => Err(e),
        }
    }

    /// The answer of a Read Attribute service.
    pub const fn attribute(&self) -> Result<AttributeInfo, ReturnCode> {
        match self.result() {
            Ok(d) => Ok(AttributeInfo::from_data(d)),
            Err(e) => Err(e),
        }
    }

    /// The answer to this request (slave side): same management byte (service, length,
    /// handshake echoed), subindex and index; the status bit and data from `result`.
    pub const fn answer(&self, result: Result<u32, ReturnCode>) -> Self {
        let (error, data) = match result {
            Ok(d) => (false, d),
            Err(rc) => (true, rc.to_data()),
        };
        Self {
            management: self.management.with_error(error),
            subindex: self.subindex,
            index: self.index,
            data,
        }
    }

    /// Whether `answer` answers this request: same service code, subindex and index (the
    /// handshake and status bits are not compared).
    pub const fn is_answered_by(&self, answer: &ParamChannel) -> bool {
        self.management.service_code() == answer.management.service_code()
            && self.subindex == answer.subindex
            && self.index == answer.index
    }
}

/// Error class of a [`ReturnCode`] (EN 50170, manual ch. 6.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
#[repr(u8)]
pub enum ErrorClass {
    /// 1: vfd-state, status error of the virtual field device.
    VfdState = 1,
    /// 2: application-reference, error in the application program.
    ApplicationReference = 2,
    /// 3: definition error.
    Definition = 3,
    /// 4: resource error.
    Resource = 4,
    /// 5: service, error executing the service.
    Service = 5,
    /// 6: access error.
    Access = 6,
    /// 7: ov, error in the object dictionary.
    ObjectDictionary = 7,
    /// 8: other; the drive's own return codes, detailed by the additional code.
    Other = 8,
}

impl ErrorClass {
    /// The class of byte `class`, `None` for undefined values.
    pub const fn from_u8(class: u8) -> Option<Self> {
        Some(match class {
            1 => Self::VfdState,
            2 => Self::ApplicationReference,
            3 => Self::Definition,
            4 => Self::Resource,
            5 => Self::Service,
            6 => Self::Access,
            7 => Self::ObjectDictionary,
            8 => Self::Other,
            _ => return None,
        })
    }
}

/// A drive's negative answer to a parameter service: bytes 4–7 of the parameter channel when
/// the status bit is set (byte 4 error class, byte 5 error code, bytes 6–7 additional code).
///
/// The drive's own codes use error class 8, error code 0 and an additional code; the named
/// constants are the complete list of the MOVIDRIVE manual, ch. 6.2, plus its two special cases.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ReturnCode {
    /// Byte 4.
    pub error_class: u8,
    /// Byte 5.
    pub error_code: u8,
    /// Bytes 6–7.
    pub additional_code: u16,
}

impl ReturnCode {
    /// A return code from its three parts.
    pub const fn new(error_class: u8, error_code: u8, additional_code: u16) -> Self {
        Self {
            error_class,
            error_code,
            additional_code,
        }
    }

    /// A drive-specific code: error class 8 ("other"), error code 0, `additional_code`.
    pub const fn drive(additional_code: u16) -> Self {
        Self::new(8, 0, additional_code)
    }

    /// 8/0/0x0000: no error.
    pub const NO_ERROR: Self = Self::drive(0x0000);
    /// 8/0/0x0010: illegal parameter index.
    pub const ILLEGAL_INDEX: Self = Self::drive(0x0010);
    /// 8/0/0x0011: function/parameter not implemented.
    pub const NOT_IMPLEMENTED: Self = Self::drive(0x0011);
    /// 8/0/0x0012: read access only.
    pub const READ_ONLY: Self = Self::drive(0x0012);
    /// 8/0/0x0013: parameter lock active.
    pub const PARAMETER_LOCK: Self = Self::drive(0x0013);
    /// 8/0/0x0014: factory setting active.
    pub const FACTORY_SETTING_ACTIVE: Self = Self::drive(0x0014);
    /// 8/0/0x0015: value too large.
    pub const VALUE_TOO_LARGE: Self = Self::drive(0x0015);
    /// 8/0/0x0016: value too small.
    pub const VALUE_TOO_SMALL: Self = Self::drive(0x0016);
    /// 8/0/0x0017: the option card this function/parameter needs is missing.
    pub const OPTION_CARD_MISSING: Self = Self::drive(0x0017);
    /// 8/0/0x0018: error in system software.
    pub const SYSTEM_SOFTWARE_ERROR: Self = Self::drive(0x0018);
    /// 8/0/0x0019: parameter access only via the RS-485 process interface on X13.
    pub const ONLY_VIA_RS485_PROCESS_INTERFACE: Self = Self::drive(0x0019);
    /// 8/0/0x001A: parameter access only via the RS-485 diagnostic interface.
    pub const ONLY_VIA_RS485_DIAGNOSTIC_INTERFACE: Self = Self::drive(0x001A);
    /// 8/0/0x001B: parameter is access-protected.
    pub const ACCESS_PROTECTED: Self = Self::drive(0x001B);
    /// 8/0/0x001C: controller inhibit required.
    pub const CONTROLLER_INHIBIT_REQUIRED: Self = Self::drive(0x001C);
    /// 8/0/0x001D: invalid value for the parameter.
    pub const INVALID_VALUE: Self = Self::drive(0x001D);
    /// 8/0/0x001E: factory setting was activated.
    pub const FACTORY_SETTING_ACTIVATED: Self = Self::drive(0x001E);
    /// 8/0/0x001F: parameter was not stored in EEPROM.
    pub const NOT_STORED_IN_EEPROM: Self = Self::drive(0x001F);
    /// 8/0/0x0020: parameter cannot be changed with the output stage enabled.
    pub const OUTPUT_STAGE_ENABLED: Self = Self::drive(0x0020);
    /// 6/2/0x0000: internal communication error between option card and drive ("hardware
    /// fault"); repeat the service.
    pub const INTERNAL_COMMUNICATION_ERROR: Self = Self::new(6, 2, 0x0000);
    /// 5/5/0x0000: wrong coding in the management byte ("illegal value", ch. 5.2 special case).
    pub const ILLEGAL_SERVICE_CODING: Self = Self::new(5, 5, 0x0000);

    /// Decode from the 4 data bytes.
    pub const fn from_data(data: u32) -> Self {
        let [class, code, hi, lo] = data.to_be_bytes();
        Self::new(class, code, u16::from_be_bytes([hi, lo]))
    }

    /// The four bytes 4–7 of the parameter channel: class, code, additional high, low.
    pub const fn to_bytes(self) -> [u8; 4] {
        let [hi, lo] = self.additional_code.to_be_bytes();
        [self.error_class, self.error_code, hi, lo]
    }

    /// Encode into the 4 data bytes.
    pub const fn to_data(self) -> u32 {
        let [hi, lo] = self.additional_code.to_be_bytes();
        u32::from_be_bytes([self.error_class, self.error_code, hi, lo])
    }

    /// The error class, if defined.
    pub const fn class(self) -> Option<ErrorClass> {
        ErrorClass::from_u8(self.error_class)
    }

    /// The manual's entry for this code (German and English meaning, section, whether to
    /// repeat the service) from the generated table ([`return_code_info`]); `None` if the
    /// manual does not list the combination.
    pub fn meaning(self) -> Option<&'static ReturnCodeInfo> {
        return_code_info(self.error_class, self.error_code, self.additional_code)
    }

    /// This code decoded against the manual's tables; its `Display` is an English description
    /// for known and unknown codes alike.
    pub fn describe(self) -> DecodedReturnCode {
        describe_return_code(self.error_class, self.error_code, self.additional_code)
    }
}

impl fmt::Display for ReturnCode {
    /// The manual's English meaning with the three numbers, e.g. `value for parameter too
    /// large (error class 8, error code 0, additional code 0x0015)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.describe().fmt(f)
    }
}

impl core::error::Error for ReturnCode {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn services_have_english_names() {
        let names: Vec<String> = (0..=8)
            .map(|c| Service::from_code(c).unwrap().to_string())
            .collect();
        assert_eq!(
            names,
            [
                "no service",
                "read",
                "write",
                "write volatile",
                "read minimum",
                "read maximum",
                "read default",
                "read scale",
                "read attribute"
            ]
        );
    }

    #[test]
    fn management_bits() {
        // Read, 4 bytes: 0011 0001.
        let m = Management::new(Service::Read, DataLength::Four);
        assert_eq!(m.raw(), 0x31);
        assert_eq!(m.with_handshake(true).raw(), 0x71);
        assert_eq!(m.with_error(true).raw(), 0xB1);
        assert_eq!(m.with_handshake(true).with_handshake(false), m);
        assert_eq!(Management::from_raw(0x0F).service(), None);
        for code in 0..=8 {
            let s = Service::from_code(code).unwrap();
            assert_eq!(s.code(), code);
            let m = Management::new(s, DataLength::One);
            assert_eq!(m.service(), Some(s));
            assert_eq!(m.data_length().bytes(), 1);
        }
        for (bits, len) in [(0u8, 1u8), (1, 2), (2, 3), (3, 4)] {
            assert_eq!(Management::from_raw(bits << 4).data_length().bytes(), len);
        }
        assert!(Service::Write.is_write() && !Service::Read.is_write());
    }

    #[test]
    fn constructors_use_service_codes() {
        let cases = [
            (ParamChannel::no_service(), 0x30),
            (ParamChannel::read(1), 0x31),
            (ParamChannel::write(1, 2), 0x32),
            (ParamChannel::write_volatile(1, 2), 0x33),
            (ParamChannel::read_minimum(1), 0x34),
            (ParamChannel::read_maximum(1), 0x35),
            (ParamChannel::read_default(1), 0x36),
            (ParamChannel::read_scale(1), 0x37),
            (ParamChannel::read_attribute(1), 0x38),
        ];
        for (p, m) in cases {
            assert_eq!(p.management.raw(), m);
        }
        assert_eq!(ParamChannel::read(1).with_subindex(3).to_bytes()[1], 3);
    }

    #[test]
    fn scale_and_attribute_answers() {
        // P131 ramp t11 down CW: size index 4 (time, s), conversion index -3 (milli).
        let p = ParamChannel::from_bytes([0x37, 0, 0x21, 0x17, 0x00, 0x00, 0x04, 0xFD]);
        let s = p.scale().unwrap();
        assert_eq!(
            s,
            ScaleInfo {
                size_index: 4,
                conversion_index: -3
            }
        );
        assert!(s.has_size_index());
        assert_eq!(ScaleInfo::from_data(s.to_data()), s);
        assert!(!ScaleInfo::from_data(0x0000_FF00).has_size_index());

        let p = ParamChannel::from_bytes([0x38, 0, 0x21, 0x00, 0x21, 0x01, 0x00, 0x13]);
        let a = p.attribute().unwrap();
        assert_eq!(
            a,
            AttributeInfo {
                next_index: 0x2101,
                attributes: 0x0013
            }
        );
        assert_eq!(AttributeInfo::from_data(a.to_data()), a);
    }

    #[test]
    fn error_answer() {
        // Status bit set, class 8, code 0, additional 0x0010 = illegal parameter index.
        let p = ParamChannel::from_bytes([0xB1, 0, 0x27, 0x10, 0x08, 0x00, 0x00, 0x10]);
        assert_eq!(p.result(), Err(ReturnCode::ILLEGAL_INDEX));
        assert_eq!(p.scale(), Err(ReturnCode::ILLEGAL_INDEX));
        assert_eq!(p.attribute(), Err(ReturnCode::ILLEGAL_INDEX));
        let req = ParamChannel::read(0x2710).with_handshake(true);
        let ans = req.answer(Err(ReturnCode::ILLEGAL_INDEX));
        assert!(ans.management.handshake());
        assert!(req.is_answered_by(&ans));
        assert!(!req.is_answered_by(&ParamChannel::read(0x2711)));
    }

    #[test]
    fn return_code_round_trip_and_names() {
        let rc = ReturnCode::from_data(0x0800_0015);
        assert_eq!(rc, ReturnCode::VALUE_TOO_LARGE);
        assert_eq!(rc.to_data(), 0x0800_0015);
        assert_eq!(rc.class(), Some(ErrorClass::Other));
        assert_eq!(
            rc.meaning().map(|m| m.en),
            Some("value for parameter too large")
        );
        assert!(ReturnCode::new(9, 9, 9).meaning().is_none());
        assert_eq!(ReturnCode::new(9, 0, 0).class(), None);
        for c in 0x10..=0x20u16 {
            assert!(ReturnCode::drive(c).meaning().is_some(), "{c:#x}");
        }
        assert_eq!(
            ReturnCode::INTERNAL_COMMUNICATION_ERROR.class(),
            Some(ErrorClass::Access)
        );
        assert_eq!(
            ReturnCode::ILLEGAL_SERVICE_CODING.class(),
            Some(ErrorClass::Service)
        );
    }

    #[test]
    fn every_named_code_has_a_generated_meaning() {
        let named = [
            ReturnCode::NO_ERROR,
            ReturnCode::INTERNAL_COMMUNICATION_ERROR,
            ReturnCode::ILLEGAL_SERVICE_CODING,
        ];
        let drive = (0x10..=0x20u16).map(ReturnCode::drive);
        for rc in named.into_iter().chain(drive) {
            let m = rc.meaning();
            assert!(m.is_some(), "{rc:?} missing in drive_profile::sew");
            if let Some(m) = m {
                assert_eq!(
                    (m.class, m.code, m.additional),
                    (rc.error_class, rc.error_code, rc.additional_code)
                );
            }
        }
        assert_eq!(
            ReturnCode::VALUE_TOO_LARGE.meaning().map(|m| m.en),
            Some("value for parameter too large")
        );
        assert!(
            ReturnCode::INTERNAL_COMMUNICATION_ERROR
                .meaning()
                .is_some_and(|m| m.retry)
        );
        assert_eq!(ReturnCode::new(9, 9, 9).meaning(), None);
    }
}
