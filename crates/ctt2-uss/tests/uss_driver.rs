//! The async USS master (`UssDriver` under `NordClient`) against simulated NORD drives over
//! drive-transport's in-memory link, on tokio's paused clock: every order AK 0–14, refusals,
//! parameter sets, P560 and RAM-only writes, the plausibility repeat with a slow drive, the
//! manual's control sequences through the process data, broadcast and mirror telegrams,
//! several drives on one line, the line timing at 9600/19200/38400 baud, response timeout and
//! retries.

// A failing fixture is a failing test: panicking is the report.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::sync::{Arc, Mutex};
use std::time::Duration;

use ctt2_uss::client::{Address, ClientConfig, ClientError, NordClient, ParameterChannel};
use ctt2_uss::serial::driver::{DriverConfig, DriverError, LinkError, RequestError, UssDriver};
use ctt2_uss::serial::sim::{self, SimulatedBus, SimulatedDrive};
use ctt2_uss::serial::{Layout, UssAddress};
use ctt2_uss::uss::pkw::{Ind, Order, Pke, Pkw, Reply, Storage};
use drive_core::LineSettings;
use drive_core::rt::ReceivedChar;
use drive_profile::nord::{ControlWord, State, Width};
use drive_transport::link::{self, Fault, LinkConfig, LinkEnd};
use tokio::task::JoinHandle;

fn addr(a: u8) -> UssAddress {
    UssAddress::new(a).unwrap()
}

const LAYOUT: Layout = Layout::PKW4_PZD4;

type Client = NordClient<UssDriver<LinkEnd>>;

/// A client for drive `a` and one simulated drive at `a` (changed by `setup`) on a link at
/// `baud`; the drive comes back when the client is dropped.
fn one_drive(
    a: u8,
    baud: u32,
    setup: impl FnOnce(&mut SimulatedDrive),
) -> (Client, JoinHandle<SimulatedDrive>) {
    let line = LineSettings::new(baud);
    let (port, wire) = link::pair(LinkConfig::from_line(line));
    let mut drive = SimulatedDrive::new(addr(a), LAYOUT, line);
    setup(&mut drive);
    let sim = tokio::spawn(async move {
        drive.serve(wire).await.unwrap();
        drive
    });
    let master = UssDriver::new(port, DriverConfig::new(addr(a), LAYOUT, line));
    (NordClient::new(master, ClientConfig::default()), sim)
}

async fn finish(client: Client, sim: JoinHandle<SimulatedDrive>) -> SimulatedDrive {
    drop(client);
    sim.await.unwrap()
}

fn drive_error<E: std::fmt::Debug>(r: Result<impl std::fmt::Debug, ClientError<E>>) -> u16 {
    match r {
        Err(ClientError::Drive { error, .. }) => error.0,
        other => panic!("expected a drive error, got {other:?}"),
    }
}

