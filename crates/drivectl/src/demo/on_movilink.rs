//! The demo's MOVILINK session: a master and simulated MOVIDRIVEs on the RS-485 wire model.

#[allow(unused_imports)]
use super::*;

/// A MOVILINK session against two simulated MOVIDRIVEs over an in-memory RS-485 link with
/// 9600-baud wire timing: scan, identify, read and write parameters, enable, watch the speed
/// ramp, stop.
pub(super) async fn movilink_session() -> Result<()> {
    use crate::movilink::{driver_error, firmware_text, resolve};
    use crate::tool::output::print_value;
    use drive_client::sew::raw_of;
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
