//! The master driver against the sans-IO slave over the wire model of drive-transport, on
//! tokio's paused clock: the manual's exchanges, exceptions with the VABus cause, broadcast,
//! diagnostics, and the timing rules (10 ms answer delay, 2 ms turnaround, 500 ms timeout).

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

#[path = "common/tap.rs"]
mod tap;
use tap::Tap;

use std::collections::HashMap;
use std::time::Duration;

use bonfiglioli_modbus::driver::{Clock, DriverConfig, DriverError, LinkError, ModbusDriver};
use bonfiglioli_modbus::frame::{
    Address, DataSet, DiagSubFunction, ExceptionCode, Request, Response, StartAddress,
};
use bonfiglioli_modbus::framing::Mode;
use bonfiglioli_modbus::slave::{Backend, Slave, SlaveConfig, Width};
use drive_core::rt::{Timebase, serve};
use drive_core::{Instant, LineSettings};
use drive_transport::link::{self, LinkConfig};

/// A drive with a few parameters: (param, data set) → (width, value); parameter 11 is the
/// VABus error register, read and cleared.
#[derive(Debug, Default)]
struct Table {
    values: HashMap<(u16, u8), (Width, u32)>,
    vabus: u16,
    exchanges: Vec<Instant>,
}

impl Table {
    fn manual() -> Self {
        let mut values = HashMap::new();
        // 372 rated speed (16-bit) in data set 2: 1390 (ch. 8.1.1); 376 rated power, 481 fixed
        // frequency 2 (32-bit): 1000 = 10.00 Hz (ch. 8.1.3).
        values.insert((372, 2), (Width::Word, 1390));
        for ds in 1..=4 {
            values.insert((376, ds), (Width::Word, 15));
        }
        values.insert((481, 0), (Width::Long, 1000));
        Self {
            values,
            ..Self::default()
        }
    }

    fn refuse(&mut self, vabus: u16) -> ExceptionCode {
        self.vabus = vabus;
        ExceptionCode::SLAVE_DEVICE_FAILURE
    }
}

impl Backend for Table {
    fn read(
        &mut self,
        start: StartAddress,
        width: Width,
        _: Instant,
    ) -> Result<u32, ExceptionCode> {
        let (Some(p), Some(ds)) = (start.param(), start.data_set()) else {
            return Err(self.refuse(11));
        };
        if p == 11 && width == Width::Word {
            return Ok(u32::from(std::mem::take(&mut self.vabus)));
        }
        match self.values.get(&(p, ds.get())) {
            Some((w, v)) if *w == width => Ok(*v),
            Some(_) => Err(self.refuse(14)),
            None => Err(self.refuse(11)),
        }
    }

    fn write(
        &mut self,
        start: StartAddress,
        width: Width,
        value: u32,
        _: Instant,
    ) -> Result<(), ExceptionCode> {
        let (Some(p), Some(ds)) = (start.param(), start.data_set()) else {
            return Err(self.refuse(11));
        };
        if p == 376 && value == 0 {
            // ch. 8.1.2 example 2: 0 is not a valid rated power.
            return Err(self.refuse(1));
        }
        self.values.insert((p, ds.get()), (width, value));
        Ok(())
    }

    fn valid_exchange(&mut self, now: Instant) {
        self.exchanges.push(now);
    }
}

impl drive_core::Timers for Table {}

const LINE_19200: u32 = 19200;

fn line() -> LineSettings {
    LineSettings::new(LINE_19200)
}

fn a(n: u8) -> Address {
    Address::new(n).unwrap()
}