#[tokio::test(start_paused = true)]
async fn reads_and_writes_words_through_every_order() {
    let (mut c, sim) = one_drive(7, 19200, |_| {});
    // AK 0: no order, answered AK 0.
    assert_eq!(c.order(Order::none()).await.unwrap(), Reply::None);
    // AK 1: P102 ramp time, simulator default 2.00 s, answered AK 1 (word).
    assert_eq!(
        c.read_value(Address::new(102)).await.unwrap(),
        (200, Width::Word)
    );
    // AK 2 (EEPROM as P560 = 1 says), answered AK 1 repeating the value.
    c.write(Address::new(102), Width::Word, Storage::Eeprom, 250)
        .await
        .unwrap();
    assert_eq!(c.read(Address::new(102)).await.unwrap(), 250);
    // AK 6 / 7: array element P546 [-02], answered AK 4.
    let sw2 = Address {
        element: Some(1),
        ..Address::new(546)
    };
    assert_eq!(c.read(sw2).await.unwrap(), 0);
    c.write(sw2, Width::Word, Storage::Eeprom, 1).await.unwrap();
    assert_eq!(c.read(sw2).await.unwrap(), 1);
    // AK 9: P701 has 5 elements (answered AK 6); P102 is no array: error 4.
    assert_eq!(c.count(701).await.unwrap(), 5);
    assert_eq!(drive_error(c.count(102).await), 4);
    // AK 12: array word without EEPROM; AK 14: word without EEPROM.
    let iw3 = Address {
        element: Some(2),
        ..Address::new(543)
    };
    c.write(iw3, Width::Word, Storage::Ram, 9).await.unwrap();
    c.write(Address::new(102), Width::Word, Storage::Ram, 300)
        .await
        .unwrap();
    assert_eq!(c.read(Address::new(102)).await.unwrap(), 300);
    // AK 3, 8, 11, 13: double words; every NORD parameter is a word: error 5 (data type).
    for (element, storage) in [
        (None, Storage::Eeprom),
        (Some(0), Storage::Eeprom),
        (Some(0), Storage::Ram),
        (None, Storage::Ram),
    ] {
        let at = Address {
            element,
            ..Address::new(if element.is_some() { 546 } else { 102 })
        };
        assert_eq!(
            drive_error(c.write(at, Width::DoubleWord, storage, 1).await),
            5
        );
    }
    let drive = finish(c, sim).await;
    let nord = drive.drive();
    // The EEPROM kept the AK 2 value, RAM has the AK 14 value; AK 12 left EEPROM alone.
    assert_eq!(nord.ram_value(102, 0, 0), Some(300));
    assert_eq!(nord.eeprom_value(102, 0, 0), Some(250));
    assert_eq!(nord.eeprom_writes_of(102, 0, 0), Some(1));
    assert_eq!(nord.ram_value(543, 2, 0), Some(9));
    assert_eq!(nord.eeprom_writes_of(543, 2, 0), Some(0));
    assert_eq!(nord.eeprom_writes_of(546, 1, 0), Some(1));
}

#[tokio::test(start_paused = true)]
async fn refusals_carry_the_manuals_error_numbers() {
    let (mut c, sim) = one_drive(1, 19200, |_| {});
    // 0: no parameter 2000.
    assert_eq!(drive_error(c.read(Address::new(2000)).await), 0);
    // 1: P700 is read-only.
    let p700 = Address {
        element: Some(0),
        ..Address::new(700)
    };
    assert_eq!(
        drive_error(c.write(p700, Width::Word, Storage::Eeprom, 1).await),
        1
    );
    // 2: P102 above 320.00 s.
    assert_eq!(
        drive_error(
            c.write(Address::new(102), Width::Word, Storage::Eeprom, 32001)
                .await
        ),
        2
    );
    // 3: P546 has three elements, not six.
    let sw6 = Address {
        element: Some(5),
        ..Address::new(546)
    };
    assert_eq!(drive_error(c.read(sw6).await), 3);
    // 6: P701 only resettable.
    let p701 = Address {
        element: Some(0),
        ..Address::new(701)
    };
    assert_eq!(
        drive_error(c.write(p701, Width::Word, Storage::Eeprom, 5).await),
        6
    );
    // A reserved order ID (AK 4) straight through the parameter channel: AK 7, error 201.
    let raw = Pkw {
        pke: Pke::new(4, 102).unwrap(),
        ..Pkw::default()
    };
    let answer = c.channel_mut().submit(raw).await.unwrap();
    assert_eq!((answer.pke.ak(), answer.pwe2), (7, 201));
    let drive = finish(c, sim).await;
    assert_eq!(
        drive.drive().eeprom_writes(),
        0,
        "no refused write reached EEPROM"
    );
}

