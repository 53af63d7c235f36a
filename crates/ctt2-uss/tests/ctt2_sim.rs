//! CTT2 against the simulated NORDAC LINK over the in-memory AS-i link, on tokio's paused
//! clock: transfer times of section 4.4, the error codes 1–5 of section 4.3.5 each provoked,
//! the parameter channel through `NordClient` (example 5.1.3 on the wire, the previous answer
//! until the order is done), the process data sequences of 5.1.1 and 5.1.2 through
//! `NordClient::drive_to`, and the BusIO bits acting as P480/P481 say.

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use std::time::Duration;

use ctt2_uss::client::{Address, ClientConfig, NordClient};
use ctt2_uss::ctt2::link::{SIM_PKW_TIME, SimulatedDoubleSlave, SimulatedLink, SimulatedLinkError};
use ctt2_uss::ctt2::master::{Ctt2Driver, Ctt2Link, DriverConfig, DriverError};
use ctt2_uss::ctt2::{BusIoIn, Channel, DiagnosisCode, ErrorCode, MAX_RESPONSE};
use ctt2_uss::uss::{Ind, Order, Pkw, PzdOut, Storage};
use drive_core::Instant;
use drive_profile::nord::{ControlWord, Ctt2MessageType, State, Width};

/// A link that records every exchange.
struct Tap<L> {
    inner: L,
    log: Vec<(Vec<u8>, Vec<u8>)>,
}

impl<L: Ctt2Link> Ctt2Link for Tap<L> {
    type Error = L::Error;

    async fn transact(&mut self, request: &[u8], answer: &mut [u8]) -> Result<usize, L::Error> {
        let n = self.inner.transact(request, answer).await?;
        self.log.push((request.to_vec(), answer[..n].to_vec()));
        Ok(n)
    }
}

fn link(slaves: u8) -> SimulatedLink {
    SimulatedLink::new(SimulatedDoubleSlave::default(), slaves).unwrap()
}

fn tapped(slaves: u8, config: DriverConfig) -> NordClient<Ctt2Driver<Tap<SimulatedLink>>> {
    let tap = Tap {
        inner: link(slaves),
        log: Vec::new(),
    };
    NordClient::new(Ctt2Driver::new(tap, config), ClientConfig::default())
}

async fn raw(link: &mut SimulatedLink, request: &[u8]) -> Vec<u8> {
    let mut a = [0u8; MAX_RESPONSE];
    let n = link.transact(request, &mut a).await.unwrap();
    a[..n].to_vec()
}

fn ms(t: Instant) -> f64 {
    t.as_nanos() as f64 / 1e6
}

/// Microseconds, for exact comparisons.
fn us(t: Instant) -> u64 {
    t.as_micros()
}

/// Section 4.4: with 31 slaves a byte takes 16 × 154 µs × 33 = 81.312 ms; reading the whole
/// ID object is 3 request bytes and 15 answer bytes = 18 byte times.
#[tokio::test(start_paused = true)]
async fn id_object_with_31_slaves_takes_18_byte_times() {
    let link = link(31);
    assert_eq!(link.network().slave_count(), 31);
    assert_eq!(link.byte_time(), Duration::from_micros(81_312));
    let mut master = Ctt2Driver::new(link, DriverConfig::default());
    let t0 = master.link_mut().now();
    let tokio_t0 = tokio::time::Instant::now();
    let id = master.read_id_object().await.unwrap();
    let t1 = master.link_mut().now();
    assert_eq!(id.manufacturer_id, Some(0x0189));
    assert!(id.is_complete());
    assert_eq!(
        t1.saturating_duration_since(t0),
        Duration::from_micros(18 * 81_312)
    );
    // tokio's clock agrees to its 1 ms tick.
    let tokio_elapsed = tokio_t0.elapsed();
    assert!(
        tokio_elapsed >= Duration::from_micros(18 * 81_312)
            && tokio_elapsed <= Duration::from_micros(18 * 81_312 + 2_000),
        "{tokio_elapsed:?}"
    );

    // A shorter read is faster: 3 bytes of the ID object = 3 + 4 byte times.
    let t0 = master.link_mut().now();
    let short = master.read_id(3).await.unwrap();
    assert_eq!(short.manufacturer_id, Some(0x0189));
    assert_eq!(short.device_id, None);
    let t1 = master.link_mut().now();
    assert_eq!(
        t1.saturating_duration_since(t0),
        Duration::from_micros(7 * 81_312)
    );
}

