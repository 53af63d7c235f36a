//! An in-memory AS-i link to a simulated NORDAC LINK (feature `sim`): the double slave
//! ([`DoubleSlave`]) in front of [`SimulatedDoubleSlave`] (the CTT2 front-end on
//! [`drive_sim::nord::SimulatedNord`]), on an [`AsiNetwork`] whose size sets the CTT2 transfer
//! time (section 4.4: 16 × 154 µs × (2 + slaves) per byte), on tokio's clock.
//!
//! [`SimulatedLink`] is a [`Ctt2Link`], so a [`Ctt2Driver`](super::master::Ctt2Driver) and a
//! [`NordClient`](crate::client::NordClient) run on it unchanged. A transaction takes the
//! request's bytes × byte time, then the drive's answer time, then the answer's bytes × byte
//! time. The link keeps that time exactly (tokio's timers tick in whole milliseconds, the byte
//! time does not); [`SimulatedLink::now`] is that time.
//!
//! Knobs for tests: [`SimulatedLink::send`] and [`SimulatedLink::receive`] separately (a second request
//! before the first was answered gets error 5), [`SimulatedDoubleSlave::set_answer_time`]
//! (slower than 200 ms: error 4), [`SimulatedDoubleSlave::set_pkw_time`] (how long the drive
//! works on a parameter order), [`SimulatedLink::exchange_busio`] (one AS-i cycle of the BusIO
//! bits).

use core::time::Duration;

use drive_core::Instant;
use drive_core::rt::{Clock, TIMER_RESOLUTION, Timebase};
use drive_sim::nord::{CONFIGURATION_LEVEL, SimulatedNord};

use super::asi::{
    AsiAddress, AsiNetwork, Bank, BusIoIn, BusIoOut, DoubleSlaveAddress, DoubleSlaveId,
    NetworkError, SlaveAddress,
};
use super::master::Ctt2Link;
use super::message::{MAX_RESPONSE, Request};
use super::object::{DiagnosisCode, DiagnosisObject, IdObject};
use super::slave::{Backend, DoubleSlave, SlaveConfig};
use crate::uss::pkw::{Order, Reply};
use crate::uss::pzd::{PzdIn, PzdOut};
use drive_profile::nord::StatusWord;

/// How long the simulated drive works on a parameter order by default (simulator choice: the
/// manual only says "low priority").
pub const SIM_PKW_TIME: Duration = Duration::from_millis(50);

/// The ID object of the simulated drive (simulator values, except the manufacturer ID of the
/// manual's example: 1, 137).
pub const SIM_ID_OBJECT: [u8; 14] = [
    1,                         // manufacturer ID, high byte (example 4.3.1)
    137,                       // manufacturer ID, low byte
    0x02,                      // device ID, high byte (simulator)
    0x80,                      // device ID, low byte
    0x07,                      // I/O configuration (profile S-7.A.x.x)
    0x01,                      // AS-i mode (simulator)
    0x10,                      // AS-i firmware version (simulator)
    0x01,                      // drive firmware version
    0x00,                      // drive firmware revision
    0x00,                      // power, high byte (simulator: 0.55 kW in 10 W)
    0x37,                      // power, low byte
    0x01,                      // voltage range (simulator)
    0x00,                      // configuration level, high byte
    CONFIGURATION_LEVEL as u8, // configuration level, low byte (P744 of the simulated drive)
];

/// The microcontroller temperature the simulated drive reports (the manual's example: 45).
pub const SIM_TEMPERATURE: u8 = 45;

/// The simulated drive behind the double slave: [`SimulatedNord`] with the ID and diagnosis
/// objects and the timing knobs.
#[derive(Debug)]
pub struct SimulatedDoubleSlave {
    drive: SimulatedNord,
    id: IdObject,
    temperature: u8,
    answer_time: Duration,
    pkw_time: Duration,
}

impl Default for SimulatedDoubleSlave {
    fn default() -> Self {
        Self::new(SimulatedNord::new())
    }
}

impl SimulatedDoubleSlave {
    /// The double slave of `drive`, answering at once and working [`SIM_PKW_TIME`] on a
    /// parameter order.
    pub fn new(drive: SimulatedNord) -> Self {
        Self {
            drive,
            id: IdObject::from_bytes(&SIM_ID_OBJECT),
            temperature: SIM_TEMPERATURE,
            answer_time: Duration::ZERO,
            pkw_time: SIM_PKW_TIME,
        }
    }