#[tokio::test(start_paused = true)]
async fn parameter_sets_are_independent_and_p560_keeps_writes_in_ram() {
    let (mut c, sim) = one_drive(2, 38400, |_| {});
    for set in 0..4u8 {
        let at = Address {
            set,
            ..Address::new(102)
        };
        c.write(at, Width::Word, Storage::Eeprom, 100 + i64::from(set))
            .await
            .unwrap();
    }
    for set in 0..4u8 {
        let at = Address {
            set,
            ..Address::new(102)
        };
        assert_eq!(c.read(at).await.unwrap(), 100 + i32::from(set));
    }
    // P560 = 0: AK 2 writes go to RAM only.
    c.write(Address::new(560), Width::Word, Storage::Eeprom, 0)
        .await
        .unwrap();
    c.write(Address::new(102), Width::Word, Storage::Eeprom, 777)
        .await
        .unwrap();
    let mut drive = finish(c, sim).await;
    let nord = drive.drive_mut();
    assert_eq!(nord.ram_value(102, 0, 0), Some(777));
    assert_eq!(nord.eeprom_value(102, 0, 0), Some(100));
    assert_eq!(nord.eeprom_writes_of(102, 0, 0), Some(1));
    // A power cycle loses the RAM-only value.
    nord.restart(drive_core::Instant::from_secs(10));
    assert_eq!(nord.ram_value(102, 0, 0), Some(100));
    assert_eq!(nord.ram_value(102, 0, 3), Some(103));
}

#[tokio::test(start_paused = true)]
async fn a_slow_drive_is_asked_again_until_the_answer_fits() {
    // The drive needs 60 ms per order and meanwhile answers the previous order: the client
    // repeats the telegram until AK, PNU, IND (and a write's value) fit.
    let (mut c, sim) = one_drive(3, 9600, |d| {
        d.set_processing_time(Duration::from_millis(60));
    });
    let t0 = tokio::time::Instant::now();
    c.write(Address::new(102), Width::Word, Storage::Eeprom, 450)
        .await
        .unwrap();
    assert!(t0.elapsed() >= Duration::from_millis(60));
    let after_write = c.repeated_requests();
    assert!(after_write >= 2, "repeats: {after_write}");
    // A read of P102 now would take the write's answer (AK 1, P102, IND 0, 450) at once: it
    // is a plausible answer to the read, and the right value. A read of P105 must wait.
    assert_eq!(c.read(Address::new(105)).await.unwrap(), 500);
    assert!(c.repeated_requests() >= after_write + 2);
    let stats = c.channel().stats();
    assert_eq!(stats.retries, 0, "repeats are new telegrams, not retries");
    let drive = finish(c, sim).await;
    // The repeated write telegram was executed once: one EEPROM write, two orders in all.
    assert_eq!(drive.drive().eeprom_writes_of(102, 0, 0), Some(1));
    assert_eq!(drive.stats().orders, 2);
    assert!(drive.stats().telegrams >= 2 + after_write);
}

#[tokio::test(start_paused = true)]
async fn the_manuals_control_sequence_through_the_process_data() {
    use ctt2_uss::client::ProcessChannel;
    use ctt2_uss::uss::pzd::PzdOut;
    let (mut c, sim) = one_drive(1, 19200, |_| {});
    let ch = c.channel_mut();
    // 5.1.1: the last status word 0B70h (switch-on disabled); 047Eh → 0B31h.
    let first = ch
        .exchange_process(PzdOut::new(ControlWord(0x0000), &[0]), 1)
        .await
        .unwrap();
    assert_eq!(first.status().0, 0x0B70);
    let ready = ch
        .exchange_process(PzdOut::new(ControlWord(0x047E), &[0]), 1)
        .await
        .unwrap();
    assert_eq!(ready.status().0, 0x0B31);
    // 5.1.2: 047Fh with SW1 2000h (50 %): the drive runs up the 2.00 s ramp; at 50 % it
    // reports 0B37h and IW1 2000h.
    let mut last = None;
    for _ in 0..200 {
        let a = ch
            .exchange_process(PzdOut::new(ControlWord(0x047F), &[0x2000]), 1)
            .await
            .unwrap();
        if a.status().0 == 0x0B37 {
            last = Some(a);
            break;
        }
    }
    let last = last.expect("0B37h within the ramp time");
    assert_eq!(last.actuals(), &[0x2000]);
    // A parameter telegram carries the last process data: the drive keeps running.
    assert_eq!(c.read(Address::new(102)).await.unwrap(), 200);
    let drive = finish(c, sim).await;
    assert_eq!(drive.drive().state(), State::OperationEnabled);
    assert!((drive.drive().actual_frequency() - 25.0).abs() < 0.01);
}