#[tokio::test(start_paused = true)]
async fn byte_time_of_the_smallest_network() {
    // The double slave alone: 2 slaves, 16 × 154 µs × 4 = 9.856 ms.
    let mut l = link(2);
    assert_eq!(l.byte_time(), Duration::from_micros(9_856));
    let t0 = l.now();
    assert_eq!(raw(&mut l, &[16, 1, 3]).await, [80, 0, 0, 45]);
    assert_eq!(us(l.now()) - us(t0), 7 * 9_856);
    assert!(SimulatedLink::new(SimulatedDoubleSlave::default(), 63).is_err());
    let mut full = link(62);
    assert_eq!(full.network().slave_count(), 62);
    assert_eq!(raw(&mut full, &[16, 1, 1]).await, [80, 0]);
}

/// Error 1: an index the double slave does not have.
#[tokio::test(start_paused = true)]
async fn error_1_invalid_index() {
    let mut l = link(2);
    assert_eq!(
        raw(&mut l, &[16, 2, 3]).await,
        [
            144, // standard read not OK
            1,   // invalid index
        ]
    );
    assert_eq!(raw(&mut l, &[18, 5, 8]).await, [146, 1]);
    assert_eq!(raw(&mut l, &[19, 0, 0]).await, [147, 1]);
    assert_eq!(raw(&mut l, &[29, 1, 3, 3, 1, 4, 0x7E]).await, [157, 1]);
    assert_eq!(l.slave().counters().errors[0], 4);
}

/// Error 2: lengths the channel does not allow, or a length byte that disagrees.
#[tokio::test(start_paused = true)]
async fn error_2_invalid_length() {
    let mut l = link(2);
    // PKW only complete.
    assert_eq!(
        raw(&mut l, &[19, 47, 7, 0, 0, 0, 0, 0, 0, 0]).await,
        [147, 2]
    );
    // PZD: a half setpoint word.
    assert_eq!(
        raw(&mut l, &[19, 3, 4, 1, 0x04, 0x7E, 0x00]).await,
        [147, 2]
    );
    // The length byte says 5, 3 bytes follow.
    assert_eq!(raw(&mut l, &[19, 3, 5, 1, 0x04, 0x7E]).await, [147, 2]);
    // Write/read with a PKW of 9 bytes on index 47.
    let mut r = vec![29, 47, 8, 9];
    r.extend([0; 9]);
    assert_eq!(raw(&mut l, &r).await, [157, 2]);
    // None of these reached the drive.
    assert_eq!(l.drive().state(), State::SwitchOnDisabled);
    assert_eq!(l.drive().control_word(), None);
}

/// Error 3: a request code the double slave does not implement, answered with 144.
#[tokio::test(start_paused = true)]
async fn error_3_not_implemented() {
    let mut l = link(2);
    assert_eq!(
        raw(&mut l, &[17, 0, 3]).await,
        [
            144, // "Standard Lese-Antwort nicht OK"
            3,   // request not implemented
        ]
    );
    assert_eq!(raw(&mut l, &[82, 1]).await, [144, 3]);
}

