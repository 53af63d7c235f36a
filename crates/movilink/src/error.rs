//! Error types.
//!
//! Transport errors ([`DecodeError`], [`RejectReason`], timeouts in the master's events) are
//! separate from device errors: a drive's negative answer is a [`ReturnCode`].

/// Why a byte slice is not a valid telegram.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum DecodeError {
    /// Fewer bytes than the telegram needs (`needed` is known once the PDU type is read).
    #[error("telegram truncated: {needed} bytes needed, {available} available")]
    Truncated {
        /// Bytes needed for the header or the whole telegram.
        needed: usize,
        /// Bytes given.
        available: usize,
    },
    /// The first byte is neither SD1 (0x02) nor SD2 (0x1D).
    #[error("bad start character {byte:#04x}")]
    BadStartCharacter {
        /// The byte found.
        byte: u8,
    },
    /// The address byte is in the unused range 200–252.
    #[error("invalid address {address}")]
    InvalidAddress {
        /// The address byte.
        address: u8,
    },
    /// The PDU type byte is not one of the 14 standard types.
    #[error("unknown pdu type {pdu_type:#04x}")]
    UnknownPduType {
        /// The type byte.
        pdu_type: u8,
    },
    /// The block check character does not match.
    #[error("bad block check character: expected {expected:#04x}, got {got:#04x}")]
    BadChecksum {
        /// XOR of all bytes before the BCC.
        expected: u8,
        /// The BCC received.
        got: u8,
    },
}

/// Why a telegram could not be encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum EncodeError {
    /// The output buffer is too small.
    #[error("output buffer too small: {needed} bytes needed, {available} available")]
    BufferTooSmall {
        /// Bytes the telegram needs.
        needed: usize,
        /// Bytes available.
        available: usize,
    },
}

/// An error the UART reported for one received character.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum CharError {
    /// Even parity violated.
    #[error("parity error")]
    Parity,
    /// Stop bit missing.
    #[error("framing error")]
    Framing,
    /// The UART lost characters before this one.
    #[error("receiver overrun")]
    Overrun,
}

/// Why a receiver or state machine dropped received characters (manual ch. 4.2, "Verarbeitung
/// der Request-/Response-Telegramme"). Rejected telegrams are never answered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum RejectReason {
    /// A character of the telegram had a parity error.
    #[error("parity error")]
    Parity,
    /// A character of the telegram had a framing error.
    #[error("framing error")]
    Framing,
    /// The UART lost characters.
    #[error("receiver overrun")]
    Overrun,
    /// The line was idle for a start pause or longer inside a telegram.
    #[error("inter-character gap exceeded after {received} bytes")]
    InterCharacterGap {
        /// Bytes received before the gap.
        received: u8,
    },
    /// The address is not one this side accepts.
    #[error("wrong address {address}")]
    WrongAddress {
        /// The address byte.
        address: u8,
    },
    /// Unknown PDU type byte.
    #[error("unknown pdu type {pdu_type:#04x}")]
    UnknownPduType {
        /// The type byte.
        pdu_type: u8,
    },
    /// Block check character mismatch.
    #[error("bad block check character: expected {expected:#04x}, got {got:#04x}")]
    BadBcc {
        /// XOR of the bytes before the BCC.
        expected: u8,
        /// The BCC received.
        got: u8,
    },
    /// A character followed the telegram's last character (its BCC) without an idle gap: the
    /// telegram on the wire is longer than its PDU type says (e.g. noise inserted a character,
    /// which shifts the real BCC out of the telegram).
    #[error("character {byte:#04x} after the end of the telegram without an idle gap")]
    TrailingCharacter {
        /// The first character after the telegram.
        byte: u8,
    },
    /// After a start pause came a character that starts no telegram (neither SD1 nor SD2).
    #[error("bad start character {byte:#04x}")]
    BadStartCharacter {
        /// The character.
        byte: u8,
    },
    /// Master: the response has another PDU type than the request.
    #[error("response pdu type {got:#04x} does not match request type {expected:#04x}")]
    PduTypeMismatch {
        /// The request's type byte.
        expected: u8,
        /// The response's type byte.
        got: u8,
    },
    /// Master: the response's parameter channel answers another service or index.
    #[error("parameter channel of the response does not answer the request")]
    ParamMismatch,
}

impl From<CharError> for RejectReason {
    fn from(e: CharError) -> Self {
        match e {
            CharError::Parity => Self::Parity,
            CharError::Framing => Self::Framing,
            CharError::Overrun => Self::Overrun,
        }
    }
}

impl From<DecodeError> for RejectReason {
    fn from(e: DecodeError) -> Self {
        match e {
            // The receiver only decodes complete telegrams; a truncated one is a gap.
            DecodeError::Truncated { available, .. } => Self::InterCharacterGap {
                received: u8::try_from(available).unwrap_or(u8::MAX),
            },
            DecodeError::BadStartCharacter { byte } => Self::BadStartCharacter { byte },
            DecodeError::InvalidAddress { address } => Self::WrongAddress { address },
            DecodeError::UnknownPduType { pdu_type } => Self::UnknownPduType { pdu_type },
            DecodeError::BadChecksum { expected, got } => Self::BadBcc { expected, got },
        }
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
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[error(
    "drive return code: error class {error_class}, error code {error_code}, additional code {additional_code:#06x}"
)]
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
    /// repeat the service) from the generated table of `drive_profile::sew`; `None` if the
    /// manual does not list the combination.
    pub fn meaning(self) -> Option<&'static drive_profile::sew::ReturnCode> {
        drive_profile::sew::return_code(self.error_class, self.error_code, self.additional_code)
    }

    /// This code decoded against the manual's tables; its `Display` is an English description
    /// for known and unknown codes alike.
    pub fn describe(self) -> drive_profile::sew::DecodedReturnCode {
        drive_profile::sew::describe_return_code(
            self.error_class,
            self.error_code,
            self.additional_code,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