#[tokio::test(start_paused = true)]
async fn drive_to_operation_enabled_and_back() {
    let (mut c, sim) = one_drive(4, 38400, |_| {});
    let a = c
        .drive_to(State::OperationEnabled, &[0x1000], 0)
        .await
        .unwrap();
    assert_eq!(a.status().0 & 0x6F, 0x27);
    let a = c.drive_to(State::SwitchOnDisabled, &[0], 0).await.unwrap();
    assert_eq!(a.status().0 & 0x4F, 0x40);
    let drive = finish(c, sim).await;
    assert_eq!(drive.drive().state(), State::SwitchOnDisabled);
}

/// A bus of drives at `addresses`, served on the wire end; a master for `to`.
fn bus(addresses: &[u8], to: u8, baud: u32) -> (UssDriver<LinkEnd>, JoinHandle<SimulatedBus>) {
    let line = LineSettings::new(baud);
    let (port, wire) = link::pair(LinkConfig::from_line(line));
    let list: Vec<UssAddress> = addresses.iter().map(|&a| addr(a)).collect();
    let mut bus = sim::bus(&list, LAYOUT, line);
    let sim = tokio::spawn(async move {
        bus.serve(wire).await.unwrap();
        bus
    });
    (
        UssDriver::new(port, DriverConfig::new(addr(to), LAYOUT, line)),
        sim,
    )
}

#[tokio::test(start_paused = true)]
async fn drives_0_to_31_share_one_line() {
    let (master, sim) = bus(&[0, 1, 17, 31], 0, 19200);
    let mut port = master.into_inner();
    let line = LineSettings::new(19200);
    // One master per address, one after the other, on the same port.
    for (i, a) in [0u8, 1, 17, 31].into_iter().enumerate() {
        let m = UssDriver::new(port, DriverConfig::new(addr(a), LAYOUT, line));
        let mut c = NordClient::new(m, ClientConfig::default());
        let at = Address::new(102);
        c.write(at, Width::Word, Storage::Ram, 1000 + i as i64)
            .await
            .unwrap();
        assert_eq!(c.read(at).await.unwrap(), 1000 + i as i32);
        port = c.into_inner().into_inner();
    }
    drop(port);
    let bus = sim.await.unwrap();
    for (i, a) in [0u8, 1, 17, 31].into_iter().enumerate() {
        let d = bus.station(a).unwrap();
        assert_eq!(d.drive().ram_value(102, 0, 0), Some(1000 + i as i32));
        assert_eq!(d.stats().rejected, 0);
    }
}

