//! A NORD drive in memory behind both NORD channels (parameters and process data), for tests
//! of work over `NordClient`: parameters by PNU and IND with the table's access and range, an
//! order answered only after a number of further requests (the drive repeats its previous
//! answer meanwhile, as a slow drive does), and a state machine that follows the manual's
//! transition table with an instant ramp.

use std::collections::HashMap;

use ctt2_uss::client::{ParameterChannel, ProcessChannel};
use ctt2_uss::uss::DriveError;
use ctt2_uss::uss::pkw::{Order, OrderKind, Pkw, Reply};
use ctt2_uss::uss::pzd::{PzdIn, PzdOut};
use drive_profile::nord::{self, ControlWord, State, StatusWord};

/// The fake transport's only error: the line is dead.
#[derive(Debug)]
pub struct Dead;

impl std::fmt::Display for Dead {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("no answer from the fake drive")
    }
}

impl std::error::Error for Dead {}

/// The drive; see the [module docs](self). `Fake::default()` is in switch-on disabled, every
/// value 0, answering at once.
#[derive(Debug, Default)]
pub struct Fake {
    /// The parameters by (PNU, IND); an unset one reads 0.
    pub values: HashMap<(u16, u16), i32>,
    /// Every parameter channel the master sent (submit and poll).
    pub sent: Vec<Pkw>,
    /// The answer the drive repeats until it has executed the next order.
    pub answer: Pkw,
    /// The order not yet executed, with the requests still to wait.
    pub pending: Option<(Pkw, u8)>,
    /// Further requests before an order is answered.
    pub delay: u8,
    /// The drive's state (`None`: switch-on disabled).
    pub state: Option<State>,
    /// The last control word with bit 10 set.
    pub last_control: u16,
    /// Every control word and setpoint sent with bit 10 set.
    pub controls: Vec<(u16, Vec<u16>)>,
    /// The line dies after this many process exchanges.
    pub process_dies_after: Option<usize>,
    /// Process exchanges so far.
    pub exchanges: usize,
}

/// The status word the fake answers in `state` (bus control set).
pub fn status_of(state: State) -> u16 {
    nord::state_info(state).map_or(0, |i| i.value) | StatusWord::BUS_CONTROL.0
}

impl Fake {
    fn execute(&mut self, pkw: Pkw) -> Pkw {
        let Ok(order) = Order::from_pkw(&pkw) else {
            return Reply::Error(DriveError(201)).to_pkw(pkw.pke.pnu(), pkw.ind);
        };
        let reply = self.reply(&order);
        reply.to_pkw(order.pnu(), order.ind())
    }

    fn reply(&mut self, order: &Order) -> Reply {
        if order.kind() == OrderKind::None {
            return Reply::None;
        }
        let Some(p) = nord::by_index(order.pnu()) else {
            return Reply::Error(DriveError(0));
        };
        let key = (order.pnu(), order.ind().0);
        match order.kind() {
            OrderKind::None => Reply::None,
            OrderKind::Count => Reply::Count(u16::from(p.array_len.unwrap_or(0))),
            OrderKind::Read { array } => Reply::Value {
                width: nord::Width::Word,
                array,
                value: *self.values.get(&key).unwrap_or(&0),
            },
            OrderKind::Write {
                array,
                value,
                width,
                ..
            } => {
                if !p.access.is_writable() {
                    return Reply::Error(DriveError(1));
                }
                if let Some((lo, hi)) = p.raw_range
                    && (i64::from(value) < lo || i64::from(value) > hi)
                {
                    return Reply::Error(DriveError(2));
                }
                self.values.insert(key, value);
                Reply::Value {
                    width,
                    array,
                    value,
                }
            }
        }
    }

    fn answer_now(&mut self) -> Pkw {
        if let Some((pkw, left)) = self.pending {
            if left == 0 {
                self.answer = self.execute(pkw);
                self.pending = None;
            } else {
                self.pending = Some((pkw, left - 1));
            }
        }
        self.answer
    }

    /// AK, PNU, IND and PWE2 of every order sent, without the repeats of one order.
    pub fn orders(&self) -> Vec<(u8, u16, u16, u16)> {
        let mut v: Vec<(u8, u16, u16, u16)> = self
            .sent
            .iter()
            .map(|p| (p.pke.ak(), p.pke.pnu(), p.ind.0, p.pwe2))
            .collect();
        v.dedup();
        v
    }
}

impl ParameterChannel for Fake {
    type Error = Dead;

    async fn submit(&mut self, order: Pkw) -> Result<Pkw, Dead> {
        self.sent.push(order);
        self.pending = Some((order, self.delay));
        Ok(self.answer_now())
    }

    async fn poll(&mut self, order: Pkw) -> Result<Pkw, Dead> {
        self.sent.push(order);
        Ok(self.answer_now())
    }
}

impl ProcessChannel for Fake {
    type Error = Dead;

    async fn exchange_process(&mut self, out: PzdOut, actuals: u8) -> Result<PzdIn, Dead> {
        self.exchanges += 1;
        if self.process_dies_after.is_some_and(|n| self.exchanges > n) {
            return Err(Dead);
        }
        let mut state = self.state.unwrap_or(State::SwitchOnDisabled);
        let word = out.control().0;
        if word & ControlWord::CONTROL_DATA_VALID.0 != 0 {
            self.controls.push((word, out.setpoints().to_vec()));
            // The fake's ramp is instant: a stop reaches 0 Hz at once.
            if let Some(t) = nord::transitions()
                .iter()
                .find(|t| t.from == Some(state) && t.triggered_by(self.last_control, word))
            {
                state = t.to;
            }
            if state == State::QuickStopActive {
                state = State::SwitchOnDisabled;
            }
            self.last_control = word;
        }
        self.state = Some(state);
        let iw1 = if state == State::OperationEnabled {
            self.controls
                .last()
                .and_then(|(_, s)| s.first().copied())
                .unwrap_or(0)
        } else {
            0
        };
        let values = [iw1, 0, 0];
        Ok(PzdIn::new(
            StatusWord(status_of(state)),
            values.get(..usize::from(actuals.min(3))).unwrap_or(&[]),
        ))
    }
}
