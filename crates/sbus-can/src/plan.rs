//! The identifier plan of a whole SBus (manual ch. 5.5, 5.6, P817): which node sends and
//! receives which identifier, checked against the rules (feature `std`).
//!
//! A [`Plan`] is a bit rate and a list of [`Device`]s: each with a name, its SBus slave
//! settings (P813 address, P814 group, P817 sync identifier; `None` for a node that is no
//! SBus slave, such as a PLC), the addresses and groups it is MOVILINK master of (IPOS
//! `MOVLNK`, master-slave operation), whether it sends SYNC, and its variable objects. Plain
//! structs, built directly or from a file.
//!
//! [`Plan::check`] reports every [`Violation`]:
//!
//! * rule 1 of ch. 5.5: an identifier is sent by one node only (two devices' MOVILINK or
//!   variable telegrams on one identifier, a variable transmit object on another device's
//!   MOVILINK transmit identifier);
//! * rule 2: a device's variable objects (transmit or receive) are none of the identifiers it
//!   uses for MOVILINK, its SYNC identifier included;
//! * beyond the two rules: a variable transmit object on an identifier another device receives
//!   as a MOVILINK or SYNC telegram while no one sends it by MOVILINK (the drive would take the
//!   variables as setpoints or parameters; ch. 6.1 "MOVILINK-Übertragung gestört");
//! * P817: a sync identifier equal to a MOVILINK identifier in use on the bus;
//! * ch. 5.6: two slaves with one SBus address;
//! * object limits (5 cyclic with 1–9 ms, 10 with 10–65530 ms, 32 receive), invalid object
//!   numbers, times and `Len` words, one object number twice in a device, and a bus load of
//!   the cyclic objects above 100 %.
//!
//! [`Plan::forbidden`] lists the identifiers a device's variable objects may not use, as the
//! manual's table "Folgende Variablen-Objekte dürfen im Beispiel nicht verwendet werden"
//! (see erratum SB-E12 for where the printed table differs).
//!
//! ```
//! use sbus_can::ids::{Address, SlaveIds};
//! use sbus_can::plan::{Device, Plan, Target};
//! use drive_core::can::Bitrate;
//!
//! let a = |n| Address::new(n).unwrap();
//! let mut d1 = Device::slave("device 1", SlaveIds { address: a(0), group: a(0), sync_id: 0 });
//! d1.master_of = vec![Target::Address(a(1)), Target::Group(a(2))];
//! let d2 = Device::slave("device 2", SlaveIds { address: a(1), group: a(2), sync_id: 0 });
//! let plan = Plan { bitrate: Bitrate::K500, devices: vec![d1, d2] };
//! assert!(plan.check().is_empty());
//! assert_eq!(plan.forbidden(1).unwrap().transmit, [523, 524, 11, 12, 13, 534, 22, 0, 516, 4]);
//! ```

use std::collections::BTreeMap;
use std::fmt;
use std::string::String;
use std::vec::Vec;

use drive_core::can::Bitrate;

use crate::busload::BusLoad;
use crate::ids::{Address, Direction, IdUse, Kind, MAX_STANDARD_ID, SlaveIds};
use crate::variable::{CycleClass, CyclicTiming, Len, MAX_RECEIVE, SetupError};

/// A node a device is MOVILINK master of.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Target {
    /// One slave by its SBus address (IPOS `MOVLNK` address 0–63): parameter request and
    /// response, PO, PI, PO sync.
    Address(Address),
    /// A group by its group address (IPOS `MOVLNK` address 100–163, master-slave operation):
    /// group parameter request and group PO, never answered.
    Group(Address),
}

/// The kind of a variable object.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ObjectKind {
    /// A cyclic transmit object (`SCD_TRCYCL`).
    Cyclic {
        /// Cycle time in ms.
        cycle_ms: u32,
        /// Offset in ms.
        offset_ms: u32,
    },
    /// An acyclic transmit object (`SCD_TRACYCL`).
    Acyclic,
    /// A receive object (`SCD_REC`).
    Receive,
}

impl ObjectKind {
    /// Whether the device sends it.
    pub const fn transmits(self) -> bool {
        !matches!(self, ObjectKind::Receive)
    }