#[tokio::test(start_paused = true)]
async fn broadcast_is_executed_by_every_drive_and_answered_by_none() {
    let (mut m, sim) = bus(&[1, 2, 3], 1, 19200);
    let order = Order::write(102, Ind::ZERO, Width::Word, false, Storage::Ram, 1234)
        .unwrap()
        .to_pkw();
    let t0 = tokio::time::Instant::now();
    m.broadcast(order).await.unwrap();
    // Returned once sent: 20 characters at 19200 8E1, nothing waited for.
    assert!(
        t0.elapsed() < Duration::from_millis(13),
        "{:?}",
        t0.elapsed()
    );
    // A read broadcast is refused before anything is sent.
    let read = Order::read(102, Ind::ZERO).unwrap().to_pkw();
    assert!(matches!(
        m.broadcast(read).await,
        Err(DriverError::Request(RequestError::Send(_)))
    ));
    // The next telegram to drive 1 is answered normally.
    let mut c = NordClient::new(m, ClientConfig::default());
    assert_eq!(c.read(Address::new(102)).await.unwrap(), 1234);
    drop(c);
    let bus = sim.await.unwrap();
    for a in [1u8, 2, 3] {
        let d = bus.station(a).unwrap();
        assert_eq!(d.drive().ram_value(102, 0, 0), Some(1234), "drive {a}");
        assert_eq!(d.stats().broadcasts, 1);
        assert_eq!(d.drive().eeprom_writes(), 0, "AK 14: RAM only");
    }
    assert_eq!(
        bus.station(2).unwrap().stats().telegrams,
        0,
        "nobody answered"
    );
}

#[tokio::test(start_paused = true)]
async fn a_mirror_telegram_comes_back_unchanged_and_executes_nothing() {
    let (mut m, sim) = bus(&[5, 6], 5, 9600);
    let echo = m.mirror().await.unwrap();
    assert!(echo.adr().is_mirror());
    assert_eq!(echo.adr().address(), addr(5));
    assert_eq!(echo.pzd(), &[0, 0, 0, 0]);
    drop(m);
    let bus = sim.await.unwrap();
    let d5 = bus.station(5).unwrap();
    assert_eq!(d5.stats().mirrored, 1);
    assert_eq!((d5.stats().telegrams, d5.stats().orders), (0, 0));
    assert_eq!(bus.station(6).unwrap().stats().mirrored, 0);
}

/// A port that logs every character it receives with its arrival time.
struct Tap {
    inner: LinkEnd,
    log: Arc<Mutex<Vec<ReceivedChar>>>,
}

impl drive_core::rt::CharIo for Tap {
    fn poll_read_chars(
        &mut self,
        cx: &mut std::task::Context<'_>,
        buf: &mut [ReceivedChar],
    ) -> std::task::Poll<std::io::Result<usize>> {
        let r = drive_core::rt::CharIo::poll_read_chars(&mut self.inner, cx, buf);
        if let std::task::Poll::Ready(Ok(n)) = r {
            self.log.lock().unwrap().extend_from_slice(&buf[..n]);
        }
        r
    }
    fn poll_write(
        &mut self,
        cx: &mut std::task::Context<'_>,
        buf: &[u8],
    ) -> std::task::Poll<std::io::Result<usize>> {
        drive_core::rt::CharIo::poll_write(&mut self.inner, cx, buf)
    }
    fn poll_flush(
        &mut self,
        cx: &mut std::task::Context<'_>,
    ) -> std::task::Poll<std::io::Result<()>> {
        drive_core::rt::CharIo::poll_flush(&mut self.inner, cx)
    }
    fn poll_write_at(
        &mut self,
        cx: &mut std::task::Context<'_>,
        buf: &[u8],
        start: tokio::time::Instant,
    ) -> std::task::Poll<std::io::Result<usize>> {
        drive_core::rt::CharIo::poll_write_at(&mut self.inner, cx, buf, start)
    }
    fn honours_write_start(&self) -> bool {
        drive_core::rt::CharIo::honours_write_start(&self.inner)
    }
    fn wire_time(&self) -> drive_core::rt::WireTime {
        drive_core::rt::CharIo::wire_time(&self.inner)
    }
}

