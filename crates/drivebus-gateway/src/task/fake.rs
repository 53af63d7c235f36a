use std::cell::RefCell;
use std::collections::{HashMap, HashSet};
use std::rc::Rc;
use std::time::Duration;

use drive_profile::{Family, Persistence};
use serde_json::{Map, Value};
use tokio::time::Instant;

use super::super::bus::{BusAccess, LinkTally, Op};
use super::super::config::{Bus, Plant};
use super::super::model::PageCommand;
use drive_client::{ClientError, DeviceError, DeviceErrorKind, ParamClient, Target};

/// What the test sees and changes while the bus runs.
#[derive(Debug, Default)]
pub struct State {
    /// Addresses that do not answer.
    pub dead: HashSet<u8>,
    /// Parameter values per address and index (absent: 0).
    pub values: HashMap<(u8, u16), i64>,
    /// Faults per address.
    pub faults: HashMap<u8, String>,
    /// Indices whose writes the drive refuses.
    pub refuse_writes: HashSet<u16>,
    /// Every write taken: address, index, raw, persistence.
    pub written: Vec<(u8, u16, i64, Persistence)>,
    /// Every transaction: when it started, the address, the op.
    pub log: Vec<(Instant, u8, Op)>,
    /// Retries since the last tally.
    pub retries: u64,
    /// Every stop sent in process data: address, output words given.
    pub stopped: Vec<(u8, Vec<u16>)>,
    /// Every process-data exchange: when it started, the address, the output words sent.
    pub exchanged: Vec<(Instant, u8, Vec<u16>)>,
}

/// The bus.
pub struct FakeBus {
    /// Shared with the test.
    pub state: Rc<RefCell<State>>,
    /// Wire time of a read, a write, a process-data exchange.
    pub wire: Duration,
    /// Response timeout per attempt.
    pub timeout: Duration,
    /// Retries after a failed attempt.
    pub retries: u8,
}

impl FakeBus {
    /// A bus with `bus`'s timeout and retries and `wire` per transaction.
    pub fn new(bus: &Bus, wire: Duration) -> (Self, Rc<RefCell<State>>) {
        let state = Rc::new(RefCell::new(State::default()));
        let fake = Self {
            state: state.clone(),
            wire,
            timeout: bus.timeout,
            retries: bus.retries,
        };
        (fake, state)
    }

    /// One transaction with `address`: its wire time, or the timeout of every attempt.
    async fn transaction(&self, address: u8, op: Op) -> Result<(), ClientError> {
        let dead = {
            let mut s = self.state.borrow_mut();
            s.log.push((Instant::now(), address, op));
            s.dead.contains(&address)
        };
        if dead {
            tokio::time::sleep(self.timeout * (u32::from(self.retries) + 1)).await;
            self.state.borrow_mut().retries += u64::from(self.retries);
            return Err(ClientError::link(
                drive_client::LinkFault::NoAnswer,
                format!("no answer from drive {address}"),
            ));
        }
        tokio::time::sleep(self.wire_time(op)).await;
        Ok(())
    }
}

/// One drive of the fake bus.
pub struct FakeClient<'a> {
    bus: &'a FakeBus,
    address: u8,
}

impl ParamClient for FakeClient<'_> {
    fn family(&self) -> Family {
        Family::Movidrive
    }
    async fn drive_key(&mut self) -> Result<String, ClientError> {
        Ok(format!("fake {}", self.address))
    }
    async fn read(&mut self, t: &Target) -> Result<i64, ClientError> {
        self.bus.transaction(self.address, Op::Read).await?;
        let s = self.bus.state.borrow();
        Ok(s.values.get(&(self.address, t.index)).copied().unwrap_or(0))
    }
    async fn write(
        &mut self,
        t: &Target,
        raw: i64,
        persistence: Persistence,
    ) -> Result<(), ClientError> {
        self.bus.transaction(self.address, Op::Write).await?;
        let mut s = self.bus.state.borrow_mut();
        if s.refuse_writes.contains(&t.index) {
            return Err(ClientError::Device(DeviceError {
                kind: DeviceErrorKind::Refused,
                code: drive_client::DeviceCode::None,
                message: "return code 0x0810: controller inhibit needed".into(),
            }));
        }
        s.written.push((self.address, t.index, raw, persistence));
        s.values.insert((self.address, t.index), raw);
        Ok(())
    }
    async fn identify(&mut self) -> Result<Map<String, Value>, ClientError> {
        Ok(Map::new())
    }
}

