//! SBus MOVILINK telegrams on CAN frames (manual ch. 5.1, 5.2): synchronisation, process data
//! (always three words, big-endian) and the 8-byte parameter channel.
//!
//! [`Telegram::decode`] reads any frame and [`Telegram::encode`] writes one; neither allocates
//! nor panics. The synchronisation telegram's identifier is a setting (P817), so both take it.
//!
//! The manual defines no data for the synchronisation telegram; drivebus sends it with no data
//! bytes and accepts it with any (see `docs/protocols/sbus.md`).

use core::fmt;

use drive_core::can::{CanFrame, Frame, Id, StandardId};
use drive_profile::sew::ParamChannel;

use crate::ids::{Address, Kind};

/// Three process data words, PO1–PO3 or PI1–PI3, big-endian on the wire (6 bytes).
///
/// ```
/// use sbus_can::telegram::ProcessData;
/// let pd = ProcessData([0x0006, 5000, 0]);
/// assert_eq!(pd.to_bytes(), [0x00, 0x06, 0x13, 0x88, 0x00, 0x00]);
/// assert_eq!(ProcessData::from_bytes(pd.to_bytes()), pd);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct ProcessData(pub [u16; 3]);

impl ProcessData {
    /// Length on the wire.
    pub const LEN: usize = 6;

    /// The 6 bytes on the wire.
    pub const fn to_bytes(self) -> [u8; 6] {
        let [a, b, c] = self.0;
        let [a0, a1] = a.to_be_bytes();
        let [b0, b1] = b.to_be_bytes();
        let [c0, c1] = c.to_be_bytes();
        [a0, a1, b0, b1, c0, c1]
    }

    /// The words of the 6 bytes `b`.
    pub const fn from_bytes(b: [u8; 6]) -> Self {
        let [a0, a1, b0, b1, c0, c1] = b;
        Self([
            u16::from_be_bytes([a0, a1]),
            u16::from_be_bytes([b0, b1]),
            u16::from_be_bytes([c0, c1]),
        ])
    }
}

/// One SBus MOVILINK telegram.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Telegram {
    /// The synchronisation telegram (identifier P817), master → every drive.
    Sync,
    /// Process output data to one drive; `synchronised`: the PO-sync telegram (8a + 5), taken
    /// at the next SYNC, otherwise 8a + 3, answered within 1 ms.
    ProcessOutput {
        /// The drive's SBus address.
        address: Address,
        /// Whether it is the synchronised telegram.
        synchronised: bool,
        /// PO1–PO3.
        data: ProcessData,
    },
    /// Process input data from one drive.
    ProcessInput {
        /// The drive's SBus address.
        address: Address,
        /// PI1–PI3.
        data: ProcessData,
    },
    /// Group process output data to every drive of a group; never answered.
    GroupProcessOutput {
        /// The SBus group address.
        group: Address,
        /// PO1–PO3.
        data: ProcessData,
    },
    /// A parameter request to one drive.
    ParamRequest {
        /// The drive's SBus address.
        address: Address,
        /// The parameter channel.
        channel: ParamChannel,
    },
    /// A drive's parameter response.
    ParamResponse {
        /// The drive's SBus address.
        address: Address,
        /// The parameter channel.
        channel: ParamChannel,
    },
    /// A group parameter request (write services only); never answered.
    GroupParamRequest {
        /// The SBus group address.
        group: Address,
        /// The parameter channel.
        channel: ParamChannel,
    },
}

/// Why a frame is no SBus telegram.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum DecodeError {
    /// An extended (29-bit) identifier: SBus uses standard identifiers only.
    ExtendedId {
        /// The identifier.
        id: u32,
    },
    /// A remote frame: SBus sends none.
    Remote {
        /// The identifier.
        id: u16,
    },
    /// A standard identifier that is neither the sync identifier nor an SBus MOVILINK one
    /// (bit 10 set, or a function other than 3–6): a variable telegram or another protocol.
    NotSbus {
        /// The identifier.
        id: u16,
    },
    /// An SBus identifier with the wrong number of data bytes.
    Length {
        /// The telegram the identifier names.
        kind: Kind,
        /// Bytes the telegram has (6 or 8).
        expected: usize,
        /// Bytes the frame has.
        got: usize,
    },
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DecodeError::ExtendedId { id } => write!(
                f,
                "extended identifier {id:08X}h: SBus uses 11-bit identifiers only"
            ),
            DecodeError::Remote { id } => {
                write!(f, "remote frame on identifier {id}: SBus sends none")
            }
            DecodeError::NotSbus { id } => write!(
                f,
                "identifier {id} is no SBus MOVILINK identifier (a variable telegram or another protocol)"
            ),
            DecodeError::Length {
                kind,
                expected,
                got,
            } => write!(f, "{kind} with {got} data bytes, expected {expected}"),
        }
    }
}