/// On the wire model: every answer starts at least the start delay (2 characters) after its
/// request, and every request at least the start delay after the previous answer; the drive's
/// response delay is exactly the start delay (NORD's typical response delay).
#[tokio::test(start_paused = true)]
async fn start_delay_of_two_characters_at_9600_19200_38400() {
    for baud in [9600u32, 19200, 38400] {
        let line = LineSettings::new(baud);
        let ct = line.char_time();
        let delay = line.char_times(2, 1);
        let (port, wire) = link::pair(LinkConfig::from_line(line));
        let to_drive = Arc::new(Mutex::new(Vec::new()));
        let to_master = Arc::new(Mutex::new(Vec::new()));
        let wire = Tap {
            inner: wire,
            log: to_drive.clone(),
        };
        let port = Tap {
            inner: port,
            log: to_master.clone(),
        };
        let mut drives = [SimulatedDrive::new(addr(1), LAYOUT, line)];
        let sim = tokio::spawn(async move {
            let mut time = drive_core::rt::Timebase::new(drive_core::rt::Clock::Real, ct);
            drive_core::rt::serve(&mut drives, &mut time, wire)
                .await
                .unwrap();
        });
        let master = UssDriver::new(port, DriverConfig::new(addr(1), LAYOUT, line));
        let mut c = NordClient::new(master, ClientConfig::default());
        let n = 20;
        for _ in 0..n {
            assert_eq!(c.read(Address::new(102)).await.unwrap(), 200);
        }
        drop(c);
        sim.await.unwrap();
        let requests = to_drive.lock().unwrap().clone();
        let answers = to_master.lock().unwrap().clone();
        let len = LAYOUT.telegram_len();
        assert_eq!(requests.len(), answers.len(), "{baud}");
        assert_eq!(requests.len() % len, 0);
        // 20 reads of the same parameter: the client puts "no order" before its first order
        // and between two orders on one PNU and IND, so 40 telegrams.
        let n = requests.len() / len;
        assert_eq!(n, 40, "{baud}");
        let mut worst_answer = Duration::MAX;
        let mut worst_next = Duration::MAX;
        for i in 0..n {
            let request_end = requests[len * i + len - 1].at;
            let answer_start = answers[len * i].at - ct;
            let answer_gap = answer_start - request_end;
            worst_answer = worst_answer.min(answer_gap);
            // The answer starts after exactly the response delay (to the wire model's
            // nanosecond rounding of the character time).
            assert!(
                answer_gap.abs_diff(delay) < Duration::from_micros(2),
                "{baud}: answer {answer_gap:?}, delay {delay:?}"
            );
            if i + 1 < n {
                let answer_end = answers[len * i + len - 1].at;
                let next_start = requests[len * (i + 1)].at - ct;
                worst_next = worst_next.min(next_start - answer_end);
            }
            // Characters of one telegram come back to back.
            for k in 1..len {
                assert_eq!(requests[len * i + k].at - requests[len * i + k - 1].at, ct);
            }
        }
        assert!(worst_answer + Duration::from_nanos(2) >= delay, "{baud}");
        assert!(
            worst_next + Duration::from_nanos(2) >= delay,
            "{baud}: {worst_next:?}"
        );
        println!(
            "{baud} 8E1: start delay {:.3} ms; shortest answer delay {:.3} ms, shortest pause before the next request {:.3} ms",
            delay.as_secs_f64() * 1e3,
            worst_answer.as_secs_f64() * 1e3,
            worst_next.as_secs_f64() * 1e3
        );
    }
}

#[tokio::test(start_paused = true)]
async fn no_drive_times_out_after_three_attempts() {
    // Nobody at address 9: three attempts, each waiting the 20 ms response timeout after the
    // telegram (plus the one character time the answer's first character may take).
    let line = LineSettings::new(19200);
    let (mut m, sim) = bus(&[1], 9, 19200);
    let t0 = tokio::time::Instant::now();
    let r = m
        .submit(Order::read(102, Ind::ZERO).unwrap().to_pkw())
        .await;
    let took = t0.elapsed();
    assert!(
        matches!(
            r,
            Err(DriverError::Link(LinkError::Timeout {
                address: 9,
                attempts: 3,
                ..
            }))
        ),
        "{r:?}"
    );
    let attempt =
        line.wire_time(LAYOUT.telegram_len()) + Duration::from_millis(20) + line.char_time();
    assert!(took >= attempt * 3, "{took:?}");
    assert!(took <= attempt * 3 + Duration::from_millis(4), "{took:?}");
    let stats = m.stats();
    assert_eq!(
        (stats.transactions, stats.retries, stats.timeouts),
        (1, 2, 1)
    );
    assert!(
        r.unwrap_err()
            .to_string()
            .contains("no answer from USS address 9")
    );
    drop(m);
    sim.await.unwrap();
}

