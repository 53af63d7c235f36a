//! The parameter services: the table's checks in the store, then the MOVIDRIVE specifics, with
//! the answers in the shared parameter-channel types.

use drive_profile::sew::{self, ParamChannel, ReturnCode, Service, index};
use drive_profile::{Access, ParamMeta};

use super::Movidrive;
use crate::error::SimError;
use crate::state::DriveState;
use crate::store::Persistence;
use drive_core::Instant;

/// The access-attribute byte of a Read Attribute answer (drivebus convention; the manual says
/// the coding is device specific): bit 0 `S`, bit 1 `RO`, bit 2 `R`, bit 3 `RW`, bit 4 `N`,
/// bits 5–7 zero. These are the bits of [`Access`] for the SEW flags.
pub const fn attribute_byte(access: Access) -> u8 {
    access.bits() & 0x1f
}

/// The return code the MOVIDRIVE answers for a refusal of the simulated drive.
pub fn return_code(error: SimError) -> ReturnCode {
    match error {
        SimError::UnknownIndex { .. } | SimError::UnknownSubIndex { .. } => {
            ReturnCode::ILLEGAL_INDEX
        }
        SimError::ReadOnly { .. } => ReturnCode::READ_ONLY,
        SimError::Locked { .. } => ReturnCode::PARAMETER_LOCK,
        SimError::TooLarge { .. } => ReturnCode::VALUE_TOO_LARGE,
        SimError::TooSmall { .. } => ReturnCode::VALUE_TOO_SMALL,
        SimError::ValueNotAllowed { .. } => ReturnCode::INVALID_VALUE,
        SimError::NeedsInhibit { .. } => ReturnCode::CONTROLLER_INHIBIT_REQUIRED,
        SimError::NotInOperation { .. } => ReturnCode::OUTPUT_STAGE_ENABLED,
        SimError::EepromWornOut { .. } => ReturnCode::NOT_STORED_IN_EEPROM,
        _ => ReturnCode::SYSTEM_SOFTWARE_ERROR,
    }
}

impl Movidrive {
    /// Execute a parameter service on `index` with `data` (ignored by the read services) at
    /// `now`; the answer's 32-bit data or a return code.
    ///
    /// Values are exchanged as 32-bit two's complement; parameters whose range starts at 0 or
    /// above read `data` as unsigned. Values on a range with steps are rounded onto the step
    /// grid (e.g. P130 1005 → 1000).
    pub fn param_service(
        &mut self,
        service: Service,
        index: u16,
        data: u32,
        now: Instant,
    ) -> Result<u32, ReturnCode> {
        self.update(now);
        if service == Service::NoService {
            return Ok(0);
        }
        let store = self.drive.store();
        let meta = store.meta(index, 0).map_err(return_code)?;
        let rc = return_code;
        match service {
            Service::NoService => Ok(0),
            Service::Read => store.read(index, 0).map(to_data).map_err(rc),
            Service::Write => self.write(index, data, Persistence::NonVolatile, now),
            Service::WriteVolatile => self.write(index, data, Persistence::Volatile, now),
            Service::ReadMinimum => store
                .min_raw(index, 0)
                .map(|m| m.map_or(i32::MIN as u32, to_data))
                .map_err(rc),
            Service::ReadMaximum => store
                .max_raw(index, 0)
                .map(|m| m.map_or(i32::MAX as u32, to_data))
                .map_err(rc),
            Service::ReadDefault => store.default_raw(index, 0).map(to_data).map_err(rc),
            Service::ReadScale => {
                let (size, conversion) =
                    sew::by_index(index).map_or((0, 0), |p| (p.size_index, p.conversion_index));
                let conversion = i8::try_from(conversion).map_or(0xff, |c| c as u8);
                Ok(u32::from(size) << 8 | u32::from(conversion))
            }
            Service::ReadAttribute => {
                let next = store.keys().map(|k| k.0).find(|&i| i > index).unwrap_or(0);
                Ok(u32::from(next) << 16 | u32::from(attribute_byte(meta.access())))
            }
            _ => Err(ReturnCode::ILLEGAL_SERVICE_CODING),
        }
    }

    /// The parameter service of the channel `request` (management byte, index, data) at `now`:
    /// the answer's data or the return code. "No service" answers 0, an undefined service
    /// code [`ReturnCode::ILLEGAL_SERVICE_CODING`] (5/5/0, "wrong coding of the management
    /// byte"); the subindex is ignored (MOVIDRIVE has none).
    ///
    /// ```
    /// use drive_profile::sew::{ParamChannel, ReturnCode};
    /// use drive_sim::Instant;
    /// use drive_sim::movidrive::Movidrive;
    ///
    /// let mut drive = Movidrive::new(1);
    /// let t = Instant::ZERO;
    /// assert_eq!(drive.param(&ParamChannel::write_volatile(8470, 1500), t), Ok(0));
    /// assert_eq!(drive.param(&ParamChannel::read(8470), t), Ok(1500));
    /// assert_eq!(drive.param(&ParamChannel::write(8318, 1), t), Err(ReturnCode::READ_ONLY));
    /// ```
    pub fn param(&mut self, request: &ParamChannel, now: Instant) -> Result<u32, ReturnCode> {
        match request.service() {
            Some(service) => self.param_service(service, request.index, request.data, now),
            None => {
                self.update(now);
                Err(ReturnCode::ILLEGAL_SERVICE_CODING)
            }
        }
    }