    /// The name used in messages.
    pub const fn name(self) -> &'static str {
        match self {
            ObjectKind::Cyclic { .. } => "cyclic transmit object",
            ObjectKind::Acyclic => "acyclic transmit object",
            ObjectKind::Receive => "receive object",
        }
    }
}

/// One variable object of a device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Object {
    /// The object number (identifier, 0–2047).
    pub id: u16,
    /// The `Len` word (length in bits 0–3, format in bit 8).
    pub len: u32,
    /// Cyclic, acyclic or receive.
    pub kind: ObjectKind,
}

/// One node on the bus.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Device {
    /// The name violations use.
    pub name: String,
    /// P813, P814, P817 of a MOVIDRIVE (every MOVIDRIVE is an SBus slave); `None` for a node
    /// that is no SBus slave (a PLC, a PC).
    pub slave: Option<SlaveIds>,
    /// The nodes it is MOVILINK master of.
    pub master_of: Vec<Target>,
    /// The identifier it sends SYNC on, if it does.
    pub sends_sync: Option<u16>,
    /// Its variable objects.
    pub objects: Vec<Object>,
}

/// What a device uses an identifier for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Usage {
    /// A MOVILINK telegram (`None`: SYNC).
    Movilink(Option<Kind>),
    /// A variable object.
    Variable(ObjectKind),
}

impl fmt::Display for Usage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Usage::Movilink(Some(kind)) => write!(f, "MOVILINK {kind}"),
            Usage::Movilink(None) => f.write_str("SYNC"),
            Usage::Variable(kind) => f.write_str(kind.name()),
        }
    }
}

/// One device's use of an identifier, as a violation names it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IdUser {
    /// The device's name.
    pub device: String,
    /// What it uses the identifier for.
    pub usage: Usage,
}

/// Which object limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Limit {
    /// Cyclic transmit objects of one class.
    Cyclic(CycleClass),
    /// Receive objects.
    Receive,
}

