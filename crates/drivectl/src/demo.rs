//! `drivectl demo`: the main job on an embedded default.
//!
//! It walks through what drivebus knows without any hardware: the parameter tables of every
//! family with their scaling, the DRIVECOM-style state machines driven by control words, a
//! MOVILINK session, an SBus session (on a virtual CAN bus, on a virtual clock), a Bonfiglioli
//! Modbus session (RTU and ASCII) and a NORD CTT2 session (through a simulated AS-i master, on
//! a virtual clock) against simulated drives.

use crate::error::CliError;
use crate::error::Result;
use crate::params::{all, lookup};
use crate::tool::output::trim_float;
use clap::Args;
use drive_profile::Family;
use drive_profile::bonfiglioli::{self, ActStateMachine};
use drive_profile::nord::{self, NordStateMachine};
use drive_profile::state::StateMachine;

/// Examples below `drivectl demo --help`.
const AFTER_HELP: &str = "\
Examples:
  drivectl demo                  tables, state machines, simulated MOVILINK, SBus, Modbus and CTT2 sessions
  drivectl demo | less           page through it";

/// Arguments of `drivectl demo`: none; it runs without hardware, on simulated drives.
#[derive(Debug, Args)]
#[command(after_help = AFTER_HELP)]
pub struct DemoArgs {}

/// Run the demonstration.
pub fn run(_args: &DemoArgs) -> Result<()> {
    outln!("drivebus demo: everything below runs without hardware.\n")?;
    tables()?;
    nord_walk()?;
    bonfiglioli_walk()?;
    let rt = crate::tool::line::runtime()?;
    rt.block_on(movilink_session())?;
    // The CAN frame times run on a virtual clock too: exact and deterministic.
    crate::tool::line::runtime()?.block_on(async {
        tokio::time::pause();
        sbus_session().await
    })?;
    rt.block_on(bonfiglioli_session())?;
    // The AS-i transfer times run on a virtual clock: counted exactly, not waited.
    crate::tool::line::runtime()?.block_on(async {
        tokio::time::pause();
        nord_session().await
    })?;
    Ok(())
}

fn tables() -> Result<()> {
    outln!("== Parameter tables generated from the manuals")?;
    for family in Family::ALL {
        outln!(
            "  {:<12} {:>4} parameters",
            family.name(),
            all(family).len()
        )?;
    }
    outln!()?;
    let samples = [
        (Family::Movidrive, "8318", 1_000_000),
        (Family::Movidrive, "P813", 5),
        (Family::Nord, "P102", 1000),
        (Family::Bonfiglioli, "1376", 1),
    ];
    for (family, key, raw) in samples {
        let p = lookup(family, key)?;
        outln!(
            "  {:<12} {:<8} {:<28} index {:>5}: raw {raw} = {} {}",
            family.name(),
            p.label(),
            p.name_en(),
            p.bus_index(),
            trim_float(p.to_physical(raw), p.decimals()),
            p.unit()
        )?;
    }
    outln!()?;
    Ok(())
}

/// How many control words a walk may take before the demo calls it stuck.
const MAX_STEPS: usize = 8;

/// NORD: drive the state machine from switch-on disabled to operation enabled and back, with a
/// drive that follows the manual's transition table.
fn nord_walk() -> Result<()> {
    use nord::State;
    outln!("== NORD state machine (control word → status word)")?;
    let status_of = |s: State| nord::state_info(s).map_or(0, |i| i.value);
    let mut state = State::SwitchOnDisabled;
    let mut last = 0u16;
    for target in [State::OperationEnabled, State::SwitchOnDisabled] {
        outln!("  target: {}", target.name_en())?;
        for _ in 0..MAX_STEPS {
            let status = status_of(state);
            let decoded = NordStateMachine::decode(status);
            let Some(word) = NordStateMachine::next_control(last, decoded, target) else {
                break;
            };
            let next = nord::transitions()
                .iter()
                .find(|t| t.from.is_none_or(|f| f == decoded) && t.triggered_by(last, word))
                .map_or(decoded, |t| t.to);
            outln!(
                "    status 0x{status:04X} {:<24} send 0x{word:04X} → {}",
                decoded.name_en(),
                next.name_en()
            )?;
            last = word;
            state = next;
        }
        if state != target {
            return Err(CliError::failed(format!(
                "NORD walk stuck in {}",
                state.name_en()
            )));
        }
    }
    outln!()?;
    Ok(())
}

