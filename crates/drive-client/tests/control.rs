//! The control jobs (`drive_client::control`) against the simulated drives over the wire model,
//! on tokio's paused clock: the words they send reach the states the manuals name, and the
//! stops stop.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::cell::Cell;
use std::time::Duration;

use drive_client::control::{Action, ControlError, bonfiglioli, nord, sew};
use drive_client::motor::Motion;
use drive_client::{Interrupt, Plain};
use drive_core::{Instant, LineSettings, Parity};
use drive_profile::sew::{ControlWord1, index};
use drive_transport::link::{self, LinkConfig};

/// A motion nobody interrupts, and whether it was armed.
fn motion<'a>(i: &'a Interrupt, armed: &'a Cell<bool>) -> Motion<'a> {
    Motion::new(i, armed)
}

#[tokio::test(start_paused = true)]
async fn sew_pd_over_movilink_enables_reports_and_stops_through_the_control_word_slot() {
    use movilink::driver::{DriverConfig, MovilinkDriver};
    use movilink::{Address, PduType};

    let (port, wire) = link::pair(LinkConfig::new(9600));
    let mut sim = movilink::sim::SimulatedMovidrive::new(1);
    let client = async move {
        let mut m = MovilinkDriver::new(port, DriverConfig::default());
        let addr = Address::new(1).unwrap();
        let words = vec![0x0006, 5000, 0];
        let mut link = drive_client::sew::movilink::MovilinkLink::new(&mut m, addr, "");
        let pre = sew::preflight(&mut link, 3, true, (index::RS485_TIMEOUT, "P812"), &Plain).await;
        // The factory setting: PO1 is control word 1; P812 is off, and said.
        assert_eq!(pre.slots, [0]);
        assert_eq!(pre.timeout, None);
        assert!(
            pre.warnings.iter().any(|w| w.contains("P812 is 0")),
            "{:?}",
            pre.warnings
        );
        let pdu = PduType::new(0x85).unwrap();
        let pd = sew::Pd {
            words: words.clone(),
            count: 3,
            period: Duration::from_millis(20),
        };
        let (i, armed) = (Interrupt::new(), Cell::new(false));
        let mut seen = Vec::new();
        sew::movilink_pd(&mut m, addr, pdu, &pd, &motion(&i, &armed), |pi| {
            seen.push(pi.to_vec());
            Ok::<_, ControlError>(())
        })
        .await
        .unwrap();
        assert!(armed.get());
        assert_eq!(seen.len(), 3);
        // Status word 1: unit status 4 "enable" once the enable was taken.
        assert!(
            seen.iter().all(|pi| pi.len() == 3 && pi[0] >> 8 == 4),
            "{seen:?}"
        );
        let stop = sew::PdStop::new(&words, &pre.slots, ControlWord1::STOP);
        let stopped = sew::movilink_stop(&mut m, addr, pdu, stop.as_ref())
            .await
            .unwrap();
        assert_eq!(stopped.sent, "stop (control word 0x0002)");
        assert!(stopped.reports.contains("no enable"), "{}", stopped.reports);
        // Without a control word slot there is no stop to send.
        assert!(matches!(
            sew::movilink_stop(&mut m, addr, pdu, None).await,
            Err(ControlError::NoStopWord)
        ));
    };
    tokio::select! {
        r = sim.serve(wire) => panic!("the simulator ended: {r:?}"),
        () = client => {}
    }
}