/// Run `f` with a master driver talking to one slave at address 1 (and 3) of `mode`.
async fn with_drive<F, Fut>(mode: Mode, f: F) -> Vec<Slave<Table>>
where
    F: FnOnce(ModbusDriver<link::LinkEnd>) -> Fut,
    Fut: std::future::Future<Output = ModbusDriver<link::LinkEnd>>,
{
    let (port, wire) = link::pair(LinkConfig::from_line(line()));
    let drives = vec![
        Slave::new(SlaveConfig::new(a(1), mode, line()), Table::manual()),
        Slave::new(SlaveConfig::new(a(3), mode, line()), Table::manual()),
    ];
    let sim = tokio::spawn(async move {
        let mut drives = drives;
        let mut time = Timebase::new(Clock::Real, line().char_time());
        let _ = serve(&mut drives, &mut time, wire).await;
        drives
    });
    let config = DriverConfig::new(mode, line());
    let master = f(ModbusDriver::new(port, config)).await;
    drop(master);
    sim.await.unwrap()
}

#[tokio::test(start_paused = true)]
async fn the_manuals_exchanges_in_both_modes() {
    for mode in [Mode::Rtu, Mode::Ascii] {
        with_drive(mode, |mut m| async move {
            let ds2 = DataSet::new(2).unwrap();
            assert_eq!(
                m.read(a(1), 372, ds2, Width::Word).await.unwrap(),
                1390,
                "{mode}"
            );
            assert_eq!(
                m.read(a(1), 481, DataSet::ALL, Width::Long).await.unwrap(),
                1000
            );
            m.write(a(3), 376, DataSet::new(4).unwrap(), Width::Word, 15)
                .await
                .unwrap();
            // Register count 2: exception 2 (ch. 8.1.1 example 2).
            let start = StartAddress::from_raw(0x0174);
            let r = m
                .transact(
                    a(1),
                    Request::ReadWord { start, count: 2 },
                    Duration::from_millis(500),
                )
                .await
                .unwrap();
            assert_eq!(
                r,
                Some(Response::Exception {
                    function: 3,
                    code: ExceptionCode::ILLEGAL_DATA_ADDRESS
                })
            );
            // Writing 0 to 376: exception 4, and the driver reads the cause (VABus 1).
            match m
                .write(a(3), 376, DataSet::new(2).unwrap(), Width::Word, 0)
                .await
            {
                Err(DriverError::Device { exception, vabus }) => {
                    assert_eq!(exception, ExceptionCode::SLAVE_DEVICE_FAILURE);
                    assert_eq!(vabus, Some(1));
                }
                other => panic!("{other:?}"),
            }
            // The wrong width for a parameter: the drive says so (VABus 14).
            match m.read(a(1), 481, DataSet::ALL, Width::Word).await {
                Err(DriverError::Device {
                    vabus: Some(14), ..
                }) => {}
                other => panic!("{other:?}"),
            }
            m
        })
        .await;
    }
}

#[tokio::test(start_paused = true)]
async fn diagnostics_count_and_clear() {
    let drives = with_drive(Mode::Rtu, |mut m| async move {
        m.read(a(1), 372, DataSet::new(2).unwrap(), Width::Word)
            .await
            .unwrap();
        m.read(a(3), 372, DataSet::new(2).unwrap(), Width::Word)
            .await
            .unwrap();
        // Drive 1 saw two valid messages on the bus (its own and drive 3's request; answers of
        // others count too), one of them for itself.
        let msgs = m
            .diagnostics(a(1), DiagSubFunction::SLAVE_MESSAGES)
            .await
            .unwrap();
        assert_eq!(msgs, 2, "its read and this diagnostic request");
        assert_eq!(
            m.diagnostics(a(1), DiagSubFunction::CLEAR_COUNTERS)
                .await
                .unwrap(),
            0
        );
        assert_eq!(
            m.diagnostics(a(1), DiagSubFunction::SLAVE_MESSAGES)
                .await
                .unwrap(),
            1
        );
        assert_eq!(
            m.diagnostics(a(1), DiagSubFunction::SLAVE_NAK)
                .await
                .unwrap(),
            0
        );
        // 0x13 is no sub-function of this drive: exception 1.
        match m.diagnostics(a(1), DiagSubFunction(0x13)).await {
            Err(DriverError::Device {
                exception,
                vabus: None,
            }) => {
                assert_eq!(exception, ExceptionCode::ILLEGAL_FUNCTION);
            }
            other => panic!("{other:?}"),
        }
        m
    })
    .await;
    assert_eq!(drives[0].counters().bus_exception_errors, 1);
}