/// Bonfiglioli ACT: the same walk, using the shortcut transition 4 from switch-on disabled.
fn bonfiglioli_walk() -> Result<()> {
    use bonfiglioli::State;
    outln!("== Bonfiglioli ACT state machine (control word 410 → status word 411)")?;
    let status_of = |s: State| {
        bonfiglioli::state::ACT_PATTERNS
            .iter()
            .find(|p| p.state == s)
            .map_or(0, |p| p.value)
    };
    let mut state = State::SwitchOnDisabled;
    for target in [State::OperationEnabled, State::SwitchOnDisabled] {
        outln!("  target: {target}")?;
        for _ in 0..MAX_STEPS {
            let status = status_of(state);
            let decoded = ActStateMachine::decode(status);
            let Some(word) = ActStateMachine::control_toward(decoded, target) else {
                break;
            };
            let next = bonfiglioli::act_transitions()
                .find(|t| t.from == decoded && t.word == word)
                .map_or(decoded, |t| t.to);
            outln!(
                "    status 0x{status:04X} {:<24} send 0x{word:04X} → {next}",
                decoded.name_en()
            )?;
            state = next;
        }
        if state != target {
            return Err(CliError::failed(format!("ACT walk stuck in {state}")));
        }
    }
    outln!()?;
    Ok(())
}

/// A MOVILINK session against two simulated MOVIDRIVEs over an in-memory RS-485 link with
/// 9600-baud wire timing: scan, identify, read and write parameters, enable, watch the speed
/// ramp, stop.
async fn movilink_session() -> Result<()> {
    use crate::movilink::{driver_error, firmware_text, raw_of, resolve};
    use crate::tool::output::print_value;
    use drive_profile::sew::{ControlWord1, StatusWord1, index};
    use drive_transport::link::{LinkConfig, pair};
    use movilink::driver::{DriverConfig, MovilinkDriver as MasterDriver, ParamServices};
    use movilink::sim;
    use movilink::{Address, PduType, Telegram};
    use std::time::Duration;

    outln!(
        "== MOVILINK session: master ↔ simulated MOVIDRIVEs at 1 and 5, 9600 baud 8E1 wire model"
    )?;
    let (master_end, drive_end) = pair(LinkConfig::new(9600));
    let sim = tokio::spawn(async move {
        let mut bus = sim::bus(&[1, 5], movilink::timing::LINE);
        bus.serve(drive_end).await
    });
    let mut m = MasterDriver::new(master_end, DriverConfig::default());
    let started = tokio::time::Instant::now();

    outln!("  scan 0…9:")?;
    let mut found = Vec::new();
    for a in 0..=9u8 {
        let addr = Address::new(a).ok_or_else(|| CliError::failed("bad address"))?;
        if let Some(device_type) = m
            .probe(addr, Duration::from_millis(20))
            .await
            .map_err(driver_error)?
        {
            let fw = m.read(addr, index::FIRMWARE).await.map_err(driver_error)?;
            outln!(
                "    address {a}: device type {device_type}, firmware {}",
                firmware_text(fw)
            )?;
            found.push(addr);
        }
    }
    let drive = *found
        .first()
        .ok_or_else(|| CliError::failed("the simulated drives did not answer the scan"))?;

    outln!("  parameters of drive {}:", drive.get())?;
    for key in ["P000", "P130", "P812"] {
        let t = resolve(key)?;
        let data = m.read(drive, t.index).await.map_err(driver_error)?;
        out!("    ")?;
        print_value(&t, raw_of(&t, data), false)?;
    }
    let p130 = resolve("P130")?;
    outln!("    write P130 = 0.5 s (volatile: RAM only, no EEPROM wear)")?;
    m.write_volatile(drive, p130.index, 500)
        .await
        .map_err(driver_error)?;
    let data = m.read(drive, p130.index).await.map_err(driver_error)?;
    out!("    ")?;
    print_value(&p130, raw_of(&p130, data), false)?;

    outln!(
        "  enable: PO1 = 0x0006 (control word 1: enable), PO2 = 5000 (1000 1/min), type 0x05 cyclic"
    )?;
    let mut last_speed = 0.0;
    for (phase, control, target) in [
        ("ramp up", ControlWord1::ENABLE, 1000.0),
        ("stop", ControlWord1::STOP, 0.0),
    ] {
        if phase == "stop" {
            outln!("  stop: PO1 = 0x0002 (control word 1: stop on the ramp)")?;
        }
        for _ in 0..40 {
            let request = Telegram::request(drive, PduType::PD3).with_process_data(&[
                control.bits(),
                5000,
                0,
            ]);
            let response = m.exchange(request).await.map_err(driver_error)?;
            let pi = response.process_data();
            let status = pi.first().copied().unwrap_or(0);
            let speed = drive_profile::sew::speed_from_word(pi.get(1).copied().unwrap_or(0));
            outln!(
                "    t = {:>5.0} ms  PI1 0x{status:04X} ({})  speed {speed:>6.1} 1/min",
                started.elapsed().as_secs_f64() * 1000.0,
                StatusWord1::from_bits(status)
            )?;
            last_speed = speed;
            if (speed - target).abs() < 0.5 {
                break;
            }
            tokio::time::sleep(Duration::from_millis(60)).await;
        }
    }
    let stats = m.stats();
    outln!(
        "  {} transactions, {} retries, {} timeouts in {:.2} s",
        stats.transactions,
        stats.retries,
        stats.timeouts,
        started.elapsed().as_secs_f64()
    )?;
    drop(m);
    sim.abort();
    if last_speed.abs() >= 0.5 {
        return Err(CliError::failed(format!(
            "the simulated drive did not stop (speed {last_speed} 1/min)"
        )));
    }
    outln!()?;
    Ok(())
}

