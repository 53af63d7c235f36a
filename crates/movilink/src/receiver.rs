//! Character-level framing: finds telegrams in a stream of received characters.
//!
//! A telegram starts only with the expected start character (SD1 on the drive side, SD2 on the
//! master side) after the line was idle for at least a start pause. Every receive error of
//! the manual's list (ch. 4.2) rejects the telegram with a [`RejectReason`]: parity and framing
//! errors, an inter-character gap of a start pause or more, a wrong address, an unknown PDU
//! type and a wrong BCC. After a rejection (or a complete telegram) the receiver ignores
//! characters until the next idle gap, then resynchronises on the next start character.
//!
//! A telegram is accepted only once its end is confirmed: after its last character (the BCC)
//! the line must stay quiet until a start pause after that character's end, i.e. no further
//! character may have started within start pause − one character time (two character times at
//! MOVILINK timing). A character arriving earlier rejects the telegram with
//! [`RejectReason::TrailingCharacter`]: the telegram on the wire was longer than its PDU type
//! says, which is how a character inserted by noise is caught (without this check, an inserted
//! character inside a telegram shifts the real BCC out of it and the XOR check passes with
//! probability 1/256). Confirmation is reported by [`Receiver::handle_timeout`] at the time of
//! [`Receiver::poll_timeout`], which is when a response or the next request may start anyway,
//! so the check does not lengthen an exchange.
//!
//! Memory is one 18-byte buffer; no input makes it panic.

use crate::codec;
use crate::error::{CharError, RejectReason};
use crate::frame::{Address, Direction, MAX_TELEGRAM_LEN, PduType, Telegram};
use crate::timing::{Instant, LineTiming};

/// One character from the UART.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct RxChar {
    /// The data byte.
    pub byte: u8,
    /// When the character was completely received (end of its stop bit).
    pub time: Instant,
    /// A UART error flagged for this character.
    pub error: Option<CharError>,
}

impl RxChar {
    /// A character received without error.
    pub const fn new(byte: u8, time: Instant) -> Self {
        Self {
            byte,
            time,
            error: None,
        }
    }

    /// A character received with `error`.
    pub const fn with_error(byte: u8, time: Instant, error: CharError) -> Self {
        Self {
            byte,
            time,
            error: Some(error),
        }
    }
}

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

/// What a received character completed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RxEvent {
    /// A valid telegram of the expected direction for an accepted address.
    Telegram(Telegram),
    /// Characters were dropped; see the reason.
    Rejected(RejectReason),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    /// Waiting for a start character after an idle gap.
    Idle,
    /// Collecting a telegram: `len` bytes so far, `expected` total once the type is known.
    Receiving { len: u8, expected: u8 },
    /// All characters of a valid telegram arrived; waiting for the quiet line after its BCC.
    Complete { telegram: Telegram },
}

/// The framing state machine; see the [module docs](self).
///
/// ```
/// use movilink::receiver::{Receiver, RxChar, RxEvent};
/// use movilink::timing::Instant;
/// use movilink::Address;
/// let mut rx = Receiver::for_slave(Address::new(1).unwrap(), Address::NO_GROUP);
/// let bytes = [0x02, 0x01, 0x05, 0x00, 0x06, 0x3A, 0x98, 0x01, 0xF4, 0x57];
/// for (i, b) in bytes.iter().enumerate() {
///     let ev = rx.handle_char(RxChar::new(*b, Instant::from_micros(1146 * (i as u64 + 1))));
///     assert_eq!(ev, None);
/// }
/// // The telegram is complete; it is accepted once the line stayed quiet after its BCC.
/// let confirm = rx.poll_timeout().unwrap();
/// assert_eq!(confirm, Instant::from_micros(1146 * 10 + 3440));
/// let ev = rx.handle_timeout(confirm);
/// assert!(matches!(ev, Some(RxEvent::Telegram(t)) if t.process_data() == [6, 0x3A98, 0x01F4]));
/// ```
#[derive(Debug, Clone)]
pub struct Receiver {
    direction: Direction,
    filter: AddressFilter,
    char_us: u64,
    pause_us: u64,
    /// Longest accepted gap inside a telegram (≥ `pause_us`).
    max_gap_us: u64,
    state: State,
    last: Option<Instant>,
    buf: [u8; MAX_TELEGRAM_LEN],
}