impl BusAccess for FakeBus {
    type Client<'a> = FakeClient<'a>;
    fn client(&mut self, address: u8) -> FakeClient<'_> {
        FakeClient { bus: self, address }
    }
    async fn process_data(&mut self, address: u8, out: &[u16]) -> Result<Vec<u16>, ClientError> {
        let n = u8::try_from(out.len()).unwrap_or(u8::MAX);
        self.state
            .borrow_mut()
            .exchanged
            .push((Instant::now(), address, out.to_vec()));
        self.transaction(address, Op::ProcessData(n)).await?;
        Ok(out.iter().map(|w| w ^ 0xFFFF).collect())
    }
    /// Like a MOVIDRIVE with PO1 the control word and PO2 the speed setpoint.
    async fn control_words(
        &mut self,
        _address: u8,
        out: &[u16],
        command: PageCommand,
        _sent: &[u16],
        _inputs: &[u16],
    ) -> Result<Result<Vec<u16>, String>, ClientError> {
        let mut w = out.to_vec();
        let (cw, sp) = match command {
            PageCommand::Enable { word } => (6, word),
            PageCommand::Stop => (2, 0),
        };
        if let Some(x) = w.get_mut(0) {
            *x = cw;
        }
        if let Some(x) = w.get_mut(1) {
            *x = sp;
        }
        Ok(Ok(w))
    }
    async fn stop_process_data(
        &mut self,
        address: u8,
        out: &[u16],
    ) -> Result<Result<Vec<u16>, String>, ClientError> {
        let n = u8::try_from(out.len()).unwrap_or(u8::MAX);
        self.transaction(address, Op::ProcessData(n)).await?;
        self.state
            .borrow_mut()
            .stopped
            .push((address, out.to_vec()));
        Ok(Ok(out.to_vec()))
    }
    async fn fault(&mut self, address: u8) -> Result<Option<String>, ClientError> {
        self.transaction(address, Op::Read).await?;
        Ok(self.state.borrow().faults.get(&address).cloned())
    }
    fn wire_time(&self, op: Op) -> Duration {
        match op {
            Op::Read | Op::Write => self.wire,
            Op::ProcessData(_) => self.wire / 2,
        }
    }
    fn take_tally(&mut self) -> LinkTally {
        LinkTally {
            retries: std::mem::take(&mut self.state.borrow_mut().retries),
            rejected: Vec::new(),
        }
    }
}

/// A plant of one simulated MOVILINK bus: `drives` drives (addresses 1…), each with the
/// points `points` (name, P130 polled at the period or not, writable) and process data at
/// `pd` if given.
pub fn plant(
    drives: usize,
    points: &[(&str, Option<&str>, bool)],
    pd: Option<&str>,
    bus_extra: &str,
) -> Plant {
    let mut t = String::from(
        "[gateway]\nname = \"gw\"\nbroker = \"mqtt://127.0.0.1:1883\"\nmetrics = \"off\"\n\
             [[bus]]\nname = \"line1\"\nprotocol = \"movilink\"\nsimulate = true\n",
    );
    t.push_str(bus_extra);
    for d in 0..drives {
        t.push_str(&format!(
            "[[bus.drive]]\nname = \"d{}\"\naddress = {}\n",
            d + 1,
            d + 1
        ));
        for (name, period, writable) in points {
            t.push_str(&format!(
                "[[bus.drive.param]]\nparam = \"P130\"\nname = \"{name}\"\nwritable = {writable}\n"
            ));
            if let Some(p) = period {
                t.push_str(&format!("period = \"{p}\"\n"));
            }
        }
        if let Some(p) = pd {
            t.push_str(&format!(
                "[bus.drive.process_data]\nperiod = \"{p}\"\nout = [6, 1000]\n"
            ));
        }
    }
    match Plant::parse(&t, "test") {
        Ok(p) => p,
        Err(e) => panic!("test config: {e}\n{t}"),
    }
}