impl core::error::Error for DecodeError {}

impl Telegram {
    /// The telegram on `frame`, with `sync_id` the synchronisation identifier (P817).
    ///
    /// The sync identifier is checked first: a P817 that collides with an SBus identifier
    /// (which the manual forbids) makes that identifier a SYNC.
    ///
    /// ```
    /// use drive_core::can::CanFrame;
    /// use sbus_can::telegram::{ProcessData, Telegram};
    /// use sbus_can::ids::Address;
    ///
    /// let f = CanFrame::standard(267, &[0, 6, 0x13, 0x88, 0, 0]).unwrap();
    /// let t = Telegram::decode(&f, 0).unwrap();
    /// assert_eq!(t, Telegram::ProcessOutput {
    ///     address: Address::new(33).unwrap(),
    ///     synchronised: false,
    ///     data: ProcessData([6, 5000, 0]),
    /// });
    /// assert_eq!(t.encode(0), f);
    /// ```
    pub fn decode(frame: &CanFrame, sync_id: u16) -> Result<Telegram, DecodeError> {
        let id = match frame.id() {
            Id::Standard(s) => s.as_raw(),
            Id::Extended(e) => return Err(DecodeError::ExtendedId { id: e.as_raw() }),
        };
        if frame.is_remote_frame() {
            return Err(DecodeError::Remote { id });
        }
        if id == sync_id {
            return Ok(Telegram::Sync);
        }
        let (kind, address) = Kind::classify(id).ok_or(DecodeError::NotSbus { id })?;
        let data = frame.data();
        let length = DecodeError::Length {
            kind,
            expected: kind.data_len(),
            got: data.len(),
        };
        if kind.is_parameter() {
            let bytes: [u8; 8] = data.try_into().map_err(|_| length)?;
            let channel = ParamChannel::from_bytes(bytes);
            Ok(match kind {
                Kind::ParamRequest => Telegram::ParamRequest { address, channel },
                Kind::ParamResponse => Telegram::ParamResponse { address, channel },
                _ => Telegram::GroupParamRequest {
                    group: address,
                    channel,
                },
            })
        } else {
            let bytes: [u8; 6] = data.try_into().map_err(|_| length)?;
            let data = ProcessData::from_bytes(bytes);
            Ok(match kind {
                Kind::ProcessOutput => Telegram::ProcessOutput {
                    address,
                    synchronised: false,
                    data,
                },
                Kind::ProcessOutputSync => Telegram::ProcessOutput {
                    address,
                    synchronised: true,
                    data,
                },
                Kind::ProcessInput => Telegram::ProcessInput { address, data },
                _ => Telegram::GroupProcessOutput {
                    group: address,
                    data,
                },
            })
        }
    }

    /// The telegram's kind and address, `None` for SYNC.
    pub const fn kind(&self) -> Option<(Kind, Address)> {
        Some(match *self {
            Telegram::Sync => return None,
            Telegram::ProcessOutput {
                address,
                synchronised,
                ..
            } => (
                if synchronised {
                    Kind::ProcessOutputSync
                } else {
                    Kind::ProcessOutput
                },
                address,
            ),
            Telegram::ProcessInput { address, .. } => (Kind::ProcessInput, address),
            Telegram::GroupProcessOutput { group, .. } => (Kind::GroupProcessOutput, group),
            Telegram::ParamRequest { address, .. } => (Kind::ParamRequest, address),
            Telegram::ParamResponse { address, .. } => (Kind::ParamResponse, address),
            Telegram::GroupParamRequest { group, .. } => (Kind::GroupParamRequest, group),
        })
    }

    /// The identifier of the telegram, with `sync_id` (P817, 0–2047) for SYNC.
    pub fn id(&self, sync_id: u16) -> u16 {
        match self.kind() {
            Some((kind, address)) => kind.id(address),
            None => sync_id & 0x7FF,
        }
    }