    /// The drive.
    pub fn drive(&self) -> &SimulatedNord {
        &self.drive
    }

    /// The drive, mutable.
    pub fn drive_mut(&mut self) -> &mut SimulatedNord {
        &mut self.drive
    }

    /// From a complete request to the start of the answer (longer than 200 ms: error 4).
    pub fn set_answer_time(&mut self, t: Duration) {
        self.answer_time = t;
    }

    /// How long the drive works on a parameter order.
    pub fn set_pkw_time(&mut self, t: Duration) {
        self.pkw_time = t;
    }

    /// The ID object reported.
    pub fn set_id_object(&mut self, id: IdObject) {
        self.id = id;
    }

    /// The microcontroller temperature reported.
    pub fn set_temperature(&mut self, t: u8) {
        self.temperature = t;
    }

    fn pzd_in(&self) -> PzdIn {
        PzdIn::new(
            StatusWord(self.drive.status_word()),
            &self.drive.actual_values(),
        )
    }
}

impl Backend for SimulatedDoubleSlave {
    fn id_object(&mut self, now: Instant) -> IdObject {
        self.drive.tick(now);
        self.id
    }

    fn diagnosis(&mut self, now: Instant) -> DiagnosisObject {
        self.drive.tick(now);
        let fault = self.drive.fault();
        DiagnosisObject::new(
            if fault == 0 {
                DiagnosisCode::NoFault
            } else {
                DiagnosisCode::Fault
            },
            fault.min(255) as u8,
            self.temperature,
        )
    }

    fn process(&mut self, out: PzdOut, now: Instant) -> PzdIn {
        self.drive.process(out.control().0, out.setpoints(), now);
        self.pzd_in()
    }

    fn process_data(&mut self, now: Instant) -> PzdIn {
        self.drive.tick(now);
        self.pzd_in()
    }

    fn execute(&mut self, order: Order, now: Instant) -> Reply {
        crate::sim::execute(&mut self.drive, &order, now)
    }

    fn pkw_time(&self, _order: &Order) -> Duration {
        self.pkw_time
    }

    fn answer_time(&self, _request: &Request) -> Duration {
        self.answer_time
    }
}

/// What can go wrong on a [`SimulatedLink`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SimulatedLinkError {
    /// [`SimulatedLink::receive`] without a request waiting for its answer.
    #[error("no request is waiting for an answer")]
    NoRequest,
    /// The answer buffer is too small.
    #[error("answer buffer of {got} bytes is too small for {needed}")]
    BufferTooSmall {
        /// Bytes needed.
        needed: usize,
        /// Bytes available.
        got: usize,
    },
}

/// An AS-i link to one simulated double slave on an [`AsiNetwork`] (see the
/// [module docs](self)).
#[derive(Debug)]
pub struct SimulatedLink {
    slave: DoubleSlave<SimulatedDoubleSlave>,
    network: AsiNetwork,
    id: DoubleSlaveId,
    /// tokio's clock seen as the link's [`Instant`]s (the runtime layer's time base).
    time: Timebase,
    /// The link's exact time: advanced by the transfer times it waits for.
    clock: Instant,
    waiting: usize,
}

