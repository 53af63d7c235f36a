//! The objects and channel contents CTT2 carries (BU 0255 section 4.3): the ID object and the
//! diagnosis object of the standard read, and the USS process data ([`PzdOut`], [`PzdIn`]) and
//! parameter channel ([`Pkw`]) inside the data of the NORD messages, with the drive address
//! where the channel has one.
//!
//! A read shorter than an object returns only its first bytes (section 4.3.5), so
//! [`IdObject::decode`] and [`DiagnosisObject::decode`] take any prefix and fill only the fields
//! whose bytes are all there.

use core::fmt;

use super::message::{Channel, DRIVE_ADDRESS, Data, MAX_DATA};
use crate::uss::pkw::{PKW_LEN, Pkw};
use crate::uss::pzd::{PzdError, PzdIn, PzdOut};

/// Why an object or a channel's data cannot be read or built.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum ObjectError {
    /// More bytes than the object has.
    #[error("{got} bytes, but the object has {max}")]
    TooLong {
        /// The object's length.
        max: u8,
        /// Bytes given (saturated at 255).
        got: u8,
    },
    /// PKW data asked of the PZD channel, or PZD data of a PKW channel.
    #[error("index {0} is not the channel asked for")]
    WrongChannel(u8),
    /// The data do not start with the drive address 1.
    #[error("drive address {0} (the drive is always address 1)")]
    BadAddress(u8),
    /// No byte at all where at least the address was expected.
    #[error("channel data without the drive address")]
    MissingAddress,
    /// Parameter channel data that are not complete (8 bytes after the address, if any).
    #[error("parameter channel of {0} bytes (must be complete: 8 bytes)")]
    IncompletePkw(u8),
    /// Process data of a length that is no whole number of words.
    #[error(transparent)]
    Pzd(#[from] PzdError),
}

/// Bytes `i..i + N` of `b` if all are there.
fn field<const N: usize>(b: &[u8], i: usize) -> Option<[u8; N]> {
    b.get(i..i + N).and_then(|s| s.first_chunk::<N>()).copied()
}

/// The ID object (standard read, index 0, 14 bytes, section 4.3.1). Each field is `None` when
/// a shorter read did not return all of its bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct IdObject {
    /// Bytes 1–2: manufacturer ID (high byte first; the manual's example: 1, 137 = 0189h).
    pub manufacturer_id: Option<u16>,
    /// Bytes 3–4: device ID.
    pub device_id: Option<u16>,
    /// Byte 5: input/output configuration of the cyclic data.
    pub io_config: Option<u8>,
    /// Byte 6: AS-i mode.
    pub asi_mode: Option<u8>,
    /// Byte 7: firmware version of the AS-Interface.
    pub asi_firmware: Option<u8>,
    /// Byte 8: firmware version of the field distributor (the drive).
    pub firmware_version: Option<u8>,
    /// Byte 9: firmware revision of the field distributor.
    pub firmware_revision: Option<u8>,
    /// Bytes 10–11: power of the field distributor.
    pub power: Option<u16>,
    /// Byte 12: voltage range of the field distributor.
    pub voltage_range: Option<u8>,
    /// Bytes 13–14: configuration level of the field distributor.
    pub configuration_level: Option<u16>,
}

/// Length of the ID object.
pub const ID_OBJECT_LEN: usize = 14;

/// Length of the diagnosis object.
pub const DIAGNOSIS_OBJECT_LEN: usize = 3;

impl IdObject {
    /// A complete ID object from its 14 bytes.
    pub fn from_bytes(b: &[u8; ID_OBJECT_LEN]) -> IdObject {
        let [m0, m1, d0, d1, io, mode, asi, fv, fr, p0, p1, v, c0, c1] = *b;
        IdObject {
            manufacturer_id: Some(u16::from_be_bytes([m0, m1])),
            device_id: Some(u16::from_be_bytes([d0, d1])),
            io_config: Some(io),
            asi_mode: Some(mode),
            asi_firmware: Some(asi),
            firmware_version: Some(fv),
            firmware_revision: Some(fr),
            power: Some(u16::from_be_bytes([p0, p1])),
            voltage_range: Some(v),
            configuration_level: Some(u16::from_be_bytes([c0, c1])),
        }
    }

    /// The fields of the first `bytes.len()` bytes of the object (a shorter read); a field
    /// whose bytes are not all there stays `None`.
    pub fn decode(bytes: &[u8]) -> Result<IdObject, ObjectError> {
        if bytes.len() > ID_OBJECT_LEN {
            return Err(ObjectError::TooLong {
                max: ID_OBJECT_LEN as u8,
                got: bytes.len().min(255) as u8,
            });
        }
        let w = |i| field::<2>(bytes, i).map(u16::from_be_bytes);
        let b = |i| field::<1>(bytes, i).map(|[x]| x);
        Ok(IdObject {
            manufacturer_id: w(0),
            device_id: w(2),
            io_config: b(4),
            asi_mode: b(5),
            asi_firmware: b(6),
            firmware_version: b(7),
            firmware_revision: b(8),
            power: w(9),
            voltage_range: b(11),
            configuration_level: w(12),
        })
    }