/// Error 4: a drive slower than the 200 ms window; the answer comes when the window ends, and
/// the request has no effect.
#[tokio::test(start_paused = true)]
async fn error_4_busy() {
    let mut l = link(2);
    l.sim_mut().set_answer_time(Duration::from_millis(250));
    let t0 = l.now();
    assert_eq!(
        raw(&mut l, &[19, 3, 5, 1, 0x04, 0x7E, 0x00, 0x00]).await,
        [
            147, // NORD write not OK
            4,   // busy
        ]
    );
    // 8 request bytes, the 200 ms window, 2 answer bytes.
    assert_eq!(us(l.now()) - us(t0), 10 * 9_856 + 200_000);
    assert_eq!(l.drive().state(), State::SwitchOnDisabled);

    // Just inside the window it works, 199 ms later than an instant drive.
    l.sim_mut().set_answer_time(Duration::from_millis(199));
    assert_eq!(
        raw(&mut l, &[19, 3, 5, 1, 0x04, 0x7E, 0x00, 0x00]).await,
        [83]
    );
    l.sim_mut().set_answer_time(Duration::ZERO);
    assert_eq!(l.drive().state(), State::ReadyToSwitchOn);

    // A USS telegram for another drive address gets no answer from the drive: error 4 too.
    assert_eq!(raw(&mut l, &[19, 3, 3, 2, 0x04, 0x00]).await, [147, 4]);
    assert_eq!(l.drive().state(), State::ReadyToSwitchOn);

    // The master repeats error 4 three times, then reports it as a typed error.
    l.sim_mut().set_answer_time(Duration::from_millis(250));
    let mut master = Ctt2Driver::new(l, DriverConfig::default());
    let e = master.read_pzd(3).await.unwrap_err();
    assert!(
        matches!(
            e,
            DriverError::Device {
                request: Ctt2MessageType::NordRead,
                error: ErrorCode::Busy,
                attempts: 4
            }
        ),
        "{e:?}"
    );
    assert_eq!(master.counters().retries, 3);
    assert!(e.to_string().contains("busy"), "{e}");
}

/// Error 5: a second request before the first was answered.
#[tokio::test(start_paused = true)]
async fn error_5_previous_request_pending() {
    let mut l = link(2);
    l.sim_mut().set_answer_time(Duration::from_millis(150));
    l.send(&[18, 3, 9]).await; // read ZSW, IW1..IW3; the drive needs 150 ms
    let t_first = l.now();
    let mut a = [0u8; MAX_RESPONSE];
    let n = l.transact(&[16, 1, 3], &mut a).await.unwrap(); // 3 bytes later: too early
    assert_eq!(
        &a[..n],
        [
            144, // standard read not OK
            5,   // previous request not yet answered
        ]
    );
    // The first request is still answered, 150 ms after it arrived.
    let n = l.receive(&mut a).await.unwrap();
    assert_eq!(&a[..n], [82, 1, 0x0B, 0x70, 0, 0, 0, 0, 0, 0]);
    assert_eq!(us(l.now()) - us(t_first), 150_000 + 10 * 9_856);
    assert_eq!(l.receive(&mut a).await, Err(SimulatedLinkError::NoRequest));
    // Afterwards all is well again.
    assert_eq!(raw(&mut l, &[16, 1, 3]).await, [80, 0, 0, 45]);
    assert_eq!(l.slave().counters().errors[4], 1);
}