impl SimulatedLink {
    /// The double slave at 1A/1B on a network of `slaves` AS-i slaves in all (2–62; the
    /// double slave counts 2, the others are extended slaves from 2A on).
    pub fn new(drive: SimulatedDoubleSlave, slaves: u8) -> Result<Self, NetworkError> {
        let mut network = AsiNetwork::new();
        let a = |n, bank| AsiAddress::new(n, bank).ok_or(NetworkError::BadAddress(n));
        let address = DoubleSlaveAddress {
            first: a(1, Bank::A)?,
            second: a(1, Bank::B)?,
        };
        let id = network.add_double_slave(address)?;
        let mut others = slaves.saturating_sub(2);
        'fill: for n in 2..=31 {
            for bank in [Bank::A, Bank::B] {
                if others == 0 {
                    break 'fill;
                }
                network.add_slave(SlaveAddress::Extended(a(n, bank)?))?;
                others -= 1;
            }
        }
        if others > 0 {
            return Err(NetworkError::Full);
        }
        Ok(Self::on_network(drive, network, id))
    }

    /// The double slave `id` of `network` (which must have it) is `drive`.
    pub fn on_network(drive: SimulatedDoubleSlave, network: AsiNetwork, id: DoubleSlaveId) -> Self {
        let time = Timebase::new(Clock::Real, network.byte_time());
        Self {
            slave: DoubleSlave::new(drive, SlaveConfig::default()),
            network,
            time,
            id,
            clock: Instant::ZERO,
            waiting: 0,
        }
    }

    /// The link's time: exact transfer times since the link was made, or tokio's clock when
    /// the caller waited longer.
    pub fn now(&mut self) -> Instant {
        let tokio_now = self.time.now();
        // tokio's timers end up to one tick late: within that the link's exact time stands.
        if tokio_now > self.clock.saturating_add(TIMER_RESOLUTION) {
            self.clock = tokio_now;
        }
        self.clock
    }

    async fn wait(&mut self, d: Duration) {
        let target = self.now().saturating_add(d);
        drive_core::rt::time::sleep_until(self.time.to_tokio(target)).await;
        self.clock = target;
    }

    async fn wait_until(&mut self, t: Instant) {
        let now = self.now();
        if t > now {
            self.wait(t.saturating_duration_since(now)).await;
        }
    }

    /// The CTT2 transfer time per byte on this network.
    pub fn byte_time(&self) -> Duration {
        self.network.byte_time()
    }

    /// Transfer `request` to the double slave without waiting for its answer.
    pub async fn send(&mut self, request: &[u8]) {
        self.wait(self.network.transfer_time(request.len())).await;
        let now = self.now();
        self.slave.handle_request(request, now);
        self.waiting += 1;
    }

    /// Wait for the next answer and transfer it into `answer`; returns its length.
    pub async fn receive(&mut self, answer: &mut [u8]) -> Result<usize, SimulatedLinkError> {
        if self.waiting == 0 {
            return Err(SimulatedLinkError::NoRequest);
        }
        loop {
            let now = self.now();
            if let Some(response) = self.slave.poll_answer(now) {
                self.waiting -= 1;
                let mut buf = [0u8; MAX_RESPONSE];
                let n = response.encode(&mut buf).unwrap_or(0);
                let got = answer.len();
                let dst = answer
                    .get_mut(..n)
                    .ok_or(SimulatedLinkError::BufferTooSmall { needed: n, got })?;
                dst.copy_from_slice(buf.get(..n).unwrap_or(&[]));
                self.wait(self.network.transfer_time(n)).await;
                return Ok(n);
            }
            match self.slave.poll_timeout() {
                Some(t) => self.wait_until(t.later(now)).await,
                None => return Err(SimulatedLinkError::NoRequest),
            }
        }
    }

    /// One AS-i cycle of the BusIO bits: the master's `bits` to the drive, the drive's back.
    pub fn exchange_busio(&mut self, bits: BusIoIn) -> Result<BusIoOut, NetworkError> {
        let now = self.now();
        self.network.set_outputs(self.id, bits)?;
        let drive = self.slave.backend_mut().drive_mut();
        self.network.exchange(self.id, |to_drive| {
            drive.set_busio_in(to_drive.bits(), now);
            BusIoOut::new(drive.busio_out())
        })
    }

    /// The double slave.
    pub fn slave(&self) -> &DoubleSlave<SimulatedDoubleSlave> {
        &self.slave
    }

    /// The double slave, mutable.
    pub fn slave_mut(&mut self) -> &mut DoubleSlave<SimulatedDoubleSlave> {
        &mut self.slave
    }

    /// The simulated double slave (drive and knobs).
    pub fn sim(&self) -> &SimulatedDoubleSlave {
        self.slave.backend()
    }

    /// The simulated double slave, mutable.
    pub fn sim_mut(&mut self) -> &mut SimulatedDoubleSlave {
        self.slave.backend_mut()
    }

    /// The drive.
    pub fn drive(&self) -> &SimulatedNord {
        self.slave.backend().drive()
    }

    /// The drive, mutable.
    pub fn drive_mut(&mut self) -> &mut SimulatedNord {
        self.slave.backend_mut().drive_mut()
    }

    /// The network.
    pub fn network(&self) -> &AsiNetwork {
        &self.network
    }
}

impl Ctt2Link for SimulatedLink {
    type Error = SimulatedLinkError;

    async fn transact(
        &mut self,
        request: &[u8],
        answer: &mut [u8],
    ) -> Result<usize, SimulatedLinkError> {
        self.send(request).await;
        self.receive(answer).await
    }
}
