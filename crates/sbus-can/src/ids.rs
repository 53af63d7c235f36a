//! SBus identifiers (manual ch. 5.1 "CAN-Bus Identifier", "Bildung der Identifier"; ch. 5.6).
//!
//! An SBus identifier is a standard (11-bit) CAN identifier:
//!
//! | bits | 10 | 9 | 8 … 3 | 2 … 0 |
//! |---|---|---|---|---|
//! | meaning | reserved, 0 | 1 = parameter, 0 = process data | SBus address (P813) or group address (P814) | function |
//!
//! | identifier | telegram |
//! |---|---|
//! | 8 × address + 3 | process output data (PO), master → drive |
//! | 8 × address + 4 | process input data (PI), drive → master |
//! | 8 × address + 5 | process output data, synchronised (PO sync) |
//! | 8 × group + 6 | group process output data (GPO) |
//! | 8 × address + 512 + 3 | parameter request |
//! | 8 × address + 512 + 4 | parameter response |
//! | 8 × group + 512 + 6 | group parameter request |
//!
//! The synchronisation telegram has its own identifier, P817 (0–2047, factory setting 0).
//!
//! The identifiers span 3 … 1022, not 3 … 1020 as the manual's technical data say (erratum
//! SB-E1 in `docs/errata-sbus.md`: the group parameter request of group 63 is 1022).

use core::fmt;

/// The highest SBus address and group address (P813, P814).
pub const MAX_ADDRESS: u8 = 63;

/// Factory setting of P817 "SBus synchronisation ID".
pub const DEFAULT_SYNC_ID: u16 = 0;

/// The highest standard CAN identifier.
pub const MAX_STANDARD_ID: u16 = 2047;

/// Bit 9 of an SBus identifier: parameter (1) or process data (0).
const PARAMETER_BIT: u16 = 512;
/// Bit 10, reserved: always 0 in an SBus MOVILINK identifier.
const RESERVED_BIT: u16 = 1024;

/// An SBus address or group address, 0–63.
///
/// ```
/// use sbus_can::ids::Address;
/// assert_eq!(Address::new(63).map(Address::get), Some(63));
/// assert!(Address::new(64).is_none());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Address(u8);

impl Address {
    /// Address `a`, `None` above 63.
    pub const fn new(a: u8) -> Option<Address> {
        if a <= MAX_ADDRESS {
            Some(Address(a))
        } else {
            None
        }
    }

    /// The number, 0–63.
    pub const fn get(self) -> u8 {
        self.0
    }
}

impl fmt::Display for Address {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// The kinds of SBus MOVILINK telegram that have an address-derived identifier.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kind {
    /// PO: process output data, master → drive (8a + 3).
    ProcessOutput,
    /// PI: process input data, drive → master (8a + 4).
    ProcessInput,
    /// PO sync: process output data the drive takes at the next SYNC (8a + 5).
    ProcessOutputSync,
    /// GPO: group process output data, master → every drive of group g (8g + 6); not answered.
    GroupProcessOutput,
    /// Parameter request, master → drive (8a + 512 + 3).
    ParamRequest,
    /// Parameter response, drive → master (8a + 512 + 4).
    ParamResponse,
    /// Group parameter request, master → every drive of group g (8g + 512 + 6); write
    /// services only, not answered.
    GroupParamRequest,
}

impl Kind {
    /// Every kind, in the order of the manual's table.
    pub const ALL: [Kind; 7] = [
        Kind::ProcessOutput,
        Kind::ProcessInput,
        Kind::ProcessOutputSync,
        Kind::GroupProcessOutput,
        Kind::ParamRequest,
        Kind::ParamResponse,
        Kind::GroupParamRequest,
    ];

    /// The function (bits 0–2).
    pub const fn function(self) -> u16 {
        match self {
            Kind::ProcessOutput | Kind::ParamRequest => 3,
            Kind::ProcessInput | Kind::ParamResponse => 4,
            Kind::ProcessOutputSync => 5,
            Kind::GroupProcessOutput | Kind::GroupParamRequest => 6,
        }
    }