/// One problem of a plan.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Violation {
    /// Rule 1 of ch. 5.5: more than one device sends the identifier.
    SharedTransmitId {
        /// The identifier.
        id: u16,
        /// Every device that sends it and for what.
        transmitters: Vec<IdUser>,
    },
    /// Rule 2 of ch. 5.5: a device's variable object on an identifier the device uses for
    /// MOVILINK or SYNC.
    OwnMovilinkId {
        /// The device.
        device: String,
        /// The identifier.
        id: u16,
        /// The variable object.
        object: ObjectKind,
        /// The MOVILINK telegram (`None`: SYNC).
        movilink: Option<Kind>,
    },
    /// A variable transmit object on an identifier another device receives as a MOVILINK or
    /// SYNC telegram (that device would take the variables as one).
    ReceivedAsMovilink {
        /// The device sending the variable object.
        device: String,
        /// The identifier.
        id: u16,
        /// The device that receives it as MOVILINK.
        receiver: String,
        /// The telegram it takes it for (`None`: SYNC).
        kind: Option<Kind>,
    },
    /// P817: a sync identifier equal to a MOVILINK identifier in use on the bus.
    SyncIdCollision {
        /// The device whose P817 it is.
        device: String,
        /// The sync identifier.
        sync_id: u16,
        /// The device using it for MOVILINK.
        user: String,
        /// The MOVILINK telegram.
        kind: Kind,
    },
    /// Ch. 5.6: two slaves with one SBus address (P813).
    DuplicateAddress {
        /// The address.
        address: Address,
        /// The devices.
        devices: Vec<String>,
    },
    /// A device has more objects than the limit.
    TooManyObjects {
        /// The device.
        device: String,
        /// Which limit.
        limit: Limit,
        /// Objects it has.
        count: usize,
        /// The limit.
        max: usize,
    },
    /// An object number above 2047.
    InvalidObjectNo {
        /// The device.
        device: String,
        /// The number.
        id: u16,
    },
    /// A wrong cycle time, offset or `Len` word.
    InvalidObject {
        /// The device.
        device: String,
        /// The object number.
        id: u16,
        /// What is wrong.
        error: SetupError,
    },
    /// One object number twice among a device's variable objects.
    DuplicateObject {
        /// The device.
        device: String,
        /// The object number.
        id: u16,
    },
    /// The cyclic objects of all devices load the bus above 100 %.
    BusOverload {
        /// The load.
        load: BusLoad,
        /// The bit rate.
        bitrate: Bitrate,
    },
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Violation::SharedTransmitId { id, transmitters } => {
                write!(
                    f,
                    "identifier {id} is sent by more than one node (ch. 5.5 rule 1):"
                )?;
                for (i, t) in transmitters.iter().enumerate() {
                    let sep = if i == 0 { " " } else { ", " };
                    write!(f, "{sep}\"{}\" ({})", t.device, t.usage)?;
                }
                Ok(())
            }
            Violation::OwnMovilinkId {
                device,
                id,
                object,
                movilink,
            } => write!(
                f,
                "\"{device}\": {} {id} is its own {} identifier (ch. 5.5 rule 2)",
                object.name(),
                Usage::Movilink(*movilink)
            ),
            Violation::ReceivedAsMovilink {
                device,
                id,
                receiver,
                kind,
            } => write!(
                f,
                "\"{device}\": transmit object {id} is \"{receiver}\"'s {} identifier: \"{receiver}\" would take the variables as that telegram",
                Usage::Movilink(*kind)
            ),
            Violation::SyncIdCollision {
                device,
                sync_id,
                user,
                kind,
            } => write!(
                f,
                "\"{device}\": sync identifier (P817) {sync_id} is the {kind} identifier of \"{user}\""
            ),
            Violation::DuplicateAddress { address, devices } => {
                write!(
                    f,
                    "SBus address (P813) {address} is set on more than one device:"
                )?;
                for (i, d) in devices.iter().enumerate() {
                    let sep = if i == 0 { " " } else { ", " };
                    write!(f, "{sep}\"{d}\"")?;
                }
                Ok(())
            }
            Violation::TooManyObjects {
                device,
                limit,
                count,
                max,
            } => match limit {
                Limit::Cyclic(class) => write!(
                    f,
                    "\"{device}\": {count} cyclic transmit objects with {class}, at most {max}"
                ),
                Limit::Receive => {
                    write!(f, "\"{device}\": {count} receive objects, at most {max}")
                }
            },
            Violation::InvalidObjectNo { device, id } => write!(
                f,
                "\"{device}\": object number {id} is no 11-bit identifier (0–2047)"
            ),
            Violation::InvalidObject { device, id, error } => {
                write!(f, "\"{device}\": object {id}: {error}")
            }
            Violation::DuplicateObject { device, id } => {
                write!(
                    f,
                    "\"{device}\": object number {id} is set up more than once"
                )
            }
            Violation::BusOverload { load, bitrate } => write!(
                f,
                "the cyclic variable objects load the bus {load} at {bitrate}: more than it carries"
            ),
        }
    }
}

impl std::error::Error for Violation {}

/// The identifiers a device's variable objects may not use.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Forbidden {
    /// For transmit objects: its own MOVILINK and SYNC identifiers (rule 2), every identifier
    /// another node sends, by MOVILINK or as a variable object (rule 1). The manual's order:
    /// its own first, then the others' by device.
    pub transmit: Vec<u16>,
    /// For receive objects: its own MOVILINK and SYNC identifiers (rule 2).
    pub receive: Vec<u16>,
}

impl Device {
    /// A MOVIDRIVE at `slave`, master of nothing, no variable objects.
    pub fn slave(name: impl Into<String>, slave: SlaveIds) -> Device {
        Device {
            name: name.into(),
            slave: Some(slave),
            ..Device::default()
        }
    }

    /// The identifiers the device uses for MOVILINK, in the manual's order: as slave (request,
    /// response, PO, PI, PO sync by its address, group parameter request and GPO by its group),
    /// as master of each target, then the SYNC it receives as a slave and the SYNC it sends.
    pub fn movilink_uses(&self) -> Vec<IdUse> {
        use Direction::{Receive, Transmit};
        let mut out = Vec::new();
        let slave = self.slave.map(|ids| ids.uses());
        // The slave's telegrams first, its SYNC after the master's (the manual's table has no
        // SYNC row; this keeps its order).
        let (sync_rx, slave_uses) = match &slave {
            Some(uses) => (uses.iter().find(|u| u.kind.is_none()), uses.as_slice()),
            None => (None, &[][..]),
        };
        out.extend(slave_uses.iter().filter(|u| u.kind.is_some()));
        let by = |kind: Kind, a: Address, direction| IdUse {
            id: kind.id(a),
            kind: Some(kind),
            direction,
        };
        for t in &self.master_of {
            match *t {
                Target::Address(a) => out.extend([
                    by(Kind::ParamRequest, a, Transmit),
                    by(Kind::ParamResponse, a, Receive),
                    by(Kind::ProcessOutput, a, Transmit),
                    by(Kind::ProcessInput, a, Receive),
                    by(Kind::ProcessOutputSync, a, Transmit),
                ]),
                Target::Group(g) => out.extend([
                    by(Kind::GroupParamRequest, g, Transmit),
                    by(Kind::GroupProcessOutput, g, Transmit),
                ]),
            }
        }
        out.extend(sync_rx);
        if let Some(id) = self.sends_sync {
            out.push(IdUse {
                id,
                kind: None,
                direction: Transmit,
            });
        }
        out
    }