/// Example 5.1.3 through `NordClient`: the order on the wire as the manual shows it (IND per
/// E4), the write's answer 83, then reads of the PKW channel until the answer fits.
#[tokio::test(start_paused = true)]
async fn pkw_write_p102_set_3_through_nord_client() {
    let mut client = tapped(2, DriverConfig::default());
    client
        .write(
            Address {
                pnu: 0x66,
                element: Some(0),
                set: 2,
            },
            Width::Word,
            Storage::Eeprom,
            1000,
        )
        .await
        .unwrap();
    let log = &client.channel().link().log;
    // "No order" first: the drive may still answer an earlier session's order (E21).
    assert_eq!(log[0].0, [19, 47, 8, 0, 0, 0, 0, 0, 0, 0, 0]);
    let w = log
        .iter()
        .position(|(request, _)| request.get(3) == Some(&0x70))
        .unwrap();
    assert_eq!(
        log[w].0,
        [
            19,   // NORD write
            47,   // PKW channel without address (the default)
            8,    // length
            0x70, // AK 7, PNU high bits
            0x66, // P102
            0x02, // IND high: parameter set 3
            0x00, // IND low
            0x00, 0x00, // PWE1
            0x03, 0xE8, // PWE2 = 1000 = 10.00 s
        ]
    );
    assert_eq!(log[w].1, [83]);
    assert_eq!(log[w + 1].0, [18, 47, 8]);
    assert_eq!(
        log.last().unwrap().1,
        [
            82,   // NORD read OK
            0x40, // AK 4: array word value
            0x66, // P102
            0x02, 0x00, // IND: set 3
            0x00, 0x00, 0x03, 0xE8, // 1000
        ]
    );
    let drive = client.channel().link().inner.drive();
    assert_eq!(drive.ram_value(102, 0, 2), Some(1000));
    assert_eq!(drive.eeprom_writes_of(102, 0, 2), Some(1));
    assert_eq!(drive.ram_value(102, 0, 0), Some(200), "set 1 untouched");

    // Read it back, and read the number of elements of P701.
    let v = client
        .read(Address {
            pnu: 102,
            element: None,
            set: 2,
        })
        .await
        .unwrap();
    assert_eq!(v, 1000);
    assert_eq!(client.count(701).await.unwrap(), 5);
    // A refusal is the drive's typed error (P701 only resettable: error 6).
    let e = client
        .write(
            Address {
                pnu: 701,
                element: Some(0),
                set: 0,
            },
            Width::Word,
            Storage::Ram,
            5,
        )
        .await
        .unwrap_err();
    assert!(e.to_string().contains("error 6"), "{e}");
}

/// The drive keeps returning its previous answer until the new order is done (sections 4.3.2,
/// 4.3.3, 4.6.1.1); before the first order, a read returns AK 7 with error 9 (erratum E17).
#[tokio::test(start_paused = true)]
async fn pkw_previous_answer_until_done() {
    let mut l = link(2);
    l.sim_mut().set_pkw_time(Duration::from_millis(500));
    let mut master = Ctt2Driver::new(l, DriverConfig::default());
    let before = master.read_pkw().await.unwrap();
    assert_eq!(before.words(), [0x7000, 0x0000, 0x0000, 0x0009]); // AK 7, PWE2 error 9
    let order = Order::write(
        0x66,
        Ind::new(0, 2).unwrap(),
        Width::Word,
        true,
        Storage::Eeprom,
        1000,
    )
    .unwrap();
    let t0 = master.link_mut().now();
    master.write_pkw(&order.to_pkw()).await.unwrap();
    let t_written = master.link_mut().now();
    let mut reads = 0;
    let answer = loop {
        let a = master.read_pkw().await.unwrap();
        reads += 1;
        if a != before {
            break a;
        }
        assert!(reads < 20);
    };
    assert_eq!(answer.words(), [0x4066, 0x0200, 0x0000, 0x03E8]);
    assert!(reads >= 4, "{reads} reads");
    // The order was done 500 ms after the write arrived.
    assert!(ms(master.link_mut().now()) - ms(t_written) >= 500.0 - 9.856);
    assert!(ms(t_written) - ms(t0) < 12.0 * 9.856 + 0.001);
    // Reads repeat the answer as often as asked.
    assert_eq!(master.read_pkw().await.unwrap(), answer);

    // The same on index 4, with the address byte.
    let mut m4 = Ctt2Driver::new(
        master.into_inner(),
        DriverConfig {
            pkw_channel: Channel::PkwWithAddress,
            ..DriverConfig::default()
        },
    );
    assert_eq!(m4.read_pkw().await.unwrap(), answer);
    m4.link_mut().sim_mut().set_pkw_time(SIM_PKW_TIME);
    let read = Order::read(0x2BD, Ind::ZERO).unwrap(); // example 5.1.4: P701 [-01]
    let mut client = NordClient::new(m4, ClientConfig::default());
    assert!(matches!(
        client.order(read).await.unwrap(),
        ctt2_uss::uss::Reply::Value { value: 0, .. }
    ));
}