#[tokio::test(start_paused = true)]
async fn nord_control_walks_the_state_machine_and_resets_a_fault() {
    use ctt2_uss::client::{ClientConfig, NordClient};
    use ctt2_uss::serial::driver::{DriverConfig, UssDriver};
    use ctt2_uss::serial::sim::SimulatedDrive;
    use ctt2_uss::serial::{Layout, UssAddress};
    use drive_profile::nord::State;

    let line = LineSettings::new(9600);
    let a = UssAddress::new(1).unwrap();
    let (port, wire) = link::pair(LinkConfig::from_line(line));
    let mut sim = SimulatedDrive::new(a, Layout::PKW4_PZD4, line);
    let client = async move {
        let mut c = NordClient::new(
            UssDriver::new(port, DriverConfig::new(a, Layout::PKW4_PZD4, line)),
            ClientConfig::default(),
        );
        let (i, armed) = (Interrupt::new(), Cell::new(false));
        let req = |action, setpoint| nord::Control {
            action,
            setpoint,
            set: 1,
            wait: Duration::from_secs(2),
            actuals: 3,
        };
        let mut events = Vec::new();
        let mut run = async |c: &mut NordClient<_>, r: &nord::Control| {
            let out = nord::control(c, r, &motion(&i, &armed), |e| {
                events.push(e);
                Ok::<_, ControlError>(())
            })
            .await;
            out.map(|o| (o.answer.status().state(), o.last))
        };
        // Enable at 50 %: 5.1.1 shutdown, switch on, 5.1.2 enable operation.
        let enable = req(Action::Enable, Some(0x2000));
        assert_eq!(enable.sw1(), 0x2000);
        assert_eq!(
            run(&mut c, &enable).await.unwrap(),
            (State::OperationEnabled, 0x047F)
        );
        // The stop of an interrupted enable: shutdown until ready to switch on.
        let stopped = nord::shutdown(&mut c, &enable).await.unwrap();
        assert!(
            stopped.sent.starts_with("shutdown 0x047E"),
            "{}",
            stopped.sent
        );
        assert!(
            stopped.reports.contains("ready to switch on"),
            "{}",
            stopped.reports
        );
        // A reset without a fault sends nothing and says so.
        let reset = req(Action::Reset, None);
        let (state, last) = run(&mut c, &reset).await.unwrap();
        assert_eq!(last, 0);
        assert!(matches!(run(&mut c, &reset).await, Ok((_, 0))));
        assert!(matches!(events[..], [nord::Event::NoFault(s), _] if s == state));
        c
    };
    let c = tokio::select! {
        r = sim.serve(wire) => panic!("the simulator ended: {r:?}"),
        c = client => c,
    };
    drop(c);
    // Power-on (1), then 5.1.1 shutdown (2), switch on (3), 5.1.2 enable operation (4), and
    // the stop: shutdown from operation enabled (8); the resets took no transition.
    let log: Vec<&str> = sim.drive().transition_log().collect();
    assert_eq!(log, ["1", "2", "3", "4", "8"]);
    // A faulted drive: enable refuses it, reset clears it with a rising edge of bit 7.
    let (port, wire) = link::pair(LinkConfig::from_line(line));
    let mut sim = SimulatedDrive::new(a, Layout::PKW4_PZD4, line);
    sim.drive_mut().raise_fault(3, Instant::ZERO);
    let client = async move {
        let mut c = NordClient::new(
            UssDriver::new(port, DriverConfig::new(a, Layout::PKW4_PZD4, line)),
            ClientConfig::default(),
        );
        tokio::time::sleep(Duration::from_secs(1)).await;
        let (i, armed) = (Interrupt::new(), Cell::new(false));
        let r = |action| nord::Control {
            action,
            setpoint: None,
            set: 1,
            wait: Duration::from_secs(2),
            actuals: 1,
        };
        let ok = |_| Ok::<_, ControlError>(());
        let e = nord::control(&mut c, &r(Action::Enable), &motion(&i, &armed), ok).await;
        assert!(matches!(e, Err(ControlError::Faulted { .. })), "{e:?}");
        assert!(!armed.get(), "nothing that moves the motor was sent");
        let out = nord::control(&mut c, &r(Action::Reset), &motion(&i, &armed), ok)
            .await
            .unwrap();
        assert_eq!(out.answer.status().state(), State::SwitchOnDisabled);
        assert_eq!(out.last & 0x0080, 0x0080, "fault reset 0x{:04X}", out.last);
    };
    tokio::select! {
        r = sim.serve(wire) => panic!("the simulator ended: {r:?}"),
        () = client => {}
    }
    // The fault (13, 14) reset by the rising edge of bit 7 (15).
    let log: Vec<&str> = sim.drive().transition_log().collect();
    assert!(log.ends_with(&["13", "14", "15"]), "{log:?}");
}

#[tokio::test(start_paused = true)]
async fn bonfiglioli_control_takes_the_control_word_enables_and_disables_operation() {
    use bonfiglioli_modbus::driver::{DriverConfig, ModbusDriver};
    use bonfiglioli_modbus::frame::Address;
    use bonfiglioli_modbus::framing::Mode;
    use drive_profile::bonfiglioli::{State, Variant};

    let line = Mode::Rtu.line_settings(19200, Parity::Even);
    let (port, wire) = link::pair(LinkConfig::from_line(line));
    let mut sim =
        bonfiglioli_modbus::sim::bus(&[1], drive_sim::bonfiglioli::Variant::Act, Mode::Rtu, line);
    let client = async move {
        let mut m = ModbusDriver::new(port, DriverConfig::new(Mode::Rtu, line));
        let (i, armed) = (Interrupt::new(), Cell::new(false));
        let r = |action, freq| bonfiglioli::Control {
            address: Address::new(1).unwrap(),
            action,
            freq,
            variant: Variant::Act,
            front: &Plain,
        };
        let enable = r(Action::Enable, Some(500));
        let mut events = Vec::new();
        let reached = bonfiglioli::control(&mut m, &enable, &motion(&i, &armed), |e| {
            events.push(e);
            Ok::<_, ControlError>(())
        })
        .await
        .unwrap();
        // 412 was not 1 (state machine): set in RAM, and said.
        assert!(
            matches!(events[..], [bonfiglioli::Event::RemoteSet(m)] if m != 1),
            "{events:?}"
        );
        assert!(enable.done(reached.word), "0x{:04X}", reached.word);
        assert_eq!(Variant::Act.state(reached.word), State::OperationEnabled);
        assert!(reached.actual.is_some());
        let stopped = bonfiglioli::disable_operation(&mut m, &enable)
            .await
            .unwrap();
        assert_eq!(stopped.sent, "disable operation (410 = 0x0007)");
        assert!(
            stopped.reports.ends_with("switched on"),
            "{}",
            stopped.reports
        );
        // A reset without a fault: said, nothing written.
        let mut events = Vec::new();
        let reset = r(Action::Reset, None);
        let reached = bonfiglioli::control(&mut m, &reset, &motion(&i, &armed), |e| {
            events.push(e);
            Ok::<_, ControlError>(())
        })
        .await
        .unwrap();
        assert_eq!(reached.last, None);
        assert!(
            matches!(events[..], [bonfiglioli::Event::NoFault(State::SwitchedOn)]),
            "{events:?}"
        );
    };
    tokio::select! {
        r = sim.serve(wire) => panic!("the simulator ended: {r:?}"),
        () = client => {}
    }
}
