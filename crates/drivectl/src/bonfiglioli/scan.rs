//! What the bus itself answers: the FC 8 diagnostic counters (`diag`) and the address scan.

use super::*;

pub async fn diag<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    addr: Address,
    clear: bool,
    json: bool,
) -> Result<()> {
    if clear {
        m.diagnostics(addr, DiagSubFunction::CLEAR_COUNTERS)
            .await
            .map_err(driver_error)?;
    }
    let mut counters = Map::new();
    let mut lines = Vec::new();
    for sub in DiagSubFunction::COUNTERS {
        let v = m.diagnostics(addr, sub).await.map_err(driver_error)?;
        let name = sub.name().unwrap_or("counter");
        counters.insert(name.replace(' ', "_"), v.into());
        lines.push(format!("  0x{:02X} {name:<38} {v}", sub.0));
    }
    if json {
        outln!(
            "{}",
            json!({"address": addr.get(), "cleared": clear, "counters": counters})
        )?;
    } else {
        outln!(
            "diagnostic counters of address {}{}:",
            addr.get(),
            if clear { " (cleared first)" } else { "" }
        )?;
        for l in lines {
            outln!("{l}")?;
        }
    }
    Ok(())
}

/// A margin for the answer of a drive that is there: USB serial adapters hand received
/// characters over late (FTDI: every 16 ms by default) and the operating system schedules.
pub const SCAN_MARGIN: Duration = Duration::from_millis(20);

/// How long `scan` waits for an answer at each address: the response timeout counts from the
/// request's end to the first character of the answer, which a drive sends 10 ms after a
/// request at the earliest (ch. 6.8); with two character times for that first character and
/// [`SCAN_MARGIN`]. The 500 ms of ch. 6.8 are for a drive under load, not for finding one.
pub fn scan_timeout(line: &drive_core::LineSettings) -> Duration {
    bonfiglioli_modbus::slave::ANSWER_DELAY + line.char_time() * 2 + SCAN_MARGIN
}

pub async fn scan<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    from: u8,
    to: u8,
    json: bool,
) -> Result<()> {
    if from == 0 || from > to || to > 247 {
        return Err(CliError::usage(
            "scan range must satisfy 1 ≤ --from ≤ --to ≤ 247",
        ));
    }
    let timeout = scan_timeout(&m.config().line);
    let bar = backup::progress(usize::from(to - from) + 1, "scanning");
    let mut found = 0;
    for a in from..=to {
        bar.set_message(format!(
            "address {a} ({found} found, {} ms each)",
            timeout.as_millis()
        ));
        let addr = address(a)?;
        let answered = m.probe(addr, timeout).await.map_err(driver_error)?;
        bar.inc(1);
        if !answered {
            continue;
        }
        found += 1;
        let mut c = client(m, addr, "", None).probing();
        let configuration = c
            .read(&resolve(&param::CONFIGURATION.to_string(), 0)?)
            .await
            .ok();
        let status = c.read(&resolve("411", 0)?).await.ok();
        // A drive that answers but refuses what tells the variant shows none.
        let variant = c.find_variant().await.ok().and_then(|f| f.variant);
        bar.suspend(|| -> Result<()> {
            if json {
                outln!(
                    "{}",
                    json!({"address": a, "variant": variant.map(|k| k.variant.key()),
                           "variant_from": variant.map(|k| k.from),
                           "configuration": configuration, "status_word": status,
                           "device_type": null, "firmware": null})
                )
            } else {
                outln!(
                    "address {a:>3}: {}, configuration {}, status word {} (the manual defines \
                     no device type or firmware parameter)",
                    variant.map_or("ACT or ACU (not told apart)", |k| k.variant.name()),
                    configuration.map_or_else(|| "unreadable".to_owned(), |v| v.to_string()),
                    status.map_or_else(|| "unreadable".to_owned(), |v| format!("0x{v:04X}"))
                )
            }
        })?;
    }
    bar.finish_and_clear();
    if !json {
        outln!("{found} drive(s) answered between {from} and {to}")?;
    }
    Ok(())
}