/// Examples 5.1.1 and 5.1.2 through `NordClient::drive_to` over CTT2 write/read messages.
#[tokio::test(start_paused = true)]
async fn pzd_sequences_through_drive_to() {
    let mut client = tapped(2, DriverConfig::default());
    let answer = client
        .drive_to(State::ReadyToSwitchOn, &[0], 0)
        .await
        .unwrap();
    assert_eq!(answer.status().0, 0x0B31);
    let log = &client.channel().link().log;
    // First the state is read with "disable voltage" (0400h): switch-on disabled, 0B40h (bit 4
    // = 0 while the command is present); then 047Eh takes it to 0B31h.
    assert_eq!(log[0].0[5..7], [0x04, 0x00]);
    assert_eq!(log[0].1, [93, 1, 0x0B, 0x40, 0x00, 0x00]);
    let (req, ans) = log.last().unwrap();
    assert_eq!(
        req,
        &[
            29, // NORD write/read
            3,  // PZD channel
            5,  // read length: address + ZSW + IW1
            5,  // write length: address + STW + SW1
            1,  // drive address
            0x04, 0x7E, // STW: shut down
            0x00, 0x00, // SW1
        ]
    );
    assert_eq!(ans, &[93, 1, 0x0B, 0x31, 0x00, 0x00]);

    let answer = client
        .drive_to(State::OperationEnabled, &[0x2000], 0)
        .await
        .unwrap();
    assert_eq!(answer.status().0 & 0x00FF, 0x37);
    let t0 = client.channel_mut().link_mut().inner.now();
    let mut last = answer;
    for _ in 0..30 {
        if last.status().0 == 0x0B37 {
            break;
        }
        last = client
            .process(ControlWord(0x047F), &[0x2000], 1)
            .await
            .unwrap();
    }
    assert_eq!(last.status().0, 0x0B37); // operation enabled, setpoint reached
    assert_eq!(last.actuals(), &[0x2000]); // IW1 = 50 %
    // P102 = 2.00 s for 0 → 50 Hz: 50 % takes about 1 s.
    let elapsed = ms(client.channel_mut().link_mut().inner.now()) - ms(t0);
    assert!((700.0..1300.0).contains(&elapsed), "{elapsed} ms");
    let (req, _) = &client.channel().link().log.last().unwrap().clone();
    assert_eq!(&req[4..9], &[1, 0x04, 0x7F, 0x20, 0x00]);
}

/// The diagnosis object follows the drive's fault.
#[tokio::test(start_paused = true)]
async fn diagnosis_shows_a_fault() {
    let mut master = Ctt2Driver::new(link(2), DriverConfig::default());
    let d = master.read_diagnosis().await.unwrap();
    assert_eq!(d.code, Some(DiagnosisCode::NoFault));
    let now = master.link_mut().now();
    master.link_mut().drive_mut().raise_fault(7, now);
    let d = master.read_diagnosis().await.unwrap();
    assert_eq!(d.code, Some(DiagnosisCode::Fault));
    assert_eq!(d.fault, Some(7));
    assert_eq!(d.temperature, Some(45));
}