    /// Whether bit 9 is set (parameter telegram).
    pub const fn is_parameter(self) -> bool {
        matches!(
            self,
            Kind::ParamRequest | Kind::ParamResponse | Kind::GroupParamRequest
        )
    }

    /// Whether the address in the identifier is a group address (P814), not an SBus address.
    pub const fn is_group(self) -> bool {
        matches!(self, Kind::GroupProcessOutput | Kind::GroupParamRequest)
    }

    /// Whether the drive sends it (PI, parameter response); the others the master sends.
    pub const fn from_drive(self) -> bool {
        matches!(self, Kind::ProcessInput | Kind::ParamResponse)
    }

    /// The data length on the wire: 6 bytes (three process data words) or 8 (parameter channel).
    pub const fn data_len(self) -> usize {
        if self.is_parameter() { 8 } else { 6 }
    }

    /// The identifier of this kind for address (or group address) `a`.
    ///
    /// ```
    /// use sbus_can::ids::{Address, Kind};
    /// let a = Address::new(33).unwrap();
    /// assert_eq!(Kind::ProcessOutput.id(a), 267);
    /// assert_eq!(Kind::ParamResponse.id(a), 780);
    /// ```
    pub const fn id(self, a: Address) -> u16 {
        8 * a.0 as u16
            + self.function()
            + if self.is_parameter() {
                PARAMETER_BIT
            } else {
                0
            }
    }

    /// The kind and address of the SBus MOVILINK identifier `id`; `None` for any other
    /// identifier (bit 10 set, functions 0–2 and 7, function 5 with bit 9 set).
    ///
    /// ```
    /// use sbus_can::ids::{Address, Kind};
    /// assert_eq!(Kind::classify(779), Some((Kind::ParamRequest, Address::new(33).unwrap())));
    /// assert_eq!(Kind::classify(0), None); // the factory sync identifier is no MOVILINK one
    /// assert_eq!(Kind::classify(1024 + 3), None); // reserved bit 10
    /// ```
    pub const fn classify(id: u16) -> Option<(Kind, Address)> {
        if id & RESERVED_BIT != 0 || id > MAX_STANDARD_ID {
            return None;
        }
        let address = Address(((id >> 3) & 0x3F) as u8);
        let kind = match (id & PARAMETER_BIT != 0, id & 7) {
            (false, 3) => Kind::ProcessOutput,
            (false, 4) => Kind::ProcessInput,
            (false, 5) => Kind::ProcessOutputSync,
            (false, 6) => Kind::GroupProcessOutput,
            (true, 3) => Kind::ParamRequest,
            (true, 4) => Kind::ParamResponse,
            (true, 6) => Kind::GroupParamRequest,
            _ => return None,
        };
        Some((kind, address))
    }

    /// The manual's name of the telegram, in English.
    pub const fn name(self) -> &'static str {
        match self {
            Kind::ProcessOutput => "process output data (PO)",
            Kind::ProcessInput => "process input data (PI)",
            Kind::ProcessOutputSync => "process output data, synchronised (PO sync)",
            Kind::GroupProcessOutput => "group process output data (GPO)",
            Kind::ParamRequest => "parameter request",
            Kind::ParamResponse => "parameter response",
            Kind::GroupParamRequest => "group parameter request",
        }
    }
}

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Whether a node sends or receives an identifier.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// The node receives it.
    Receive,
    /// The node transmits it.
    Transmit,
}

/// One identifier a node uses: the identifier, the telegram and whether the node sends it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct IdUse {
    /// The identifier.
    pub id: u16,
    /// The telegram (`None`: the synchronisation telegram).
    pub kind: Option<Kind>,
    /// Whether the node transmits or receives it.
    pub direction: Direction,
}