impl Receiver {
    /// A receiver for telegrams of `direction` (requests on the drive side, responses on the
    /// master side) from addresses passing `filter`.
    pub fn new(direction: Direction, filter: AddressFilter, timing: LineTiming) -> Self {
        let (char_us, pause_us) = timing.micros();
        Self {
            direction,
            filter,
            char_us,
            pause_us,
            max_gap_us: timing.max_gap_micros(),
            state: State::Idle,
            last: None,
            buf: [0; MAX_TELEGRAM_LEN],
        }
    }

    /// A drive-side receiver (requests, SD1) for `own` and `group` with MOVILINK timing.
    pub fn for_slave(own: Address, group: Address) -> Self {
        Self::new(
            Direction::Request,
            AddressFilter::Slave { own, group },
            LineTiming::MOVILINK,
        )
    }

    /// A master-side receiver (responses, SD2) accepting `expected` with MOVILINK timing.
    pub fn for_master(expected: Address) -> Self {
        Self::new(
            Direction::Response,
            AddressFilter::Master { expected },
            LineTiming::MOVILINK,
        )
    }

    /// Change the address filter (takes effect with the next telegram's address byte).
    pub fn set_filter(&mut self, filter: AddressFilter) {
        self.filter = filter;
    }

    /// The address filter.
    pub fn filter(&self) -> AddressFilter {
        self.filter
    }

    /// Drop a partial telegram and forget the line history: the next expected start
    /// character starts a telegram even without a preceding idle gap.
    pub fn reset(&mut self) {
        self.state = State::Idle;
        self.last = None;
    }

    /// Whether a telegram is being received (including a complete one whose end is not yet
    /// confirmed by the quiet line after it).
    pub fn is_receiving(&self) -> bool {
        matches!(self.state, State::Receiving { .. } | State::Complete { .. })
    }

    /// Time of the last character seen.
    pub fn last_char_time(&self) -> Option<Instant> {
        self.last
    }

    /// Feed one character; returns a completed or rejected telegram.
    pub fn handle_char(&mut self, c: RxChar) -> Option<RxEvent> {
        let gap = self.last.map(|prev| self.gap_us(prev, c.time));
        let idle = gap.is_none_or(|g| g >= self.pause_us);
        // Inside a telegram the gap limit may be wider than the start pause (LineTiming::max_gap).
        let broke_off = gap.is_none_or(|g| g >= self.max_gap_us);
        self.last = Some(match self.last {
            Some(prev) if prev > c.time => prev,
            _ => c.time,
        });
        match self.state {
            State::Receiving { len, .. } if broke_off => {
                // The telegram broke off; this character may start the next one.
                self.state = State::Idle;
                let _ = self.start(c);
                Some(RxEvent::Rejected(RejectReason::InterCharacterGap {
                    received: len,
                }))
            }
            State::Receiving { len, expected } => self.continue_with(c, len, expected),
            State::Complete { telegram } if idle => {
                // The confirmation was not polled in time, but the line was quiet long enough:
                // the telegram stands, and this character may start the next one.
                self.state = State::Idle;
                let _ = self.start(c);
                Some(RxEvent::Telegram(telegram))
            }
            State::Complete { .. } => {
                // A character right after the BCC: the telegram was longer than its type says.
                self.state = State::Idle;
                Some(RxEvent::Rejected(RejectReason::TrailingCharacter {
                    byte: c.byte,
                }))
            }
            State::Idle if idle => self.start(c),
            State::Idle => None,
        }
    }