/// The frames a sniffer node has received so far, with their times.
async fn sniffed(
    node: &mut drive_transport::can::virtual_bus::VirtualNode,
) -> Result<Vec<drive_core::rt::ReceivedFrame>> {
    let mut v = Vec::new();
    while node.pending_rx() > 0 {
        let f = drive_core::rt::recv_frame(node)
            .await
            .map_err(|e| CliError::failed(format!("demo: the virtual bus: {e}")))?;
        v.push(f);
    }
    Ok(v)
}

/// An SBus session on a virtual CAN bus at 500 kbit/s against two simulated MOVIDRIVEs (SBus
/// addresses 1 and 2), on tokio's paused clock: the identifiers, a scan, reads in both
/// handshake modes (the sync-mode answer after the SYNC, measured from the frame times),
/// synchronous and asynchronous process data with the speeds ramping, a volatile write, a group
/// write, the stop, and a MOVLNK command executed by drive 1 towards drive 2.
async fn sbus_session() -> Result<()> {
    use crate::sbus::link::driver_error;
    use drive_core::can::Bitrate;
    use drive_profile::sew::{ControlWord1, ParamChannel, StatusWord1, index, speed_from_word};
    use drive_transport::can::virtual_bus::VirtualBus;
    use sbus_can::driver::{ParamServices, SbusDriver};
    use sbus_can::ids::{Kind, SlaveIds};
    use sbus_can::master::{Handshake, MasterConfig};
    use sbus_can::movlnk::{MlData, MovlnkCommand};
    use sbus_can::sim::SimulatedSbusBus;
    use sbus_can::{Address, ProcessData};
    use std::time::Duration;
    use tokio::time::Instant;

    let bad = |what: String| CliError::failed(format!("demo: {what}"));
    let addr = |a: u8| Address::new(a).ok_or_else(|| bad(format!("address {a}")));
    outln!(
        "== SBus session: master ↔ simulated MOVIDRIVEs at SBus addresses 1 and 2, virtual CAN bus \
         500 kbit/s (virtual clock)"
    )?;
    let vbus = VirtualBus::new(Bitrate::K500);
    let mut sniffer = vbus.node();
    let drives_node = vbus.node();
    let mut drives = SimulatedSbusBus::new(&[1, 2]);
    let ipos = drives
        .movlnk_handle(1)
        .ok_or_else(|| bad("no simulated drive 1".into()))?;
    let sim = tokio::spawn(async move { drives.serve(drives_node).await });
    let mut m = SbusDriver::new(vbus.node(), MasterConfig::default());
    let started = Instant::now();
    let ms = |t: Instant| t.saturating_duration_since(started).as_secs_f64() * 1e3;
    let (d1, d2) = (addr(1)?, addr(2)?);

    for a in [d1, d2] {
        let ids = SlaveIds {
            address: a,
            group: addr(0)?,
            sync_id: 0,
        };
        let id = |k: Kind| {
            ids.uses()
                .iter()
                .find(|u| u.kind == Some(k))
                .map_or(0, |u| u.id)
        };
        outln!(
            "  identifiers of drive {a} (P813 = {a}, P814 group 0, P817 SYNC 0): request {}, \
             response {}, PO {}, PI {}, PO sync {}; group: request {}, GPO {}",
            id(Kind::ParamRequest),
            id(Kind::ParamResponse),
            id(Kind::ProcessOutput),
            id(Kind::ProcessInput),
            id(Kind::ProcessOutputSync),
            id(Kind::GroupParamRequest),
            id(Kind::GroupProcessOutput),
        )?;
    }

    let hits = m.scan(addr(0)?, addr(63)?).await.map_err(driver_error)?;
    let found: Vec<String> = hits
        .iter()
        .map(|h| match h.unit_type {
            Ok(t) => format!("{} (P070 unit type {t})", h.address),
            Err(rc) => format!("{} ({rc})", h.address),
        })
        .collect();
    outln!(
        "  scan 0…63 (P070 to every address at once): {} (t = {:.1} ms)",
        found.join(", "),
        ms(Instant::now())
    )?;

    sniffed(&mut sniffer).await?;
    let p000 = m
        .param_with(d1, ParamChannel::read(index::SPEED), Handshake::Async)
        .await
        .map_err(driver_error)?;
    let frames = sniffed(&mut sniffer).await?;
    let gap = |a: Instant, b: Instant| b.saturating_duration_since(a).as_secs_f64() * 1e3;
    let (req, resp) = (frames.first(), frames.last());
    if let (Some(q), Some(r)) = (req, resp) {
        outln!(
            "  read P000 of drive 1, handshake bit 0 (answer at once): {} 1/min, answer {:.3} ms \
             after the request (frame end to frame end: the answer's own frame time)",
            p000.data as i32 / 1000,
            gap(q.at, r.at)
        )?;
    }
    m.param_with(d1, ParamChannel::read(index::SPEED), Handshake::Sync)
        .await
        .map_err(driver_error)?;
    let frames = sniffed(&mut sniffer).await?;
    let request = frames.first();
    let sync = frames.iter().find(|f| f.frame.raw_id() == 0);
    let answer = frames.iter().find(|f| f.frame.raw_id() == 524);
    match (request, sync, answer) {
        (Some(q), Some(s), Some(r)) => outln!(
            "  read P000 of drive 1, handshake bit 1 (answer after the SYNC): SYNC {:.3} ms \
             after the request, answer {:.3} ms after the SYNC",
            gap(q.at, s.at),
            gap(s.at, r.at)
        )?,
        _ => {
            return Err(bad(
                "the sync-mode read left no SYNC and answer on the bus".into()
            ));
        }
    }

    let pd = |control: ControlWord1, speed: u16| ProcessData([control.bits(), speed, 0]);
    sniffed(&mut sniffer).await?;
    let p1 = m
        .process_data_sync(d1, pd(ControlWord1::ENABLE, 5000))
        .await
        .map_err(driver_error)?;
    let frames = sniffed(&mut sniffer).await?;
    let po = frames.iter().find(|f| f.frame.raw_id() == 13);
    let pi = frames.iter().find(|f| f.frame.raw_id() == 12);
    let sync = po.and_then(|po| {
        frames
            .iter()
            .find(|f| f.frame.raw_id() == 0 && f.at > po.at)
    });
    match (po, sync, pi) {
        (Some(po), Some(s), Some(pi)) => outln!(
            "  enable drive 1 by PO sync 0x0006/5000 (1000 1/min) on 13: taken at the SYNC {:.3} ms \
             later, PI 0x{:04X} {:.3} ms after the SYNC (in the cycle's first millisecond)",
            gap(po.at, s.at),
            p1.0[0],
            gap(s.at, pi.at)
        )?,
        _ => return Err(bad("the PO sync left no SYNC and PI on the bus".into())),
    }
    outln!(
        "  PO 0x0006/2500 (500 1/min) to drive 2 on 19, answered at once; every 40 ms PO to both, \
         SYNC every 5 ms:"
    )?;
    let show = |t: Instant, p1: ProcessData, p2: ProcessData| {
        let [s1, n1, _] = p1.0;
        let [s2, n2, _] = p2.0;
        outln!(
            "    t = {:>5.0} ms  drive 1: PI1 0x{s1:04X} ({}) {:>6.1} 1/min  drive 2: PI1 0x{s2:04X} \
             {:>6.1} 1/min",
            ms(t),
            StatusWord1::from_bits(s1),
            speed_from_word(n1),
            speed_from_word(n2)
        )
    };
    let mut last = (ProcessData::default(), ProcessData::default());
    for (control, targets) in [
        (ControlWord1::ENABLE, (1000.0, 500.0)),
        (ControlWord1::STOP, (0.0, 0.0)),
    ] {
        if control == ControlWord1::STOP {
            let p130 = crate::movilink::resolve("P130")?;
            m.write_volatile(d2, index::RAMP_T11_UP_CW, 500)
                .await
                .map_err(driver_error)?;
            let back = m
                .read(d2, index::RAMP_T11_UP_CW)
                .await
                .map_err(driver_error)?;
            outln!(
                "  write P130 of drive 2 = 0.5 s, volatile (service 3: RAM only, no EEPROM wear): \
                 reads back {}",
                p130.param.map_or_else(
                    || back.to_string(),
                    |p| crate::tool::output::physical_text(p, i64::from(back))
                )
            )?;
            m.group_write(
                addr(0)?,
                ParamChannel::write_volatile(index::RAMP_T11_DOWN_CW, 500),
            )
            .await
            .map_err(driver_error)?;
            let r1 = m
                .read(d1, index::RAMP_T11_DOWN_CW)
                .await
                .map_err(driver_error)?;
            let r2 = m
                .read(d2, index::RAMP_T11_DOWN_CW)
                .await
                .map_err(driver_error)?;
            outln!(
                "  group write P131 ramp down = 0.5 s to group 0 (518, never answered): drive 1 \
                 reads {r1} ms, drive 2 {r2} ms"
            )?;
            outln!("  stop: PO1 = 0x0002 (control word 1: stop on the ramp) to both")?;
        }
        let (w1, w2) = if control == ControlWord1::STOP {
            (0, 0)
        } else {
            (5000, 2500)
        };
        for i in 0..40 {
            let p1 = m
                .process_data(d1, pd(control, w1))
                .await
                .map_err(driver_error)?;
            let p2 = m
                .process_data(d2, pd(control, w2))
                .await
                .map_err(driver_error)?;
            last = (p1, p2);
            let done = (speed_from_word(p1.0[1]) - targets.0).abs() < 0.5
                && (speed_from_word(p2.0[1]) - targets.1).abs() < 0.5;
            if done || i % 4 == 0 {
                show(Instant::now(), p1, p2)?;
            }
            if done {
                break;
            }
            // SYNC every 5 ms in between (P815 is 100 ms: process data every 40 ms keep it).
            m.sync_for(Duration::from_millis(40))
                .await
                .map_err(driver_error)?;
        }
    }
    let (p1, p2) = last;
    if speed_from_word(p1.0[1]).abs() >= 0.5 || speed_from_word(p2.0[1]).abs() >= 0.5 {
        return Err(bad("the simulated drives did not stop".into()));
    }

    // MOVLNK: the manual's ch. 5.3 command from drive 1 to drive 2, PO 0x0002 (stop), 0, 0.
    // The master stays silent meanwhile: MOVLNK allows one master on the bus.
    let cmd = MovlnkCommand::from_vars([5, 2, 4, 1, i32::from(index::SPEED), 20, 0])
        .map_err(|e| bad(e.to_string()))?;
    let data = MlData::from_vars([0, 0, 2, 0, 0, 0, 0, 0]);
    let done = ipos
        .execute(cmd, data)
        .await
        .map_err(|e| bad(e.to_string()))?;
    let [pi1, pi2, _] = done.data.pi;
    outln!(
        "  MOVLNK executed by drive 1 (BusType 5, Address 2, Format 4 = Param + 3PD, Service 1 \
         read, Index 8318, PO 0x0002/0/0; the PC stays silent: one master): Result {}, ReadPar {} \
         (P000 of drive 2), PI1 0x{pi1:04X}, PI2 {pi2}",
        done.result,
        done.data.read_par
    )?;
    if done.result != 0 {
        return Err(bad(format!("MOVLNK Result {}", done.result)));
    }
    let stats = m.stats();
    outln!(
        "  {} transactions, {} SYNCs, {} frames on the bus, {} retries, {} timeouts in {:.2} s",
        stats.transactions,
        stats.syncs_sent,
        vbus.frames(),
        stats.retries,
        stats.timeouts,
        started.elapsed().as_secs_f64()
    )?;
    drop(m);
    sim.abort();
    outln!()?;
    Ok(())
}