    /// The 14 bytes, if every field is there.
    pub fn to_bytes(&self) -> Option<[u8; ID_OBJECT_LEN]> {
        let [m0, m1] = self.manufacturer_id?.to_be_bytes();
        let [d0, d1] = self.device_id?.to_be_bytes();
        let [p0, p1] = self.power?.to_be_bytes();
        let [c0, c1] = self.configuration_level?.to_be_bytes();
        Some([
            m0,
            m1,
            d0,
            d1,
            self.io_config?,
            self.asi_mode?,
            self.asi_firmware?,
            self.firmware_version?,
            self.firmware_revision?,
            p0,
            p1,
            self.voltage_range?,
            c0,
            c1,
        ])
    }

    /// The bytes of the fields that are there, up to the first one missing (the data of a
    /// standard read answer).
    pub fn to_data(&self) -> Data {
        let w = |v: Option<u16>| v.unwrap_or(0).to_be_bytes();
        let b = |v: Option<u8>| v.unwrap_or(0);
        let [m0, m1] = w(self.manufacturer_id);
        let [d0, d1] = w(self.device_id);
        let [p0, p1] = w(self.power);
        let [c0, c1] = w(self.configuration_level);
        let bytes = [
            m0,
            m1,
            d0,
            d1,
            b(self.io_config),
            b(self.asi_mode),
            b(self.asi_firmware),
            b(self.firmware_version),
            b(self.firmware_revision),
            p0,
            p1,
            b(self.voltage_range),
            c0,
            c1,
        ];
        let fields = [
            (2, self.manufacturer_id.is_some()),
            (2, self.device_id.is_some()),
            (1, self.io_config.is_some()),
            (1, self.asi_mode.is_some()),
            (1, self.asi_firmware.is_some()),
            (1, self.firmware_version.is_some()),
            (1, self.firmware_revision.is_some()),
            (2, self.power.is_some()),
            (1, self.voltage_range.is_some()),
            (2, self.configuration_level.is_some()),
        ];
        let n: usize = fields
            .iter()
            .take_while(|(_, present)| *present)
            .map(|(len, _)| len)
            .sum();
        Data::new(bytes.get(..n).unwrap_or(&[])).unwrap_or_default()
    }

    /// Whether every field is there.
    pub fn is_complete(&self) -> bool {
        self.to_bytes().is_some()
    }
}

/// Byte 1 of the diagnosis object.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DiagnosisCode {
    /// 0: no fault.
    NoFault,
    /// 255: fault.
    Fault,
    /// A value the manual does not define.
    Other(u8),
}

impl DiagnosisCode {
    /// The code from its byte.
    pub const fn from_byte(b: u8) -> DiagnosisCode {
        match b {
            0 => DiagnosisCode::NoFault,
            255 => DiagnosisCode::Fault,
            other => DiagnosisCode::Other(other),
        }
    }

    /// The byte.
    pub const fn byte(self) -> u8 {
        match self {
            DiagnosisCode::NoFault => 0,
            DiagnosisCode::Fault => 255,
            DiagnosisCode::Other(b) => b,
        }
    }
}

/// The diagnosis object (standard read, index 1, 3 bytes, section 4.3.1). Each field is
/// `None` when a shorter read did not return it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct DiagnosisObject {
    /// Byte 1: 0 no fault, 255 fault.
    pub code: Option<DiagnosisCode>,
    /// Byte 2: fault number of the field distributor (the drive).
    pub fault: Option<u8>,
    /// Byte 3: temperature of the microcontroller (the manual's example: 45; it gives no
    /// unit, °C is likely).
    pub temperature: Option<u8>,
}

impl DiagnosisObject {
    /// A complete diagnosis object.
    pub const fn new(code: DiagnosisCode, fault: u8, temperature: u8) -> DiagnosisObject {
        DiagnosisObject {
            code: Some(code),
            fault: Some(fault),
            temperature: Some(temperature),
        }
    }

    /// The fields of the first `bytes.len()` bytes of the object.
    pub fn decode(bytes: &[u8]) -> Result<DiagnosisObject, ObjectError> {
        if bytes.len() > DIAGNOSIS_OBJECT_LEN {
            return Err(ObjectError::TooLong {
                max: DIAGNOSIS_OBJECT_LEN as u8,
                got: bytes.len().min(255) as u8,
            });
        }
        Ok(DiagnosisObject {
            code: bytes.first().map(|b| DiagnosisCode::from_byte(*b)),
            fault: bytes.get(1).copied(),
            temperature: bytes.get(2).copied(),
        })
    }

