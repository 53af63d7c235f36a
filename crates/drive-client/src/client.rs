//! The client of one drive: [`ParamClient`], what every family gives a front end (read and
//! write a parameter by its table entry, the link's own settings, what identifies the drive),
//! and [`ClientError`], a drive's refusal kept apart from a failing link.

pub use drive_core::LinkFault;
use drive_profile::{Family, Persistence};
use serde_json::{Map, Value};

use crate::target::Target;

/// Why a client call failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ClientError {
    /// The drive answered negatively: the drive is there.
    #[error("{}", .0.message)]
    Device(DeviceError),
    /// The line failed: no answer, garbled answers, the port is gone; the message says what
    /// to check.
    #[error("{0}")]
    Link(LinkError),
    /// The request was not made, nothing was sent: the client cannot build it (a parameter
    /// the client needs the table for and the table does not have, a width not known, a value
    /// past the width, an order the protocol cannot carry). The caller's to change; the
    /// drive and the line are as they were.
    #[error("{0}")]
    Request(String),
}

/// A failing link: what kind of failure, and for a person what to check.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct LinkError {
    /// What kind of failure, for a caller that acts on it (a gateway counts a drive that does
    /// not answer as timed out).
    pub fault: LinkFault,
    /// What failed and what to check, for a person.
    pub message: String,
}

impl LinkError {
    /// A link failure of this kind, said by `message`.
    pub fn new(fault: LinkFault, message: impl Into<String>) -> Self {
        LinkError {
            fault,
            message: message.into(),
        }
    }
}

impl ClientError {
    /// A link failure of this kind, said by `message`.
    pub fn link(fault: LinkFault, message: impl Into<String>) -> Self {
        ClientError::Link(LinkError::new(fault, message))
    }
}

/// A negative answer of the drive, sorted by what a tool does about it (each protocol maps its
/// own codes).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeviceError {
    /// What kind of refusal.
    pub kind: DeviceErrorKind,
    /// The drive's own code, as its protocol carries it.
    pub code: DeviceCode,
    /// The drive's answer, for a person (with the code).
    pub message: String,
}

/// The code a drive refused with, in its protocol's terms, for a caller that acts on a
/// particular one (the manuals' tables name them).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum DeviceCode {
    /// SEW (MOVILINK, SBus): the parameter channel's return code (error class, error code,
    /// additional code).
    Sew(drive_profile::sew::ReturnCode),
    /// NORD (USS, CTT2): the error number in PWE of a refused order (AK 7).
    Nord(u16),
    /// Bonfiglioli (Modbus): the exception code and, where the drive was asked for it, its
    /// VABus error.
    Modbus {
        /// The Modbus exception code (1–4).
        exception: u8,
        /// The drive's VABus error code.
        vabus: Option<u16>,
    },
    /// No code: a refusal a front end or a test made up.
    None,
}

/// What a negative answer means for the tool.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DeviceErrorKind {
    /// This drive does not have the parameter (unknown index, not implemented, option card
    /// missing): a backup leaves it out.
    Absent,
    /// A passing fault of the drive (e.g. SEW 6/2 "internal communication error: repeat the
    /// service"): the same request may succeed when repeated.
    Transient,
    /// Anything else (value refused, parameter lock, controller inhibit needed, …).
    Refused,
}

impl std::fmt::Display for DeviceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

/// Read and write parameters of one drive by their table entries: what a protocol gives every
/// front end. Values are raw (the family's table scales them, [`Target`]).
///
/// The futures are not `Send`: a client owns its drive's line and runs on one thread (the
/// command line's current-thread runtime, a gateway bus task on a `LocalSet`).
#[allow(async_fn_in_trait)]
pub trait ParamClient {
    /// The family whose table the drive's parameters come from.
    fn family(&self) -> Family;

    /// A name of the drive for the EEPROM-wear log: the canonical port path (symlinks and `//`
    /// resolved, see [`crate::text::canonical_port`]) and the address the drive really has (a point-to-point
    /// address is resolved by asking the drive), so that no second way to the same drive
    /// starts a fresh log.
    async fn drive_key(&mut self) -> std::result::Result<String, ClientError>;