#[tokio::test(start_paused = true)]
async fn a_broadcast_write_reaches_every_drive_and_is_never_answered() {
    let drives = with_drive(Mode::Rtu, |mut m| async move {
        let ds7 = DataSet::new(7).unwrap();
        m.write(Address::BROADCAST, 400, ds7, Width::Word, 42)
            .await
            .unwrap();
        assert_eq!(m.read(a(1), 400, ds7, Width::Word).await.unwrap(), 42);
        assert_eq!(m.read(a(3), 400, ds7, Width::Word).await.unwrap(), 42);
        assert_eq!(m.stats().timeouts, 0);
        m
    })
    .await;
    assert_eq!(drives[0].counters().slave_no_response, 1);
}

#[tokio::test(start_paused = true)]
async fn a_missing_drive_costs_the_timeout_and_the_retries() {
    with_drive(Mode::Rtu, |mut m| async move {
        let t0 = tokio::time::Instant::now();
        match m
            .read(a(9), 372, DataSet::new(2).unwrap(), Width::Word)
            .await
        {
            Err(DriverError::Link(LinkError::Timeout {
                address: 9,
                attempts: 3,
            })) => {}
            other => panic!("{other:?}"),
        }
        // Three attempts of 500 ms each, plus the frames and pauses.
        let took = t0.elapsed();
        assert!(
            took >= Duration::from_millis(1500) && took < Duration::from_millis(1600),
            "{took:?}"
        );
        m
    })
    .await;
}

#[tokio::test(start_paused = true)]
async fn answers_come_10_ms_after_a_request_and_requests_2_ms_after_an_answer() {
    // At 38400 baud RTU's idle gap is the fixed 1.75 ms: the manual's 2 ms rule is the longer.
    let line = LineSettings::new(38400);
    let char_time = line.char_time();
    let (port, wire) = link::pair(LinkConfig::from_line(line));
    let drive_log = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let master_log = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let wire = Tap {
        inner: wire,
        log: drive_log.clone(),
    };
    let port = Tap {
        inner: port,
        log: master_log.clone(),
    };
    let sim = tokio::spawn(async move {
        let mut drives = [Slave::new(
            SlaveConfig::new(a(1), Mode::Rtu, line),
            Table::manual(),
        )];
        let mut time = Timebase::new(Clock::Real, char_time);
        let _ = serve(&mut drives, &mut time, wire).await;
    });
    let mut m = ModbusDriver::new(port, DriverConfig::new(Mode::Rtu, line));
    for _ in 0..3 {
        m.read(a(1), 372, DataSet::new(2).unwrap(), Width::Word)
            .await
            .unwrap();
    }
    drop(m);
    sim.await.unwrap();
    let requests = drive_log.lock().unwrap().clone();
    let answers = master_log.lock().unwrap().clone();
    // Three requests of 8 characters and three answers of 7.
    assert_eq!((requests.len(), answers.len()), (24, 21));
    for i in 0..3 {
        let request_end = requests[8 * i + 7].at;
        let answer_start = answers[7 * i].at - char_time;
        let delay = answer_start - request_end;
        assert!(
            delay >= Duration::from_millis(10),
            "answer {i} after {delay:?}"
        );
        assert!(
            delay < Duration::from_millis(12),
            "answer {i} after {delay:?}"
        );
        if i < 2 {
            let answer_end = answers[7 * i + 6].at;
            let next_start = requests[8 * (i + 1)].at - char_time;
            let pause = next_start - answer_end;
            assert!(
                pause >= Duration::from_millis(2),
                "request {} after {pause:?}",
                i + 1
            );
            assert!(
                pause < Duration::from_millis(3),
                "request {} after {pause:?}",
                i + 1
            );
        }
    }
}
