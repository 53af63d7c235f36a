//! The wire time of one transaction on each protocol, from the real codecs' encoded lengths
//! and the line's character time ([`LineSettings::char_time`]), without opening anything; and a
//! bus's demand: the share of the wire its configured polls ask for.
//!
//! | protocol | one transaction |
//! |---|---|
//! | MOVILINK | start pause + request + start pause (the drive's answer delay) + answer |
//! | USS | 2 × (start delay + request + response delay + answer): a NORD read or write may need a "no order" telegram before the order |
//! | Modbus RTU | t3.5 + request + max(answer delay 10 ms, t3.5) + answer |
//! | Modbus ASCII | request + answer delay 10 ms + answer |
//! | SBus | request frame + answer frame ([`drive_core::can::CanFrame::duration`]) |
//! | CTT2 | a parameter order: NORD write of the PKW channel (request + answer) and NORD reads of it (request + answer) until the drive has worked on the order, twice (a "no order" first, as on USS); process data: one NORD write/read of the PZD channel; every byte 16 AS-i cycles of 154 µs × (2 + slaves) (BU 0255 4.4) |

use std::time::Duration;

use bonfiglioli_modbus::framing::Mode;
use ctt2_uss::serial::{Layout, UssAddress, UssTiming};
use drive_core::LineSettings;
use drive_core::can::Bitrate;
use drive_profile::sew::ParamChannel;

use crate::bus::Op;
use crate::config::{Bus, Endpoint, Protocol};

/// What a bus's wire times depend on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WireDesc {
    /// The protocol.
    pub protocol: Protocol,
    /// The serial line (serial protocols; for Modbus with the mode's data bits).
    pub line: LineSettings,
    /// The CAN bit rate (SBus).
    pub bitrate: Bitrate,
    /// The USS telegram layout.
    pub layout: Layout,
    /// CTT2: the AS-i slaves on the network (two per drive's double slave).
    pub asi_slaves: u8,
}

/// The CAN bit rate of an SBus bus: the slcan interface's or the simulated bus's; 500 kbit/s
/// for a SocketCAN interface (its rate is the interface's setting: `ip link`).
pub fn bitrate_of(bus: &Bus) -> Bitrate {
    match &bus.endpoint {
        Endpoint::Simulated { bitrate, .. } => Bitrate::new(*bitrate).unwrap_or(Bitrate::K500),
        Endpoint::Can { bitrate, .. } => Bitrate::new(*bitrate).unwrap_or(Bitrate::K500),
        Endpoint::Serial { .. } => Bitrate::K500,
    }
}

/// The serial line of a bus as its drives speak it (Modbus: the mode's data bits).
pub fn line_of(bus: &Bus) -> LineSettings {
    let line = match &bus.endpoint {
        Endpoint::Serial { line, .. } | Endpoint::Simulated { line, .. } => *line,
        Endpoint::Can { .. } => LineSettings::new(9600),
    };
    match bus.protocol {
        Protocol::ModbusRtu => super::access::modbus_line(Mode::Rtu, line),
        Protocol::ModbusAscii => super::access::modbus_line(Mode::Ascii, line),
        _ => line,
    }
}

impl WireDesc {
    /// The description of `bus`.
    pub fn of(bus: &Bus) -> Self {
        Self {
            protocol: bus.protocol,
            line: line_of(bus),
            bitrate: bitrate_of(bus),
            layout: super::access::uss_layout(bus),
            asi_slaves: super::access::ctt2_network(bus).slave_count(),
        }
    }

    /// The wire time of one transaction of `op` (see the [module docs](self)).
    pub fn time(&self, op: Op) -> Duration {
        match self.protocol {
            Protocol::Movilink => self.movilink(op),
            Protocol::Sbus => self.sbus(op),
            Protocol::Uss => self.uss(),
            Protocol::Ctt2 => self.ctt2(op),
            Protocol::ModbusRtu => self.modbus(Mode::Rtu, op),
            Protocol::ModbusAscii => self.modbus(Mode::Ascii, op),
        }
    }

