//! The demo's SBus session: simulated MOVIDRIVEs on a virtual CAN bus, on a virtual clock.

#[allow(unused_imports)]
use super::*;

/// The frames a sniffer node has received so far, with their times.
pub(super) async fn sniffed(
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
/// addresses 1 and 2), on a virtual clock (`drive_core::rt::time::VirtualClock`): the identifiers, a scan, reads in both
/// handshake modes (the sync-mode answer after the SYNC, measured from the frame times),
/// synchronous and asynchronous process data with the speeds ramping, a volatile write, a group
/// write, the stop, and a MOVLNK command executed by drive 1 towards drive 2.
pub(super) async fn sbus_session() -> Result<()> {
    use crate::sbus::link::driver_error;
    use drive_core::can::Bitrate;
    use drive_core::rt::time::Instant;
    use drive_profile::sew::{ControlWord1, ParamChannel, StatusWord1, index, speed_from_word};
    use drive_transport::can::virtual_bus::VirtualBus;
    use sbus_can::driver::{ParamServices, SbusDriver};
    use sbus_can::ids::{Kind, SlaveIds};
    use sbus_can::master::{Handshake, MasterConfig};
    use sbus_can::movlnk::{MlData, MovlnkCommand};
    use sbus_can::sim::SimulatedSbusBus;
    use sbus_can::{Address, ProcessData};
    use std::time::Duration;

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
    let started = drive_core::rt::time::now();
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
        ms(drive_core::rt::time::now())
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
                show(drive_core::rt::time::now(), p1, p2)?;
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
        drive_core::rt::time::elapsed(started).as_secs_f64()
    )?;
    drop(m);
    sim.abort();
    outln!()?;
    Ok(())
}
