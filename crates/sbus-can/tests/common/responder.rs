//! A minimal sans-IO SBus drive for the master's tests and bench: it answers like the manual's
//! drive (parameter response on 8a + 516 echoing management, subindex and index; PI on 8a + 4;
//! sync-mode answers and the PI of PO sync after the next SYNC). It is not the simulated
//! MOVIDRIVE (that is drive-sim's, at integration); values live in a small table.

use drive_core::Instant;
use drive_core::Queue;
use drive_core::can::{CanEndpoint, CanFrame};
use drive_profile::sew::{ParamChannel, ReturnCode, Service};
use sbus_can::Address;
use sbus_can::telegram::{ProcessData, Telegram};

/// P070 unit type the responder reports.
pub const UNIT_TYPE: u32 = 0x0060_0015;

#[derive(Debug, Clone)]
pub struct Responder {
    pub address: Address,
    pub group: Address,
    pub sync_id: u16,
    /// (index, value) pairs; writes change them.
    pub values: [(u16, u32); 6],
    /// Status word 1 reported as PI1.
    pub status: u16,
    /// Last PO received.
    pub po: ProcessData,
    /// PI reported instead of (status, PO2 echoed, 0).
    pub pi: Option<ProcessData>,
    /// Answers held for the next SYNC.
    pub held: Queue<CanFrame, 4>,
    pub out: Queue<CanFrame, 8>,
    pub requests: u32,
}

impl Responder {
    pub fn new(address: u8) -> Self {
        Self {
            address: Address::new(address).unwrap_or_default(),
            group: Address::default(),
            sync_id: 0,
            values: [
                (8318, 1_000_000),
                (8301, UNIT_TYPE),
                (8319, 50_000),
                (8470, 1000),
                (8517, 1_500_000),
                (0, 0),
            ],
            status: 0x0407,
            po: ProcessData::default(),
            pi: None,
            held: Queue::new(),
            out: Queue::new(),
            requests: 0,
        }
    }

    fn value_mut(&mut self, index: u16) -> Option<&mut u32> {
        self.values
            .iter_mut()
            .find(|(i, _)| *i == index && index != 0)
            .map(|(_, v)| v)
    }

    fn execute(&mut self, ch: &ParamChannel) -> Result<u32, ReturnCode> {
        let Some(service) = ch.service() else {
            return Err(ReturnCode::ILLEGAL_SERVICE_CODING);
        };
        let data = ch.data;
        let read_only = ch.index == 8318 || ch.index == 8301;
        let v = self.value_mut(ch.index).ok_or(ReturnCode::ILLEGAL_INDEX)?;
        match service {
            Service::Read => Ok(*v),
            Service::Write | Service::WriteVolatile if read_only => Err(ReturnCode::READ_ONLY),
            Service::Write | Service::WriteVolatile => {
                *v = data;
                Ok(0)
            }
            Service::ReadMinimum => Ok(0),
            Service::ReadMaximum => Ok(3_000_000),
            Service::ReadDefault => Ok(1000),
            Service::ReadScale => Ok(0x0000_0BFD),
            Service::ReadAttribute => Ok(0x2080_0013),
            _ => Ok(0),
        }
    }

    fn pi(&self) -> ProcessData {
        self.pi
            .unwrap_or(ProcessData([self.status, self.po.0[1], 0]))
    }
}

impl CanEndpoint for Responder {
    fn handle_frame(&mut self, frame: &CanFrame, _now: Instant) {
        let Ok(t) = Telegram::decode(frame, self.sync_id) else {
            return;
        };
        let me = self.address;
        match t {
            Telegram::Sync => {
                while let Some(f) = self.held.pop() {
                    self.out.push(f);
                }
            }
            Telegram::ParamRequest { address, channel } if address == me => {
                self.requests += 1;
                let answer = channel.answer(self.execute(&channel));
                let f = Telegram::ParamResponse {
                    address: me,
                    channel: answer,
                }
                .encode(self.sync_id);
                if channel.management.handshake() {
                    self.held.push(f);
                } else {
                    self.out.push(f);
                }
            }
            Telegram::GroupParamRequest { group, channel }
                if group == self.group && channel.service().is_some_and(Service::is_write) =>
            {
                let _ = self.execute(&channel);
            }
            Telegram::ProcessOutput {
                address,
                synchronised,
                data,
            } if address == me => {
                self.requests += 1;
                self.po = data;
                let f = Telegram::ProcessInput {
                    address: me,
                    data: self.pi(),
                }
                .encode(self.sync_id);
                if synchronised {
                    self.held.push(f);
                } else {
                    self.out.push(f);
                }
            }
            Telegram::GroupProcessOutput { group, data } if group == self.group => self.po = data,
            _ => {}
        }
    }

    fn handle_timeout(&mut self, _now: Instant) {}

    fn poll_transmit(&mut self, _now: Instant) -> Option<CanFrame> {
        self.out.pop()
    }

    fn poll_timeout(&self) -> Option<Instant> {
        None
    }
}