    fn movilink(&self, op: Op) -> Duration {
        let pdu = match op {
            Op::Read | Op::Write => movilink::PduType::PARAM_0PD_ACYCLIC,
            Op::ProcessData(n) => movilink::PduType::from_layout(false, n.clamp(1, 3), true)
                .unwrap_or(movilink::PduType::PD3),
        };
        let a = movilink::Address::POINT_TO_POINT;
        let request = movilink::Telegram::request(a, pdu).encoded_len();
        let answer = movilink::Telegram::response(a, pdu).encoded_len();
        let t = movilink::timing::LineTiming::new(self.line);
        t.start_pause + t.wire_time(request) + t.start_pause + t.wire_time(answer)
    }

    fn sbus(&self, op: Op) -> Duration {
        use sbus_can::telegram::Telegram;
        let address = sbus_can::Address::new(1).unwrap_or_default();
        let sync = sbus_can::master::MasterConfig::default().sync_id;
        let (request, answer) = match op {
            Op::Read | Op::Write => {
                let channel = ParamChannel::read(drive_profile::sew::index::SPEED);
                (
                    Telegram::ParamRequest { address, channel },
                    Telegram::ParamResponse { address, channel },
                )
            }
            Op::ProcessData(_) => {
                let data = sbus_can::ProcessData([0x0006, 0x1388, 0]);
                (
                    Telegram::ProcessOutput {
                        address,
                        synchronised: false,
                        data,
                    },
                    Telegram::ProcessInput { address, data },
                )
            }
        };
        request.encode(sync).duration(self.bitrate) + answer.encode(sync).duration(self.bitrate)
    }

    fn uss(&self) -> Duration {
        let timing = UssTiming::from_line(&self.line);
        let mut buf = [0u8; ctt2_uss::serial::telegram::MAX_TELEGRAM];
        let Some(a) = UssAddress::new(0) else {
            return Duration::ZERO;
        };
        let adr = ctt2_uss::serial::Adr::new(a);
        let chars = ctt2_uss::serial::Telegram::new(adr, self.layout, Default::default(), &[])
            .ok()
            .and_then(|t| t.encode(&mut buf).ok())
            .unwrap_or(self.layout.telegram_len());
        let delay = ctt2_uss::serial::slave::SlaveConfig::new(a, self.layout, self.line)
            .response_delay
            .max(timing.start_delay);
        let one =
            timing.start_delay + self.line.wire_time(chars) + delay + self.line.wire_time(chars);
        one * 2
    }