    /// Feed characters, calling `on_event` for each event.
    pub fn handle_chars(&mut self, chars: &[RxChar], mut on_event: impl FnMut(RxEvent)) {
        for c in chars {
            if let Some(ev) = self.handle_char(*c) {
                on_event(ev);
            }
        }
    }

    /// Tell the receiver the time is `now` without a new character: a complete telegram
    /// followed by a quiet line until a start pause after its last character is accepted; a
    /// partial telegram whose inter-character gap reached [`LineTiming::max_gap`] (a start
    /// pause by default) is rejected.
    pub fn handle_timeout(&mut self, now: Instant) -> Option<RxEvent> {
        let last = self.last?;
        if let State::Complete { telegram } = self.state {
            if now.as_micros().saturating_sub(last.as_micros()) >= self.pause_us {
                self.state = State::Idle;
                return Some(RxEvent::Telegram(telegram));
            }
            return None;
        }
        let State::Receiving { len, .. } = self.state else {
            return None;
        };
        if self.gap_us(last, now) >= self.max_gap_us {
            self.state = State::Idle;
            Some(RxEvent::Rejected(RejectReason::InterCharacterGap {
                received: len,
            }))
        } else {
            None
        }
    }

    /// When [`Receiver::handle_timeout`] will accept the complete telegram or reject the
    /// partial one, if one is in progress.
    pub fn poll_timeout(&self) -> Option<Instant> {
        match (self.state, self.last) {
            (State::Receiving { .. }, Some(last)) => {
                Some(last.plus_micros(self.char_us + self.max_gap_us))
            }
            (State::Complete { .. }, Some(last)) => Some(last.plus_micros(self.pause_us)),
            _ => None,
        }
    }

    /// Idle time between a character completed at `prev` and one completed at `now`.
    fn gap_us(&self, prev: Instant, now: Instant) -> u64 {
        now.as_micros()
            .saturating_sub(prev.as_micros())
            .saturating_sub(self.char_us)
    }

    fn start(&mut self, c: RxChar) -> Option<RxEvent> {
        if let Some(e) = c.error {
            return Some(RxEvent::Rejected(e.into()));
        }
        if c.byte == self.direction.start_character() {
            self.buf[0] = c.byte;
            self.state = State::Receiving {
                len: 1,
                expected: 0,
            };
            None
        } else if Direction::from_start_character(c.byte).is_some() {
            // Traffic of the other direction: not for us, not an error.
            None
        } else {
            Some(RxEvent::Rejected(RejectReason::BadStartCharacter {
                byte: c.byte,
            }))
        }
    }

    fn continue_with(&mut self, c: RxChar, len: u8, expected: u8) -> Option<RxEvent> {
        if let Some(e) = c.error {
            self.state = State::Idle;
            return Some(RxEvent::Rejected(e.into()));
        }
        let Some(slot) = self.buf.get_mut(usize::from(len)) else {
            self.state = State::Idle;
            return None;
        };
        *slot = c.byte;
        let len = len + 1;
        let mut expected = expected;
        match len {
            2 if !self.filter.accepts(c.byte) => {
                self.state = State::Idle;
                return Some(RxEvent::Rejected(RejectReason::WrongAddress {
                    address: c.byte,
                }));
            }
            3 => match PduType::new(c.byte) {
                Some(t) => expected = t.telegram_len() as u8,
                None => {
                    self.state = State::Idle;
                    return Some(RxEvent::Rejected(RejectReason::UnknownPduType {
                        pdu_type: c.byte,
                    }));
                }
            },
            _ => {}
        }
        if len == expected {
            let frame = self.buf.get(..usize::from(len)).unwrap_or(&[]);
            return match codec::decode(frame) {
                Ok((telegram, _)) => {
                    self.state = State::Complete { telegram };
                    None
                }
                Err(e) => {
                    self.state = State::Idle;
                    Some(RxEvent::Rejected(e.into()))
                }
            };
        }
        self.state = State::Receiving { len, expected };
        None
    }
}
