//! The demo's Modbus session: a simulated ACTIVE Cube on the RTU wire model.

#[allow(unused_imports)]
use super::*;

/// A Bonfiglioli session against a simulated ACTIVE Cube over an in-memory RS-485 link with
/// 19200-baud wire timing, in Modbus RTU and then ASCII: the manual's examples, an exception
/// with its VABus cause, the diagnostic counters, and (RTU) a run-up through the state machine.
pub(super) async fn bonfiglioli_session() -> Result<()> {
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