#[tokio::test(start_paused = true)]
async fn a_corrupted_answer_is_rejected_and_the_telegram_sent_again() {
    let line = LineSettings::new(19200);
    let (port, wire) = link::pair(LinkConfig::from_line(line));
    let mut drive = SimulatedDrive::new(addr(1), LAYOUT, line);
    // The drive's first answer gets one flipped data bit (parity error).
    wire.inject(Fault::Flip(1 << 3));
    let sim = tokio::spawn(async move {
        drive.serve(wire).await.unwrap();
        drive
    });
    let mut m = UssDriver::new(port, DriverConfig::new(addr(1), LAYOUT, line));
    let answer = m
        .submit(Order::read(102, Ind::ZERO).unwrap().to_pkw())
        .await
        .unwrap();
    assert_eq!(answer.pwe2, 200);
    let stats = m.stats();
    assert_eq!((stats.retries, stats.rejected, stats.timeouts), (1, 1, 0));
    drop(m);
    sim.await.unwrap();
}

#[tokio::test(start_paused = true)]
async fn the_three_word_pkw_reads_and_writes_words() {
    let line = LineSettings::new(19200);
    let layout = Layout::new(3, 2).unwrap();
    let (port, wire) = link::pair(LinkConfig::from_line(line));
    let mut drive = SimulatedDrive::new(addr(8), layout, line);
    let sim = tokio::spawn(async move {
        drive.serve(wire).await.unwrap();
        drive
    });
    let m = UssDriver::new(port, DriverConfig::new(addr(8), layout, line));
    let mut c = NordClient::new(m, ClientConfig::default());
    c.write(Address::new(102), Width::Word, Storage::Eeprom, 250)
        .await
        .unwrap();
    assert_eq!(c.read(Address::new(102)).await.unwrap(), 250);
    // An array element (AK 6) through the 3-word form.
    let sw1 = Address {
        element: Some(0),
        ..Address::new(546)
    };
    assert_eq!(c.read(sw1).await.unwrap(), 1);
    assert!(matches!(
        c.write(Address::new(102), Width::DoubleWord, Storage::Eeprom, 70000)
            .await,
        Err(ClientError::Transport(DriverError::Request(
            RequestError::Telegram(_)
        )))
    ));
    drop(c);
    let drive = sim.await.unwrap();
    assert_eq!(drive.drive().ram_value(102, 0, 0), Some(250));
}

/// Issue 18: a timeout names the line as the master really has it (the message said "parity
/// (8E1)" whatever the parity was) and the telegram layout it uses.
#[tokio::test(start_paused = true)]
async fn issue18_a_timeout_names_the_line_and_layout_in_use() {
    let line = LineSettings::new(38400).with_parity(drive_core::line::Parity::None);
    let (port, _wire) = link::pair(LinkConfig::from_line(line));
    let layout = Layout::new(3, 2).unwrap();
    let mut m = UssDriver::new(port, DriverConfig::new(addr(4), layout, line));
    let e = m
        .submit(Order::read(102, Ind::ZERO).unwrap().to_pkw())
        .await
        .unwrap_err()
        .to_string();
    assert!(e.contains("38400 8N1"), "{e}");
    assert!(!e.contains("8E1"), "{e}");
    assert!(e.contains("3 PKW + 2 PZD words"), "{e}");
}