    /// The bytes of the fields that are there, up to the first one missing.
    pub fn to_data(&self) -> Data {
        let mut out = [0u8; DIAGNOSIS_OBJECT_LEN];
        let mut n = 0;
        for (slot, v) in out.iter_mut().zip([
            self.code.map(DiagnosisCode::byte),
            self.fault,
            self.temperature,
        ]) {
            let Some(v) = v else { break };
            *slot = v;
            n += 1;
        }
        Data::new(out.get(..n).unwrap_or(&[])).unwrap_or_default()
    }
}

impl fmt::Display for DiagnosisObject {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.code {
            Some(DiagnosisCode::NoFault) => write!(f, "no fault")?,
            Some(DiagnosisCode::Fault) => write!(f, "fault")?,
            Some(DiagnosisCode::Other(b)) => write!(f, "diagnosis code {b}")?,
            None => write!(f, "diagnosis code not read")?,
        }
        if let Some(n) = self.fault {
            write!(f, ", fault number {n}")?;
        }
        if let Some(t) = self.temperature {
            write!(f, ", microcontroller at {t} °C")?;
        }
        Ok(())
    }
}

impl Data {
    /// The data of a parameter channel: the 8 PKW bytes, after the drive address on index 4.
    pub fn from_pkw(index: Channel, pkw: &Pkw) -> Result<Data, ObjectError> {
        let b = pkw.to_bytes();
        let mut out = [0u8; MAX_DATA];
        let n = match index {
            Channel::Pzd => return Err(ObjectError::WrongChannel(index.index())),
            Channel::Pkw => {
                if let Some(dst) = out.first_chunk_mut::<PKW_LEN>() {
                    *dst = b;
                }
                PKW_LEN
            }
            Channel::PkwWithAddress => {
                if let Some((first, rest)) = out.split_first_mut() {
                    *first = DRIVE_ADDRESS;
                    if let Some(dst) = rest.first_chunk_mut::<PKW_LEN>() {
                        *dst = b;
                    }
                }
                PKW_LEN + 1
            }
        };
        Ok(Data::from_array(out, n as u8))
    }

    /// The data of the PZD channel written: address 1, STW, setpoints.
    pub fn from_pzd_out(out: &PzdOut) -> Data {
        let mut b = [0u8; MAX_DATA];
        let (first, rest) = b.split_at_mut(1);
        first.copy_from_slice(&[DRIVE_ADDRESS]);
        let n = out.encode(rest).unwrap_or(0);
        Data::new(b.get(..1 + n).unwrap_or(&[])).unwrap_or_default()
    }

    /// The data of the PZD channel read: address 1, ZSW, actual values.
    pub fn from_pzd_in(pzd: &PzdIn) -> Data {
        let mut b = [0u8; MAX_DATA];
        let (first, rest) = b.split_at_mut(1);
        first.copy_from_slice(&[DRIVE_ADDRESS]);
        let n = pzd.encode(rest).unwrap_or(0);
        Data::new(b.get(..1 + n).unwrap_or(&[])).unwrap_or_default()
    }

    /// The bytes after the drive address of an addressed channel (checked to be 1), or all of
    /// them.
    #[inline]
    pub fn payload(&self, index: Channel) -> Result<&[u8], ObjectError> {
        let bytes = self.as_slice();
        if !index.has_address() {
            return Ok(bytes);
        }
        match bytes.split_first() {
            None => Err(ObjectError::MissingAddress),
            Some((&DRIVE_ADDRESS, rest)) => Ok(rest),
            Some((&other, _)) => Err(ObjectError::BadAddress(other)),
        }
    }

    /// The parameter channel in these data (index 4: after the address; 47: the data).
    pub fn to_pkw(&self, index: Channel) -> Result<Pkw, ObjectError> {
        if !index.is_pkw() {
            return Err(ObjectError::WrongChannel(index.index()));
        }
        let p = self.payload(index)?;
        match p.first_chunk::<PKW_LEN>() {
            Some(b) if p.len() == PKW_LEN => Ok(Pkw::from_array(b)),
            _ => Err(ObjectError::IncompletePkw(p.len() as u8)),
        }
    }

    /// The process data written (PZD channel: address, STW, 0–3 setpoints).
    pub fn to_pzd_out(&self) -> Result<PzdOut, ObjectError> {
        Ok(PzdOut::decode(self.payload(Channel::Pzd)?)?)
    }

    /// The process data read (PZD channel: address, ZSW, 0–3 actual values).
    #[inline]
    pub fn to_pzd_in(&self) -> Result<PzdIn, ObjectError> {
        Ok(PzdIn::decode(self.payload(Channel::Pzd)?)?)
    }
}