/// The BusIO bits beside CTT2 act as P480/P481 say: P509 := 0 (not AS-i) over CTT2, then
/// BusIO In bit 1 (P480 [-01] = 1, enable right) enables the drive and BusIO Out bits 1–3
/// (ready, fault active low, running) report it; P480 [-04] := 11 (quick stop, active low) over
/// CTT2 makes In bit 4 = 0 a quick stop.
#[tokio::test(start_paused = true)]
async fn busio_bits_act_per_p480_p481() {
    let mut client = tapped(2, DriverConfig::default());
    client
        .write(Address::new(509), Width::Word, Storage::Ram, 0)
        .await
        .unwrap();
    let link = &mut client.channel_mut().link_mut().inner;
    // Under BusIO control without an enable bit the drive waits in "ready to switch on".
    let out = link.exchange_busio(BusIoIn::new(0)).unwrap();
    assert_eq!(link.drive().state(), State::ReadyToSwitchOn);
    assert!(out.bit(1) && out.bit(2) && !out.bit(3), "{out:?}"); // ready, no fault, stopped
    let enable = BusIoIn::new(0).with(1, true);
    let mut out = link.exchange_busio(enable).unwrap();
    for _ in 0..10 {
        tokio::time::sleep(Duration::from_millis(5)).await;
        out = link.exchange_busio(enable).unwrap();
    }
    assert_eq!(link.drive().state(), State::OperationEnabled);
    assert_eq!(out.bits() & 0b111, 0b111, "{out:?}"); // ready, no fault, running
    let id = first_id(link);
    assert_eq!(link.network().inputs(id).unwrap(), out);

    // P480 [-04] := 11, quick stop: a non-set array parameter, so NordClient puts the element
    // into IND bits 8..15 as the sub-index (before IndLayout it put it into bits 10..15, and
    // the drive wrote element [-01]).
    let at = Address {
        pnu: 480,
        element: Some(3),
        set: 0,
    };
    client
        .write(at, Width::Word, Storage::Ram, 11)
        .await
        .unwrap();
    assert_eq!(
        client.channel().link().inner.drive().ram_value(480, 0, 0),
        Some(1),
        "element [-01] untouched"
    );
    let link = &mut client.channel_mut().link_mut().inner;
    assert_eq!(link.drive().ram_value(480, 3, 0), Some(11));
    let mut out = link.exchange_busio(enable).unwrap(); // bit 4 = 0: quick stop
    for _ in 0..50 {
        tokio::time::sleep(Duration::from_millis(10)).await;
        out = link.exchange_busio(enable).unwrap();
    }
    assert_eq!(link.drive().state(), State::SwitchOnDisabled);
    assert!(!out.bit(3), "not running: {out:?}");
    // Bit 4 = 1 lifts the quick stop, and the enable on bit 1 runs the drive up again.
    let both = enable.with(4, true);
    for _ in 0..10 {
        tokio::time::sleep(Duration::from_millis(5)).await;
        out = link.exchange_busio(both).unwrap();
    }
    assert_eq!(link.drive().state(), State::OperationEnabled);
    assert!(out.bit(3));
}

fn first_id(link: &SimulatedLink) -> ctt2_uss::ctt2::asi::DoubleSlaveId {
    link.network()
        .double_slave_at(ctt2_uss::ctt2::AsiAddress::new(1, ctt2_uss::ctt2::Bank::B).unwrap())
        .unwrap()
}

#[tokio::test(start_paused = true)]
async fn pzd_write_and_read_separately() {
    let mut master = Ctt2Driver::new(link(2), DriverConfig::default());
    master
        .write_pzd(&PzdOut::new(ControlWord(0x047E), &[]))
        .await
        .unwrap();
    let pzd = master.read_pzd(0).await.unwrap();
    assert_eq!(pzd.status().0, 0x0B31);
    assert!(pzd.actuals().is_empty());
    let pzd = master.read_pzd(3).await.unwrap();
    assert_eq!(pzd.actuals().len(), 3);
    // A raw PKW channel with a reserved AK: the drive answers AK 7, error 201.
    master
        .write_pkw(&Pkw::from_words([0x4066, 0, 0, 0]))
        .await
        .unwrap();
    assert_eq!(
        master.read_pkw().await.unwrap().words(),
        [0x7066, 0, 0, 201]
    );
}