/// A Bonfiglioli session against a simulated ACTIVE Cube over an in-memory RS-485 link with
/// 19200-baud wire timing, in Modbus RTU and then ASCII: the manual's examples, an exception
/// with its VABus cause, the diagnostic counters, and (RTU) a run-up through the state machine.
async fn bonfiglioli_session() -> Result<()> {
    use bonfiglioli_modbus::driver::{DriverConfig, DriverError, ModbusDriver as MasterDriver};
    use bonfiglioli_modbus::frame::{Address, DataSet, DiagSubFunction};
    use bonfiglioli_modbus::framing::Mode;
    use bonfiglioli_modbus::sim;
    use bonfiglioli_modbus::slave::Width;
    use drive_profile::bonfiglioli::AcuStateMachine;
    use drive_sim::bonfiglioli::Variant;
    use drive_transport::link::{LinkConfig, pair};
    use std::time::Duration;

    let failed = |e: DriverError| CliError::failed(e.to_string());
    let bad = |what: &str| CliError::failed(format!("demo: {what}"));
    for mode in [Mode::Rtu, Mode::Ascii] {
        let line = mode.line_settings(19200, drive_core::Parity::Even);
        outln!(
            "== Bonfiglioli session: master ↔ simulated ACTIVE Cube at address 1, Modbus {mode}, 19200 baud wire model"
        )?;
        let (master_end, drive_end) = pair(LinkConfig::from_line(line));
        let sim = tokio::spawn(async move {
            let mut bus = sim::bus(&[1], Variant::Acu, mode, line);
            bus.serve(drive_end).await
        });
        let mut m = MasterDriver::new(master_end, DriverConfig::new(mode, line));
        let started = tokio::time::Instant::now();
        let d = Address::new(1).ok_or_else(|| bad("address"))?;
        let ds = |n| DataSet::new(n).ok_or_else(|| bad("data set"));
        let rated = m.read(d, 372, ds(2)?, Width::Word).await.map_err(failed)?;
        outln!("  read 372 rated speed, data set 2 (FC 3, start address 0x2174): {rated} 1/min")?;
        m.write(d, 376, ds(4)?, Width::Word, 15)
            .await
            .map_err(failed)?;
        outln!("  write 376 rated mechanical power = 1.5 kW in data set 4 (FC 6, raw 15): echoed")?;
        let f2 = m
            .read(d, 481, DataSet::ALL, Width::Long)
            .await
            .map_err(failed)?;
        outln!(
            "  read 481 fixed frequency 2 (FC 100, 32 bits): {} Hz",
            trim_float(f64::from(f2) / 100.0, 2)
        )?;
        match m.write(d, 376, ds(2)?, Width::Word, 0).await {
            Err(e @ DriverError::Device { .. }) => outln!("  write 376 = 0 kW: {e}")?,
            other => return Err(bad(&format!("376 = 0 was not refused: {other:?}"))),
        }
        let msgs = m
            .diagnostics(d, DiagSubFunction::SLAVE_MESSAGES)
            .await
            .map_err(failed)?;
        let excs = m
            .diagnostics(d, DiagSubFunction::BUS_EXCEPTION_ERRORS)
            .await
            .map_err(failed)?;
        outln!("  FC 8 counters: {msgs} messages for this drive, {excs} exception answer(s)")?;
        if mode == Mode::Rtu {
            outln!("  412 = 1 (state machine), 484 = 10.00 Hz, 410 = 0x06, 0x07, 0x0F:")?;
            m.write(d, 412, ds(5)?, Width::Word, 1)
                .await
                .map_err(failed)?;
            m.write(d, 484, DataSet::ALL, Width::Long, 1000)
                .await
                .map_err(failed)?;
            for word in [0x06, 0x07, 0x0F] {
                m.write(d, 410, DataSet::ALL, Width::Word, word)
                    .await
                    .map_err(failed)?;
            }
            let mut hz = 0.0;
            for _ in 0..40 {
                let status = m
                    .read(d, 411, DataSet::ALL, Width::Word)
                    .await
                    .map_err(failed)? as u16;
                let f = m
                    .read(d, 241, DataSet::ALL, Width::Long)
                    .await
                    .map_err(failed)?;
                hz = f64::from(f) / 100.0;
                outln!(
                    "    t = {:>5.0} ms  411 = 0x{status:04X} ({})  actual frequency {hz:>5.2} Hz",
                    started.elapsed().as_secs_f64() * 1000.0,
                    AcuStateMachine::decode(status).name_en(),
                )?;
                if (hz - 10.0).abs() < 0.01 {
                    break;
                }
                tokio::time::sleep(Duration::from_millis(200)).await;
            }
            if (hz - 10.0).abs() >= 0.01 {
                return Err(bad(&format!(
                    "the simulated ACU did not reach 10 Hz ({hz} Hz)"
                )));
            }
            m.write(d, 410, DataSet::ALL, Width::Word, 0x06)
                .await
                .map_err(failed)?;
            outln!("  410 = 0x06 (shutdown): the drive stops")?;
        }
        let stats = m.stats();
        outln!(
            "  {} transactions, {} retries, {} timeouts, {} exception answers in {:.2} s",
            stats.transactions,
            stats.retries,
            stats.timeouts,
            stats.device_errors,
            started.elapsed().as_secs_f64()
        )?;
        drop(m);
        sim.abort();
        if rated != 1390 || f2 != 1000 {
            return Err(bad(
                "the simulated drive did not answer the manual's values",
            ));
        }
    }
    outln!()?;
    Ok(())
}