    /// The frame of the telegram, with `sync_id` (P817; taken modulo 2048) for SYNC.
    pub fn encode(&self, sync_id: u16) -> CanFrame {
        let id = StandardId::new(self.id(sync_id)).unwrap_or(StandardId::ZERO);
        let mut bytes = [0u8; 8];
        let len = match *self {
            Telegram::Sync => 0,
            Telegram::ProcessOutput { data, .. }
            | Telegram::ProcessInput { data, .. }
            | Telegram::GroupProcessOutput { data, .. } => {
                let [a, b, c, d, e, g] = data.to_bytes();
                bytes = [a, b, c, d, e, g, 0, 0];
                ProcessData::LEN
            }
            Telegram::ParamRequest { channel, .. }
            | Telegram::ParamResponse { channel, .. }
            | Telegram::GroupParamRequest { channel, .. } => {
                bytes = channel.to_bytes();
                ParamChannel::LEN
            }
        };
        CanFrame::from_array(id.into(), bytes, len)
    }
}

impl fmt::Display for Telegram {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Telegram::Sync => f.write_str("SYNC"),
            Telegram::ProcessOutput {
                address,
                synchronised,
                data: ProcessData([a, b, c]),
            } => write!(
                f,
                "PO{} to {address}: {a:04X}h {b:04X}h {c:04X}h",
                if *synchronised { " sync" } else { "" }
            ),
            Telegram::ProcessInput {
                address,
                data: ProcessData([a, b, c]),
            } => write!(f, "PI from {address}: {a:04X}h {b:04X}h {c:04X}h"),
            Telegram::GroupProcessOutput {
                group,
                data: ProcessData([a, b, c]),
            } => write!(f, "GPO to group {group}: {a:04X}h {b:04X}h {c:04X}h"),
            Telegram::ParamRequest { address, channel } => write!(
                f,
                "parameter request to {address}: management {:02X}h index {} data {:08X}h",
                channel.management.raw(),
                channel.index,
                channel.data
            ),
            Telegram::ParamResponse { address, channel } => write!(
                f,
                "parameter response from {address}: management {:02X}h index {} data {:08X}h",
                channel.management.raw(),
                channel.index,
                channel.data
            ),
            Telegram::GroupParamRequest { group, channel } => write!(
                f,
                "group parameter request to group {group}: management {:02X}h index {} data {:08X}h",
                channel.management.raw(),
                channel.index,
                channel.data
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_profile::sew::{ReturnCode, Service};
    use proptest::prelude::*;

    fn a(n: u8) -> Address {
        Address::new(n).unwrap()
    }

    /// Manual ch. 5.3 example: the MOVLNK read of index 8318 (speed) at SBus address 1
    /// answered with 1 000 000 (1000.000 1/min). The request has 8 bytes, the reserved byte 1
    /// included (ch. 5.2; ch. 5.1 lists only seven: erratum SB-E2).
    #[test]
    fn manual_5_3_read_8318_sb_e2() {
        let req = Telegram::ParamRequest {
            address: a(1),
            channel: ParamChannel::read(8318),
        };
        let f = req.encode(0);
        assert_eq!(f.raw_id(), 523);
        assert_eq!(f.data(), &[0x31, 0x00, 0x20, 0x7E, 0, 0, 0, 0]);
        let answer = CanFrame::standard(524, &[0x31, 0x00, 0x20, 0x7E, 0x00, 0x0F, 0x42, 0x40]);
        match Telegram::decode(&answer.unwrap(), 0).unwrap() {
            Telegram::ParamResponse { address, channel } => {
                assert_eq!(address, a(1));
                assert!(req_answered(&channel));
                assert_eq!(channel.result(), Ok(1_000_000));
            }
            other => panic!("{other:?}"),
        }
        // Seven bytes (the layout of ch. 5.1) are refused, with what was expected.
        let seven = CanFrame::standard(523, &[0x31, 0x20, 0x7E, 0, 0, 0, 0]).unwrap();
        assert_eq!(
            Telegram::decode(&seven, 0),
            Err(DecodeError::Length {
                kind: Kind::ParamRequest,
                expected: 8,
                got: 7
            })
        );
    }

    fn req_answered(ch: &ParamChannel) -> bool {
        ParamChannel::read(8318).is_answered_by(ch)
    }

    /// Manual ch. 5.2 "Sonderfälle": the answer to a wrong management byte is class 5 code 5;
    /// it travels as an ordinary response with the status bit.
    #[test]
    fn error_response_carries_the_return_code() {
        let req = ParamChannel::request(Service::Read, 8318, 0);
        let rc = ReturnCode::from_data(0x0505_0000);
        let t = Telegram::ParamResponse {
            address: a(7),
            channel: req.answer(Err(rc)),
        };
        let f = t.encode(0);
        assert_eq!(f.raw_id(), 8 * 7 + 512 + 4);
        assert_eq!(f.data(), &[0xB1, 0, 0x20, 0x7E, 5, 5, 0, 0]);
        assert_eq!(Telegram::decode(&f, 0), Ok(t));
    }

    #[test]
    fn sync_id_and_refusals_sb_e3() {
        let sync = CanFrame::standard(0, &[]).unwrap();
        assert_eq!(Telegram::decode(&sync, 0), Ok(Telegram::Sync));
        // With P817 = 1000 the frame on 0 is nothing of SBus's.
        assert_eq!(
            Telegram::decode(&sync, 1000),
            Err(DecodeError::NotSbus { id: 0 })
        );
        assert_eq!(Telegram::Sync.encode(1000).raw_id(), 1000);
        // SB-E3: the parameter identifiers follow the SBus address, not the sync identifier.
        for sync in [0, 1000, 2047] {
            let req = Telegram::ParamRequest {
                address: a(1),
                channel: ParamChannel::read(8318),
            };
            assert_eq!(req.encode(sync).raw_id(), 523);
            assert_eq!(Telegram::decode(&req.encode(sync), sync), Ok(req));
        }
        let remote = CanFrame::remote_frame(StandardId::new(267).unwrap(), 6).unwrap();
        assert_eq!(
            Telegram::decode(&remote, 0),
            Err(DecodeError::Remote { id: 267 })
        );
        let ext =
            CanFrame::data_frame(drive_core::can::ExtendedId::new(267).unwrap(), &[0; 6]).unwrap();
        assert_eq!(
            Telegram::decode(&ext, 0),
            Err(DecodeError::ExtendedId { id: 267 })
        );
        // Bit 10 set: reserved.
        let reserved = CanFrame::standard(1024 + 267, &[0; 6]).unwrap();
        assert_eq!(
            Telegram::decode(&reserved, 0),
            Err(DecodeError::NotSbus { id: 1291 })
        );
        // Process data are always three words.
        let short = CanFrame::standard(267, &[0; 4]).unwrap();
        assert_eq!(
            Telegram::decode(&short, 0),
            Err(DecodeError::Length {
                kind: Kind::ProcessOutput,
                expected: 6,
                got: 4
            })
        );
    }

    fn any_telegram() -> impl Strategy<Value = Telegram> {
        let addr = (0u8..=63).prop_map(a);
        let pd = any::<[u16; 3]>().prop_map(ProcessData);
        let ch = any::<[u8; 8]>().prop_map(ParamChannel::from_bytes);
        prop_oneof![
            Just(Telegram::Sync),
            (addr.clone(), any::<bool>(), pd.clone()).prop_map(|(address, synchronised, data)| {
                Telegram::ProcessOutput {
                    address,
                    synchronised,
                    data,
                }
            }),
            (addr.clone(), pd.clone())
                .prop_map(|(address, data)| Telegram::ProcessInput { address, data }),
            (addr.clone(), pd)
                .prop_map(|(group, data)| Telegram::GroupProcessOutput { group, data }),
            (addr.clone(), ch.clone())
                .prop_map(|(address, channel)| Telegram::ParamRequest { address, channel }),
            (addr.clone(), ch.clone())
                .prop_map(|(address, channel)| Telegram::ParamResponse { address, channel }),
            (addr, ch).prop_map(|(group, channel)| Telegram::GroupParamRequest { group, channel }),
        ]
    }

    proptest! {
        #[test]
        fn encode_decode_round_trip(t in any_telegram(), sync in 1024u16..2048) {
            // A sync identifier with bit 10 set never collides with an SBus identifier.
            prop_assert_eq!(Telegram::decode(&t.encode(sync), sync), Ok(t));
        }

        #[test]
        fn decode_never_panics(id in 0u16..2048, data in proptest::collection::vec(any::<u8>(), 0..=8), sync in 0u16..2048) {
            let f = CanFrame::standard(id, &data).unwrap();
            if let Ok(t) = Telegram::decode(&f, sync) {
                // Whatever decodes re-encodes to the same frame (SYNC: to its identifier).
                let back = t.encode(sync);
                prop_assert_eq!(back.raw_id(), u32::from(id));
                if t != Telegram::Sync {
                    prop_assert_eq!(back, f);
                }
            }
        }
    }
}
