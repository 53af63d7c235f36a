//! MOVILINK's framing on the shared character receiver.
//!
//! The receiver itself is [`drive_core::Receiver`]; this module only describes MOVILINK's
//! telegrams to it ([`TelegramFraming`]):
//!
//! * a telegram starts only with the expected start character (SD1 on the drive side, SD2 on
//!   the master side) after the line was idle for a start pause; the other direction's start
//!   character is ignored, anything else is a [`RejectReason::BadStartCharacter`];
//! * byte 2 (the address) must pass the [`AddressFilter`], byte 3 (the PDU type) must be one
//!   of the 14 types and gives the telegram's length;
//! * a complete telegram is checked with its BCC and decoded ([`codec::decode`]);
//! * every other receive error of the manual's list (ch. 4.2): parity and framing errors, an
//!   inter-character gap of a start pause or more, and a character right after the BCC before a
//!   start pause of silence confirmed the telegram's end ([`RejectReason::TrailingCharacter`],
//!   which is how a character inserted by noise is caught: without this check, an inserted
//!   character inside a telegram shifts the real BCC out of it and the XOR check passes with
//!   probability 1/256).
//!
//! Confirmation is reported by [`Receiver::handle_timeout`] at the time of
//! [`Receiver::poll_timeout`], which is when a response or the next request may start anyway,
//! so the check does not lengthen an exchange. Memory is one 18-byte buffer; no input makes it
//! panic.

use crate::codec;
use crate::error::RejectReason;
use crate::frame::{Address, Direction, MAX_TELEGRAM_LEN, PduType, Telegram};
use crate::timing::LineTiming;
use drive_core::framing::{FrameTiming, Framing, Progress, Start};

pub use drive_core::{CharError, RxChar};

/// The character receiver for MOVILINK telegrams.
///
/// ```
/// use movilink::receiver::{Receiver, RxChar, RxEvent, TelegramFraming};
/// use movilink::timing::Instant;
/// use movilink::Address;
/// let mut rx = Receiver::new(TelegramFraming::slave(Address::new(1).unwrap(), Address::NO_GROUP));
/// let bytes = [0x02, 0x01, 0x05, 0x00, 0x06, 0x3A, 0x98, 0x01, 0xF4, 0x57];
/// for (i, b) in bytes.iter().enumerate() {
///     let ev = rx.handle_char(RxChar::new(*b, Instant::from_micros(1146 * (i as u64 + 1))));
///     assert_eq!(ev, None);
/// }
/// // The telegram is complete; it is accepted once the line stayed quiet after its BCC.
/// let confirm = rx.poll_timeout().unwrap();
/// assert_eq!(confirm, Instant::from_micros(1146 * 10 + 3440));
/// let ev = rx.handle_timeout(confirm);
/// assert!(matches!(ev, Some(RxEvent::Frame(t)) if t.process_data() == [6, 0x3A98, 0x01F4]));
/// ```
pub type Receiver = drive_core::Receiver<TelegramFraming, MAX_TELEGRAM_LEN>;

/// What a received character completed: [`RxEvent::Frame`] with a valid telegram of the
/// expected direction for an accepted address, or [`RxEvent::Rejected`] with the reason
/// characters were dropped.
pub type RxEvent = drive_core::RxEvent<Telegram, RejectReason>;

/// Which addresses a receiver accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AddressFilter {
    /// Every valid address (0–199, 253–255); for bus monitors.
    Any,
    /// A drive: its own address, its group (unless 100 = no group), 254 and 255.
    Slave {
        /// Own address (P810).
        own: Address,
        /// Group address (P811); [`Address::NO_GROUP`] for none.
        group: Address,
    },
    /// A master waiting for the answer of `expected`. If `expected` is 254 (point-to-point),
    /// a response from any unicast address (0–99) is accepted too, since the drive may answer
    /// with its own address.
    Master {
        /// The address of the request.
        expected: Address,
    },
}

impl AddressFilter {
    /// Whether address byte `address` passes.
    pub const fn accepts(&self, address: u8) -> bool {
        match *self {
            Self::Any => Address::new(address).is_some(),
            Self::Slave { own, group } => {
                address == own.get()
                    || (address == group.get()
                        && group.is_group()
                        && group.get() != Address::NO_GROUP.get())
                    || address == Address::POINT_TO_POINT.get()
                    || address == Address::BROADCAST.get()
            }
            Self::Master { expected } => {
                address == expected.get() || (expected.is_point_to_point() && address <= 99)
            }
        }
    }
}

/// MOVILINK's framing rules for [`drive_core::Receiver`]; see the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TelegramFraming {
    /// Telegrams of this direction are received (requests on the drive side, responses on the
    /// master side).
    pub direction: Direction,
    /// Addresses accepted.
    pub filter: AddressFilter,
    /// The line's times.
    pub timing: LineTiming,
}

impl TelegramFraming {
    /// Telegrams of `direction` from addresses passing `filter`, on a line with `timing`.
    pub const fn new(direction: Direction, filter: AddressFilter, timing: LineTiming) -> Self {
        Self {
            direction,
            filter,
            timing,
        }
    }

    /// A drive's side (requests, SD1) for `own` and `group`, at 9600 8E1.
    pub const fn slave(own: Address, group: Address) -> Self {
        Self::new(
            Direction::Request,
            AddressFilter::Slave { own, group },
            LineTiming::MOVILINK,
        )
    }

    /// A master's side (responses, SD2) accepting `expected`, at 9600 8E1.
    pub const fn master(expected: Address) -> Self {
        Self::new(
            Direction::Response,
            AddressFilter::Master { expected },
            LineTiming::MOVILINK,
        )
    }

    /// The same framing on a line with `timing`.
    #[must_use]
    pub const fn with_timing(self, timing: LineTiming) -> Self {
        Self { timing, ..self }
    }
}

impl Framing for TelegramFraming {
    type Frame = Telegram;
    type Error = RejectReason;

    fn timing(&self) -> FrameTiming {
        self.timing.frame_timing()
    }

    #[inline]
    fn start(&self, byte: u8) -> Start<RejectReason> {
        if byte == self.direction.start_character() {
            Start::Begin
        } else if Direction::from_start_character(byte).is_some() {
            // Traffic of the other direction: not for us, not an error.
            Start::Ignore
        } else {
            Start::Reject(RejectReason::BadStartCharacter { byte })
        }
    }

    #[inline]
    fn progress(&self, frame: &[u8]) -> Progress<RejectReason> {
        match *frame {
            [_, address] if !self.filter.accepts(address) => {
                Progress::Reject(RejectReason::WrongAddress { address })
            }
            [_, _, typ, ..] => match PduType::new(typ) {
                None => Progress::Reject(RejectReason::UnknownPduType { pdu_type: typ }),
                Some(t) => Progress::Length(t.telegram_len()),
            },
            _ => Progress::More,
        }
    }

    #[inline]
    fn decode(&self, frame: &[u8]) -> Result<Telegram, RejectReason> {
        codec::decode(frame)
            .map(|(t, _)| t)
            .map_err(RejectReason::from)
    }
}