    /// Non-volatile writes `index` has received (EEPROM wear); `None` for an unknown index.
    pub fn nv_writes(&self, index: u16) -> Option<u64> {
        self.drive.store().nv_writes(index, 0).ok()
    }

    /// Time of the last non-volatile write of `index`; `None` for an unknown index or none yet.
    pub fn last_nv_write(&self, index: u16) -> Option<Instant> {
        self.drive.store().last_nv_write(index, 0).ok().flatten()
    }

    /// A write service: table checks in the store, then the MOVIDRIVE specifics.
    pub(super) fn write(
        &mut self,
        index: u16,
        data: u32,
        persistence: Persistence,
        now: Instant,
    ) -> Result<u32, ReturnCode> {
        let store = self.drive.store();
        let signed = store
            .min_raw(index, 0)
            .ok()
            .flatten()
            .is_none_or(|min| min < 0);
        let mut raw = if signed {
            i64::from(data as i32)
        } else {
            i64::from(data)
        };
        let row = sew::all_by_index(index).find(|p| p.index == index);
        if let Some(p) = row.filter(|p| !p.ranges.is_empty())
            && p.raw_range().is_some_and(|(lo, hi)| lo <= raw && raw <= hi)
        {
            match p.snap(raw) {
                Some(snapped) => raw = snapped,
                // In a gap between range segments: invalid, once access is granted.
                None => {
                    return Err(self
                        .access_refusal(index)
                        .unwrap_or(ReturnCode::INVALID_VALUE));
                }
            }
        }
        let enumerated = row.is_some_and(|p| p.ranges.is_empty() && !p.values.is_empty());
        let result = self
            .drive
            .store_mut()
            .write(index, 0, raw, persistence, now);
        if let Err(e) = result {
            return Err(match e {
                // An enumeration's range is its value list: outside it is an invalid value.
                SimError::TooLarge { .. } | SimError::TooSmall { .. } if enumerated => {
                    ReturnCode::INVALID_VALUE
                }
                SimError::NeedsInhibit { .. } => self.inhibit_refusal(),
                other => return_code(other),
            });
        }
        match index {
            index::FACTORY_SETTING if raw == 1 => self.factory_setting(persistence, now),
            index::RESET_STATISTICS if raw != 0 => {
                if raw == 1 {
                    let store = self.drive.store_mut();
                    for i in index::FAULT_T0..=index::FAULT_T0 + 4 {
                        let _ = store.set_internal(i, 0);
                    }
                }
                let _ = self
                    .drive
                    .store_mut()
                    .set_internal(index::RESET_STATISTICS, 0);
            }
            _ => {}
        }
        self.update(now);
        Ok(0)
    }

    /// The answer to a write of an `R` parameter without controller inhibit: `0x0020` while the
    /// output stage is still on without enable (stop / rapid stop ramp running), else `0x001C`.
    pub(super) fn inhibit_refusal(&self) -> ReturnCode {
        if self.drive.state() != DriveState::Enabled && self.output_stage_enabled() {
            ReturnCode::OUTPUT_STAGE_ENABLED
        } else {
            ReturnCode::CONTROLLER_INHIBIT_REQUIRED
        }
    }

    /// The store's access checks (read-only, lock, `R`) without a value, in the store's order.
    pub(super) fn access_refusal(&self, index: u16) -> Option<ReturnCode> {
        let store = self.drive.store();
        let access = match store.meta(index, 0) {
            Ok(meta) => meta.access(),
            Err(e) => return Some(return_code(e)),
        };
        if !access.is_writable() {
            Some(ReturnCode::READ_ONLY)
        } else if store.is_locked() && !access.contains(Access::STORE_LOCKED) {
            Some(ReturnCode::PARAMETER_LOCK)
        } else if access.contains(Access::NEEDS_INHIBIT) && !store.condition().controller_inhibited
        {
            Some(self.inhibit_refusal())
        } else {
            None
        }
    }

    /// P802 = 1: every writable parameter back to its default, except the RS-485 address and
    /// group address (simulator choice, so the master keeps its connection); P802 returns to 0.
    pub(super) fn factory_setting(&mut self, persistence: Persistence, now: Instant) {
        let address = self.value(index::RS485_ADDRESS);
        let group = self.value(index::RS485_GROUP_ADDRESS);
        let store = self.drive.store_mut();
        store.reset_to_defaults(persistence, now);
        let _ = store.set_internal(index::RS485_ADDRESS, address);
        let _ = store.set_internal(index::RS485_GROUP_ADDRESS, group);
        let _ = store.set_internal(index::FACTORY_SETTING, 0);
    }
}

/// A raw value as 32-bit data (two's complement; values beyond 32 bits are truncated).
fn to_data(raw: i64) -> u32 {
    raw as u32
}