/// The identifiers a MOVIDRIVE uses as an SBus slave (P813, P814, P817).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SlaveIds {
    /// P813 SBus address.
    pub address: Address,
    /// P814 SBus group address.
    pub group: Address,
    /// P817 SBus synchronisation ID.
    pub sync_id: u16,
}

impl SlaveIds {
    /// The identifiers in the manual's order: parameter request and response, PO, PI, PO sync
    /// (by the SBus address), group parameter request and GPO (by the group address), then SYNC.
    pub fn uses(&self) -> [IdUse; 8] {
        let by = |kind: Kind, a: Address, direction| IdUse {
            id: kind.id(a),
            kind: Some(kind),
            direction,
        };
        use Direction::{Receive, Transmit};
        [
            by(Kind::ParamRequest, self.address, Receive),
            by(Kind::ParamResponse, self.address, Transmit),
            by(Kind::ProcessOutput, self.address, Receive),
            by(Kind::ProcessInput, self.address, Transmit),
            by(Kind::ProcessOutputSync, self.address, Receive),
            by(Kind::GroupParamRequest, self.group, Receive),
            by(Kind::GroupProcessOutput, self.group, Receive),
            IdUse {
                id: self.sync_id,
                kind: None,
                direction: Receive,
            },
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn a(n: u8) -> Address {
        Address::new(n).unwrap()
    }

    /// Manual ch. 5.6, "IDs auf dem CAN-Bus": four drives at addresses 33, 17, 11 and 7.
    #[test]
    fn manual_table_5_6() {
        let table: [(u8, [u16; 5]); 4] = [
            (33, [267, 268, 269, 779, 780]),
            (17, [139, 140, 141, 651, 652]),
            (11, [91, 92, 93, 603, 604]),
            (7, [59, 60, 61, 571, 572]),
        ];
        for (addr, ids) in table {
            let got = [
                Kind::ProcessOutput.id(a(addr)),
                Kind::ProcessInput.id(a(addr)),
                Kind::ProcessOutputSync.id(a(addr)),
                Kind::ParamRequest.id(a(addr)),
                Kind::ParamResponse.id(a(addr)),
            ];
            assert_eq!(got, ids, "address {addr}");
        }
    }

    /// Manual ch. 2.2 says identifiers 3 … 1020; the group parameter request of group 63 is
    /// 8 × 63 + 512 + 6 = 1022 (erratum SB-E1).
    #[test]
    fn identifier_range_of_technical_data_sb_e1() {
        let mut min = u16::MAX;
        let mut max = 0;
        for n in 0..=MAX_ADDRESS {
            for k in Kind::ALL {
                let id = k.id(a(n));
                min = min.min(id);
                max = max.max(id);
                assert_eq!(id & RESERVED_BIT, 0);
            }
        }
        assert_eq!((min, max), (3, 1022));
        assert_eq!(Kind::GroupParamRequest.id(a(63)), 1022);
        assert_eq!(Kind::ParamResponse.id(a(63)), 1020);
    }

    #[test]
    fn classify_inverts_id_and_rejects_the_rest() {
        let mut sbus = 0;
        for id in 0..=MAX_STANDARD_ID {
            if let Some((k, addr)) = Kind::classify(id) {
                assert_eq!(k.id(addr), id);
                sbus += 1;
            }
        }
        // 64 addresses × 7 kinds, every one distinct.
        assert_eq!(sbus, 64 * 7);
        assert_eq!(Kind::classify(2048), None);
    }

    /// Manual ch. 5.5 example, device 1 (address 0, group 0): 515, 516, 3, 4, 5, 518, 6.
    #[test]
    fn manual_table_5_5_device_1() {
        let ids = SlaveIds {
            address: a(0),
            group: a(0),
            sync_id: DEFAULT_SYNC_ID,
        };
        let got: [u16; 7] = core::array::from_fn(|i| ids.uses()[i].id);
        assert_eq!(got, [515, 516, 3, 4, 5, 518, 6]);
    }
}