    /// The problems of the device's own objects: invalid numbers, times and `Len` words,
    /// duplicates, limits and rule 2.
    pub fn check_objects(&self) -> Vec<Violation> {
        let mut out = Vec::new();
        let name = || self.name.clone();
        let uses = self.movilink_uses();
        let mut seen = BTreeMap::new();
        let (mut fast, mut slow, mut receive) = (0, 0, 0);
        for o in &self.objects {
            if o.id > MAX_STANDARD_ID {
                out.push(Violation::InvalidObjectNo {
                    device: name(),
                    id: o.id,
                });
                continue;
            }
            let count = seen.entry(o.id).or_insert(0u32);
            *count += 1;
            if *count == 2 {
                out.push(Violation::DuplicateObject {
                    device: name(),
                    id: o.id,
                });
            }
            if let Err(e) = Len::from_word(o.len) {
                out.push(Violation::InvalidObject {
                    device: name(),
                    id: o.id,
                    error: SetupError::Len(e),
                });
            }
            match o.kind {
                ObjectKind::Cyclic {
                    cycle_ms,
                    offset_ms,
                } => match CyclicTiming::new(cycle_ms, offset_ms) {
                    Ok(t) if t.class() == CycleClass::Fast => fast += 1,
                    Ok(_) => slow += 1,
                    Err(error) => out.push(Violation::InvalidObject {
                        device: name(),
                        id: o.id,
                        error,
                    }),
                },
                ObjectKind::Receive => receive += 1,
                ObjectKind::Acyclic => {}
            }
            // Rule 2: one report per object, naming the first MOVILINK use.
            if let Some(u) = uses.iter().find(|u| u.id == o.id) {
                out.push(Violation::OwnMovilinkId {
                    device: name(),
                    id: o.id,
                    object: o.kind,
                    movilink: u.kind,
                });
            }
        }
        for (limit, count, max) in [
            (
                Limit::Cyclic(CycleClass::Fast),
                fast,
                CycleClass::Fast.max(),
            ),
            (
                Limit::Cyclic(CycleClass::Slow),
                slow,
                CycleClass::Slow.max(),
            ),
            (Limit::Receive, receive, MAX_RECEIVE),
        ] {
            if count > max {
                out.push(Violation::TooManyObjects {
                    device: name(),
                    limit,
                    count,
                    max,
                });
            }
        }
        out
    }
}

/// A bus: its bit rate (P816) and its devices.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Plan {
    /// P816, for the bus load.
    pub bitrate: Bitrate,
    /// The nodes.
    pub devices: Vec<Device>,
}

/// One identifier one device uses.
struct Entry<'a> {
    device: &'a Device,
    id: u16,
    usage: Usage,
    direction: Direction,
}

