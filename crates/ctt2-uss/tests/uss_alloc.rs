//! Encode, decode, the receiver with USS framing and whole master ↔ slave exchanges do not
//! allocate: a counting global allocator sees no allocation while they run (it counts the test
//! thread's allocations only).

// A failing fixture is a failing test: panicking is the report.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

#[path = "uss_common/bus.rs"]
mod bus;

use ctt2_uss::serial::framing::{Side, UssFraming, UssReceiver};
use ctt2_uss::serial::master::{MasterConfig, MasterEvent, UssMaster};
use ctt2_uss::serial::slave::{Slave, SlaveConfig};
use ctt2_uss::serial::telegram::{Adr, Layout, MAX_TELEGRAM, Telegram, UssAddress};
use ctt2_uss::uss::pkw::{Ind, Order};
use drive_core::alloc_count::CountingAllocator;
use drive_core::{Instant, LineSettings, RxChar, RxEvent};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

#[test]
fn nothing_allocates() {
    let line = LineSettings::new(19200);
    let a = UssAddress::new(7).unwrap();
    let order = Order::read(102, Ind::ZERO).unwrap().to_pkw();
    let layouts = [
        Layout::PKW4_PZD2,
        Layout::new(3, 16).unwrap(),
        Layout::new(0, 1).unwrap(),
    ];
    let mut receivers =
        layouts.map(|l| UssReceiver::new(UssFraming::new(Side::Slave(a), l, &line)));
    let mut bus = bus::Bus::new(
        UssMaster::new(MasterConfig::new(line)),
        vec![Slave::new(
            SlaveConfig::new(a, Layout::PKW4_PZD2, line),
            bus::Store::default(),
        )],
    );
    let before = CountingAllocator::count();

    let mut frames = 0usize;
    let mut t = 0u64;
    for (l, rx) in layouts.iter().zip(receivers.iter_mut()) {
        let words = [0x047E; 16];
        let telegram =
            Telegram::new(Adr::new(a), *l, order, &words[..usize::from(l.pzd_words())]).unwrap();
        let mut wire = [0u8; MAX_TELEGRAM];
        let n = telegram.encode(&mut wire).unwrap();
        assert_eq!(Telegram::decode(&wire[..n], *l), Ok(telegram));
        t += 10_000_000;
        for b in &wire[..n] {
            t += 572_917;
            if let Some(RxEvent::Frame(_)) = rx.handle_char(RxChar::new(*b, Instant::from_nanos(t)))
            {
                frames += 1;
            }
        }
        while let Some(at) = rx.poll_timeout() {
            if let Some(RxEvent::Frame(_)) = rx.handle_timeout(at) {
                frames += 1;
            }
        }
    }
    // Master ↔ slave: 100 reads through the receivers and state machines.
    let request = Telegram::new(Adr::new(a), Layout::PKW4_PZD2, order, &[0x047E, 0]).unwrap();
    let mut answers = 0;
    for _ in 0..100 {
        let now = bus.now;
        bus.master.send(request, now).unwrap();
        assert!(bus.run(|e| {
            if let MasterEvent::Response(_) = e {
                answers += 1;
            }
        }));
    }

    let after = CountingAllocator::count();
    assert_eq!(frames, 3, "every telegram received");
    assert_eq!(answers, 100, "every read answered");
    assert_eq!(
        after - before,
        0,
        "allocations during encode/decode/receive/exchange"
    );
}