    /// Indices of the drive's own settings for the link this client talks over (address,
    /// baud rate, timeouts): writing one needs confirmation.
    fn link_settings(&self) -> &'static [u16] {
        &[]
    }

    /// What writing `raw` to the link setting `target` does to the link, for a person (e.g.
    /// "the drive will answer at address 5").
    fn link_change(&self, target: &Target, raw: i64) -> String {
        format!(
            "writing {raw} to {} changes how the drive is reached",
            target.label()
        )
    }

    /// The link setting `target` was just written with `raw`: follow it where the client can
    /// (talk to the new address from now on) and say where the drive answers now.
    fn follow_link_change(&mut self, target: &Target, raw: i64) -> String {
        self.link_change(target, raw)
    }

    /// Indices a restore never writes (commands, the link's own settings).
    fn not_restored(&self) -> &'static [u16] {
        &[]
    }

    /// The raw value of `target`.
    async fn read(&mut self, target: &Target) -> std::result::Result<i64, ClientError>;

    /// Write raw `raw` to `target` (the value has passed [`Target::check_width`]).
    async fn write(
        &mut self,
        target: &Target,
        raw: i64,
        persistence: Persistence,
    ) -> std::result::Result<(), ClientError>;

    /// Fields that identify the drive in a backup (device type, firmware, …).
    async fn identify(&mut self) -> std::result::Result<Map<String, Value>, ClientError>;

    /// The drive's present fault as its manual names it, `None` without one; one read of the
    /// family's fault parameter: a MOVIDRIVE's P012 (status word 1: bit 5 and the fault number
    /// in the high byte, `F47 TIMEOUT SBUS`), NORD's P700 [-01] (present fault), Bonfiglioli's
    /// 260 (current fault); a number the table does not name is said as a number.
    async fn present_fault(&mut self) -> std::result::Result<Option<String>, ClientError> {
        let family = self.family();
        let t = match family {
            Family::Nord => crate::nord::resolve("P700", Some(1), None, false)
                .ok()
                .and_then(|v| v.into_iter().next()),
            Family::Bonfiglioli => drive_profile::family::lookup(family, "260").map(Target::of),
            _ => drive_profile::family::lookup(family, "P012").map(Target::of),
        }
        .ok_or_else(|| {
            ClientError::Request(format!("the {family} table has no fault parameter"))
        })?;
        let raw = self.read(&t).await?;
        Ok(match family {
            Family::Nord | Family::Bonfiglioli => crate::meaning::fault_text(&t, raw),
            _ => crate::meaning::sew_fault_text(drive_profile::sew::StatusWord1::from_bits(
                (raw & 0xFFFF) as u16,
            )),
        })
    }

    /// What is known of the drive beyond the table, for the meaning of its values (a
    /// Bonfiglioli drive's variant decodes its status word): nothing by default.
    fn device(&self) -> crate::meaning::Device {
        crate::meaning::Device::default()
    }

    /// Bytes the link discarded so far because they arrived before a request had left the
    /// port (an answer an earlier program left there, a late answer): never taken as an
    /// answer; a front end reports them.
    fn stale_bytes(&self) -> u64 {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A drive of `family` whose every read answers `raw`.
    struct Answers {
        family: Family,
        raw: i64,
    }

    impl ParamClient for Answers {
        fn family(&self) -> Family {
            self.family
        }
        async fn drive_key(&mut self) -> Result<String, ClientError> {
            Ok("test".into())
        }
        async fn read(&mut self, _: &Target) -> Result<i64, ClientError> {
            Ok(self.raw)
        }
        async fn write(&mut self, _: &Target, _: i64, _: Persistence) -> Result<(), ClientError> {
            Ok(())
        }
        async fn identify(&mut self) -> Result<Map<String, Value>, ClientError> {
            Ok(Map::new())
        }
    }

    fn fault(family: Family, raw: i64) -> Option<String> {
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        rt.block_on(Answers { family, raw }.present_fault())
            .unwrap()
    }

    /// The present fault of each family, from the raw value of its fault parameter: the
    /// manual's name where the table has it (the gateway's status topic says it).
    #[test]
    fn the_present_fault_is_read_and_named_in_every_family() {
        // MOVIDRIVE P012: status word 1 with bit 5 (fault/warning) set, the fault number in the
        // high byte: F43 RS-485 timeout, F47 SBus timeout (named by the manual).
        assert_eq!(fault(Family::Movidrive, 0x2B20).as_deref(), Some("F43"));
        assert_eq!(
            fault(Family::Movidrive, 0x2F20).as_deref(),
            Some("F47 TIMEOUT SBUS")
        );
        // Bit 5 clear: no fault, whatever the high byte (the unit status).
        assert_eq!(fault(Family::Movidrive, 0x0407), None);
        // NORD P700 [-01] and Bonfiglioli 260: zero is no fault, anything else is named.
        assert_eq!(fault(Family::Nord, 0), None);
        assert!(fault(Family::Nord, 3).is_some_and(|t| t.contains('3')));
        assert_eq!(fault(Family::Bonfiglioli, 0), None);
        let t = fault(Family::Bonfiglioli, 0x0102).unwrap();
        assert!(t.starts_with("F0102") && t.contains("overloaded"), "{t}");
    }
}