impl Plan {
    /// Every use of every identifier, device by device.
    fn entries(&self) -> Vec<Entry<'_>> {
        let mut out = Vec::new();
        for device in &self.devices {
            for u in device.movilink_uses() {
                out.push(Entry {
                    device,
                    id: u.id,
                    usage: Usage::Movilink(u.kind),
                    direction: u.direction,
                });
            }
            for o in device.objects.iter().filter(|o| o.id <= MAX_STANDARD_ID) {
                out.push(Entry {
                    device,
                    id: o.id,
                    usage: Usage::Variable(o.kind),
                    direction: if o.kind.transmits() {
                        Direction::Transmit
                    } else {
                        Direction::Receive
                    },
                });
            }
        }
        out
    }

    /// Every violation of the plan (empty: the plan is sound).
    pub fn check(&self) -> Vec<Violation> {
        let mut out = Vec::new();
        let entries = self.entries();

        // Ch. 5.6: one SBus address per slave.
        let mut by_address: BTreeMap<Address, Vec<String>> = BTreeMap::new();
        for d in &self.devices {
            if let Some(s) = d.slave {
                by_address
                    .entry(s.address)
                    .or_default()
                    .push(d.name.clone());
            }
        }
        for (address, devices) in by_address {
            if devices.len() > 1 {
                out.push(Violation::DuplicateAddress { address, devices });
            }
        }

        // Each device's own objects (rule 2, limits, validity).
        for d in &self.devices {
            out.extend(d.check_objects());
        }

        // Rule 1: one transmitting device per identifier.
        let mut transmitters: BTreeMap<u16, Vec<&Entry<'_>>> = BTreeMap::new();
        for e in entries
            .iter()
            .filter(|e| e.direction == Direction::Transmit)
        {
            transmitters.entry(e.id).or_default().push(e);
        }
        for (&id, list) in &transmitters {
            let Some(first) = list.first() else { continue };
            if list.iter().any(|e| !std::ptr::eq(e.device, first.device)) {
                out.push(Violation::SharedTransmitId {
                    id,
                    transmitters: list
                        .iter()
                        .map(|e| IdUser {
                            device: e.device.name.clone(),
                            usage: e.usage,
                        })
                        .collect(),
                });
            }
        }

        // Variable transmit objects on another device's MOVILINK receive identifier that no
        // one sends by MOVILINK (otherwise rule 1 has reported it).
        for e in &entries {
            if !matches!(e.usage, Usage::Variable(k) if k.transmits()) {
                continue;
            }
            let movilink_sent = transmitters
                .get(&e.id)
                .is_some_and(|l| l.iter().any(|t| matches!(t.usage, Usage::Movilink(_))));
            if movilink_sent {
                continue;
            }
            for r in &entries {
                if let Usage::Movilink(kind) = r.usage
                    && r.id == e.id
                    && r.direction == Direction::Receive
                    && !std::ptr::eq(r.device, e.device)
                {
                    out.push(Violation::ReceivedAsMovilink {
                        device: e.device.name.clone(),
                        id: e.id,
                        receiver: r.device.name.clone(),
                        kind,
                    });
                }
            }
        }

        // P817: no sync identifier on a MOVILINK identifier in use.
        for d in &self.devices {
            let Some(s) = d.slave else { continue };
            let mut named = Vec::new();
            for e in &entries {
                if let Usage::Movilink(Some(kind)) = e.usage
                    && e.id == s.sync_id
                    && !named.contains(&e.device.name)
                {
                    named.push(e.device.name.clone());
                    out.push(Violation::SyncIdCollision {
                        device: d.name.clone(),
                        sync_id: s.sync_id,
                        user: e.device.name.clone(),
                        kind,
                    });
                }
            }
        }

        // The bus load of every cyclic object.
        let load = self
            .devices
            .iter()
            .flat_map(|d| &d.objects)
            .filter_map(|o| match o.kind {
                ObjectKind::Cyclic { cycle_ms, .. } if o.id <= MAX_STANDARD_ID => {
                    let len = Len::from_word(o.len).ok()?;
                    Some(BusLoad::cyclic_ms(len.bytes(), cycle_ms, self.bitrate))
                }
                _ => None,
            })
            .fold(BusLoad::ZERO, |a, b| a + b);
        if load.is_overload() {
            out.push(Violation::BusOverload {
                load,
                bitrate: self.bitrate,
            });
        }
        out
    }

    /// The identifiers device `index`'s variable objects may not use; `None` for no such
    /// device.
    pub fn forbidden(&self, index: usize) -> Option<Forbidden> {
        let device = self.devices.get(index)?;
        let mut own = Vec::new();
        for u in device.movilink_uses() {
            if !own.contains(&u.id) {
                own.push(u.id);
            }
        }
        let mut transmit = own.clone();
        for e in self.entries() {
            if e.direction == Direction::Transmit
                && !std::ptr::eq(e.device, device)
                && !transmit.contains(&e.id)
            {
                transmit.push(e.id);
            }
        }
        Some(Forbidden {
            transmit,
            receive: own,
        })
    }
}

#[cfg(test)]
mod tests;