    /// CTT2 on the simulated AS-i link (see [`ctt2_uss::ctt2::link`]): request bytes × byte
    /// time, the double slave's answer (at once in the simulation), answer bytes × byte time.
    /// A parameter order is handed over with a NORD write of the PKW channel and read back with
    /// NORD reads; the drive works on it for [`SIM_PKW_TIME`](ctt2_uss::ctt2::link::SIM_PKW_TIME)
    /// (the simulator's figure: the manual says only "low priority"), and a read before that
    /// returns the previous answer, so the client reads again.
    fn ctt2(&self, op: Op) -> Duration {
        use ctt2_uss::ctt2::message::{Channel, Data, Request, Response};
        use ctt2_uss::uss::pkw::PKW_LEN;
        let byte = Duration::from_micros(u64::from(drive_profile::nord::ctt2_byte_time_us(
            self.asi_slaves,
        )));
        let bytes = |n: usize| byte.saturating_mul(u32::try_from(n).unwrap_or(u32::MAX));
        let ok = |n: usize| Response::Ok {
            kind: drive_profile::nord::Ctt2MessageType::NordRead,
            data: [0u8; 14].get(..n).and_then(Data::new).unwrap_or_default(),
        };
        match op {
            Op::Read | Op::Write => {
                let pkw = Data::new(&[0; PKW_LEN]).unwrap_or_default();
                let write = Request::NordWrite {
                    index: Channel::Pkw,
                    data: pkw,
                }
                .encoded_len()
                    + ok(0).encoded_len();
                let read_request = Request::NordRead {
                    index: Channel::Pkw,
                    len: PKW_LEN as u8,
                }
                .encoded_len();
                let read = read_request + ok(PKW_LEN).encoded_len();
                // The order reaches the drive at the end of the write's request; a read sees
                // its answer when the drive was done by the end of that read's request.
                let mut since_order = ok(0).encoded_len() + read_request;
                let mut reads = 1;
                while bytes(since_order) < ctt2_uss::ctt2::link::SIM_PKW_TIME && reads < 50 {
                    since_order += read;
                    reads += 1;
                }
                // A read or write of the parameter the previous order had needs a "no order"
                // first (answered at once), as on USS (erratum E21): counted, the worst case.
                bytes(write + read + write + read * reads)
            }
            Op::ProcessData(n) => {
                // Address 1, the control word and the setpoints; the answer: address 1, the
                // status word and as many actual values.
                let words = usize::from(n.clamp(1, 4));
                let request = 4 + 1 + 2 * words;
                let answer = ok(1 + 2 * words).encoded_len();
                bytes(request + answer)
            }
        }
    }

    fn modbus(&self, mode: Mode, op: Op) -> Duration {
        use bonfiglioli_modbus::frame::{Address, DataSet, Request, Response, StartAddress};
        use bonfiglioli_modbus::framing::{MAX_FRAME, ModbusFraming, Side};
        let timing = ModbusFraming::new(mode, Side::Master, &self.line).timing();
        let (Some(a), Some(start)) = (Address::new(1), StartAddress::new(DataSet::ALL, 420)) else {
            return Duration::ZERO;
        };
        let pairs = match op {
            Op::Write => [
                (
                    Request::WriteWord { start, value: 0 },
                    Response::WriteWord { start, value: 0 },
                ),
                (
                    Request::WriteLong { start, value: 0 },
                    Response::WriteLong { start, value: 0 },
                ),
            ],
            _ => [
                (
                    Request::ReadWord { start, count: 1 },
                    Response::ReadWord { value: 0 },
                ),
                (Request::ReadLong { start }, Response::ReadLong { value: 0 }),
            ],
        };
        let mut buf = [0u8; MAX_FRAME];
        let mut longest = 0;
        for (q, r) in pairs {
            let ql =
                bonfiglioli_modbus::framing::encode_request(mode, a, &q, &mut buf).unwrap_or(0);
            let rl =
                bonfiglioli_modbus::framing::encode_response(mode, a, &r, &mut buf).unwrap_or(0);
            longest = longest.max(ql + rl);
        }
        let delay = bonfiglioli_modbus::slave::ANSWER_DELAY.max(timing.start_gap);
        timing.start_gap + self.line.wire_time(longest) + delay
    }
}

/// The share of the wire (0–1, above 1: more than the wire carries) `bus`'s configuration asks
/// for: every polled point once per period, every drive's process data once per period and
/// its fault once per `status_period`, each at the wire time of its transaction.
pub fn demand(bus: &Bus) -> f64 {
    let w = WireDesc::of(bus);
    let share = |op: Op, period: Duration| {
        if period.is_zero() {
            f64::INFINITY
        } else {
            w.time(op).as_secs_f64() / period.as_secs_f64()
        }
    };
    let mut total = 0.0;
    for d in &bus.drives {
        total += share(Op::Read, bus.status_period);
        for p in &d.points {
            if let Some(period) = p.period {
                total += share(Op::Read, period);
            }
        }
        if let Some(pd) = &d.process_data {
            let n = u8::try_from(pd.out.len()).unwrap_or(u8::MAX);
            total += share(Op::ProcessData(n), pd.period);
        }
    }
    total
}