/// A NORD session over CTT2: a simulated AS-i master and network (2 slaves: the NORDAC LINK's
/// double slave at 1A/1B) with the transfer-time model of BU 0255 ch. 4.4, on tokio's paused
/// clock: the ID and diagnosis objects, a parameter written and read back, the drive enabled
/// at 50 % through the state machine (the manual's 5.1.1/5.1.2) and stopped.
async fn nord_session() -> Result<()> {
    use crate::nord::{NordParamClient, Sub, resolve, state_text};
    use crate::tool::client::ParamClient;
    use ctt2_uss::client::{ClientConfig, NordClient};
    use ctt2_uss::ctt2::link::{SimulatedDoubleSlave, SimulatedLink};
    use ctt2_uss::ctt2::master::{Ctt2Driver, DriverConfig};
    use drive_profile::Persistence;
    use drive_profile::nord::{ControlWord, State, command};

    let failed = |e: &dyn std::fmt::Display| CliError::failed(format!("demo: {e}"));
    let link = SimulatedLink::new(SimulatedDoubleSlave::default(), 2).map_err(|e| failed(&e))?;
    let byte = link.byte_time();
    outln!(
        "== NORD session: CTT2 through a simulated AS-i master ↔ NORDAC LINK double slave 1A/1B, 2 \
         AS-i slaves: {} ms per byte (virtual clock)",
        trim_float(byte.as_secs_f64() * 1e3, 3)
    )?;
    let started = tokio::time::Instant::now();
    let ms = || trim_float(started.elapsed().as_secs_f64() * 1e3, 0);
    let mut master = Ctt2Driver::new(link, DriverConfig::default());
    let id = master.read_id_object().await.map_err(|e| failed(&e))?;
    outln!(
        "  ID object: manufacturer 0x{:04X}, device 0x{:04X}, drive firmware {}.{}, configuration \
         level {} (t = {} ms)",
        id.manufacturer_id.unwrap_or(0),
        id.device_id.unwrap_or(0),
        id.firmware_version.unwrap_or(0),
        id.firmware_revision.unwrap_or(0),
        id.configuration_level.unwrap_or(0),
        ms()
    )?;
    let diag = master.read_diagnosis().await.map_err(|e| failed(&e))?;
    outln!("  diagnosis object: {diag} (t = {} ms)", ms())?;

    let mut client = NordClient::new(master, ClientConfig::default());
    let p102 = resolve(
        "P102",
        Sub {
            array: None,
            set: Some(3),
        },
        false,
    )?
    .into_iter()
    .next()
    .ok_or_else(|| failed(&"P102"))?;
    {
        let mut pc = NordParamClient::new(&mut client, "demo", serde_json::Map::new());
        pc.write(&p102, 1000, Persistence::NonVolatile)
            .await
            .map_err(|e| failed(&CliError::from(e)))?;
        outln!(
            "  write {} = 10.00 s (AK 2, IND 0200h, 03E8h): a NORD write of the PKW channel, then \
             NORD reads until the answer fits the order (t = {} ms)",
            p102.label(),
            ms()
        )?;
        let back = pc
            .read(&p102)
            .await
            .map_err(|e| failed(&CliError::from(e)))?;
        outln!(
            "  read back {}: {} (raw {back}) (t = {} ms)",
            p102.label(),
            p102.param.map_or_else(
                || back.to_string(),
                |p| crate::tool::output::physical_text(p, back)
            ),
            ms()
        )?;
        if back != 1000 {
            return Err(failed(&format!("P102 set 3 reads back {back}")));
        }
    }

    outln!("  enable at 50 % (SW1 2000h) through the state machine (5.1.1, 5.1.2):")?;
    let sw1 = [0x2000u16];
    let mut answer = client
        .process(ControlWord(0), &[], 1)
        .await
        .map_err(|e| failed(&e))?;
    let mut last = 0u16;
    for _ in 0..MAX_STEPS {
        let state = answer.status().state();
        let Some(word) = NordStateMachine::next_control(last, state, State::OperationEnabled)
        else {
            break;
        };
        answer = client
            .process(ControlWord(word), &sw1, 1)
            .await
            .map_err(|e| failed(&e))?;
        last = word;
        outln!(
            "    STW 0x{word:04X} → ZSW 0x{:04X} {} (t = {} ms)",
            answer.status().0,
            state_text(answer.status().state()),
            ms()
        )?;
    }
    let iw1 = |a: &ctt2_uss::uss::pzd::PzdIn| a.actuals().first().copied().unwrap_or(0);
    for _ in 0..40 {
        if answer.status().0 == 0x0B37 && iw1(&answer) == 0x2000 {
            break;
        }
        tokio::time::sleep(std::time::Duration::from_millis(200)).await;
        answer = client
            .process(ControlWord(last), &sw1, 1)
            .await
            .map_err(|e| failed(&e))?;
        outln!(
            "    t = {:>5} ms  ZSW 0x{:04X}  IW1 0x{:04X} = {:>5} % = {:>5} Hz of P105 50 Hz",
            ms(),
            answer.status().0,
            iw1(&answer),
            trim_float(nord::percent_from_word(iw1(&answer)), 2),
            trim_float(nord::word_to_physical(iw1(&answer), 50.0), 2)
        )?;
    }
    if answer.status().0 != 0x0B37 || iw1(&answer) != 0x2000 {
        return Err(failed(&format!(
            "the simulated drive did not reach the manual's 0B37h / 2000h (0x{:04X} / 0x{:04X})",
            answer.status().0,
            iw1(&answer)
        )));
    }
    outln!("    ZSW 0x0B37, IW1 0x2000: 50 % reached, as in the manual's 5.1.2")?;
    outln!("  stop: STW 0x047E (shutdown): braking ramp (P102), then ready to switch on")?;
    for _ in 0..40 {
        answer = client
            .process(command::SHUTDOWN, &[0], 1)
            .await
            .map_err(|e| failed(&e))?;
        if answer.status().state() != State::OperationEnabled {
            break;
        }
        tokio::time::sleep(std::time::Duration::from_millis(200)).await;
    }
    outln!(
        "    ZSW 0x{:04X} {} (t = {} ms)",
        answer.status().0,
        state_text(answer.status().state()),
        ms()
    )?;
    if answer.status().state() != State::ReadyToSwitchOn {
        return Err(failed(&"the simulated drive did not stop"));
    }
    let counters = *client.channel().counters();
    outln!(
        "  {} CTT2 requests, {} parameter-channel reads repeated until the answer fitted, {:.2} s \
         on the AS-i clock",
        counters.requests,
        client.repeated_requests(),
        started.elapsed().as_secs_f64()
    )?;
    outln!()?;
    Ok(())
}
