//! A complete telegram: direction (start character), address, PDU type and PDU.

use super::{Address, ParamChannel, PduType};

/// Request start character SD1 (master → drive).
pub const SD1: u8 = 0x02;
/// Response start character SD2 (drive → master).
pub const SD2: u8 = 0x1D;
/// Longest telegram: PARAM + 3PD, 18 bytes.
pub const MAX_TELEGRAM_LEN: usize = 18;
/// Shortest telegram: 1PD, 6 bytes.
pub const MIN_TELEGRAM_LEN: usize = 6;

/// Direction of a telegram, given by its start character.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// SD1 = 0x02: request, master → drive.
    Request,
    /// SD2 = 0x1D: response, drive → master.
    Response,
}

impl Direction {
    /// The start character.
    pub const fn start_character(self) -> u8 {
        match self {
            Self::Request => SD1,
            Self::Response => SD2,
        }
    }

    /// The direction of start character `byte`.
    pub const fn from_start_character(byte: u8) -> Option<Self> {
        match byte {
            SD1 => Some(Self::Request),
            SD2 => Some(Self::Response),
            _ => None,
        }
    }
}

/// A MOVILINK telegram (without the start pause and the BCC, which the codec adds).
///
/// The PDU type decides which parts exist: [`Telegram::param`] is `None` for PD-only types and
/// [`Telegram::process_data`] has exactly [`PduType::pd_words`] words. Parts the PDU type does
/// not carry are kept zero, so `==` compares what goes on the wire.
///
/// ```
/// use movilink::{Address, ParamChannel, PduType, Telegram};
/// let t = Telegram::request(Address::new(1).unwrap(), PduType::PARAM_1PD_ACYCLIC)
///     .with_param(ParamChannel::read(8318))
///     .with_process_data(&[0x0006]);
/// assert_eq!(t.param(), Some(ParamChannel::read(8318)));
/// assert_eq!(t.process_data(), &[0x0006]);
/// assert_eq!(t.encoded_len(), 14);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Telegram {
    direction: Direction,
    address: Address,
    pdu_type: PduType,
    param: ParamChannel,
    pd: [u16; 3],
}

impl Telegram {
    /// A telegram with a zero parameter channel and zero process data.
    pub const fn new(direction: Direction, address: Address, pdu_type: PduType) -> Self {
        Self {
            direction,
            address,
            pdu_type,
            param: ParamChannel {
                management: super::Management::from_raw(0),
                subindex: 0,
                index: 0,
                data: 0,
            },
            pd: [0; 3],
        }
    }

    /// A request (SD1) to `address`.
    pub const fn request(address: Address, pdu_type: PduType) -> Self {
        Self::new(Direction::Request, address, pdu_type)
    }

    /// A response (SD2) from `address`.
    pub const fn response(address: Address, pdu_type: PduType) -> Self {
        Self::new(Direction::Response, address, pdu_type)
    }

    /// The same telegram with parameter channel `param`; no effect if the PDU type carries no
    /// parameter channel (check [`PduType::has_param`]).
    #[must_use]
    pub const fn with_param(mut self, param: ParamChannel) -> Self {
        if self.pdu_type.has_param() {
            self.param = param;
        }
        self
    }

    /// The same telegram with the process data words `words`: the first
    /// [`PduType::pd_words`] words are taken, missing ones are zero.
    #[must_use]
    pub fn with_process_data(mut self, words: &[u16]) -> Self {
        self.set_process_data(words);
        self
    }

    /// Replace the process data like [`Telegram::with_process_data`].
    pub fn set_process_data(&mut self, words: &[u16]) {
        let mut src = words.iter();
        for w in self.process_data_mut() {
            *w = src.next().copied().unwrap_or(0);
        }
    }

    /// Direction (start character).
    pub const fn direction(&self) -> Direction {
        self.direction
    }

    /// Address byte.
    pub const fn address(&self) -> Address {
        self.address
    }

    /// PDU type.
    pub const fn pdu_type(&self) -> PduType {
        self.pdu_type
    }

    /// The parameter channel, if the PDU type has one.
    pub const fn param(&self) -> Option<ParamChannel> {
        if self.pdu_type.has_param() {
            Some(self.param)
        } else {
            None
        }
    }

    /// The parameter channel for changing, if the PDU type has one.
    pub fn param_mut(&mut self) -> Option<&mut ParamChannel> {
        if self.pdu_type.has_param() {
            Some(&mut self.param)
        } else {
            None
        }
    }

    /// The process data words (0–3).
    pub fn process_data(&self) -> &[u16] {
        self.pd.get(..self.pdu_type.pd_words()).unwrap_or(&[])
    }

    /// The process data words for changing.
    pub fn process_data_mut(&mut self) -> &mut [u16] {
        let n = self.pdu_type.pd_words();
        self.pd.get_mut(..n).unwrap_or(&mut [])
    }

    /// Length on the wire including SD and BCC.
    pub const fn encoded_len(&self) -> usize {
        self.pdu_type.telegram_len()
    }

    /// The same telegram sent to or from `address`.
    #[must_use]
    pub const fn with_address(mut self, address: Address) -> Self {
        self.address = address;
        self
    }
}
