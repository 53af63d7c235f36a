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

/// `scan`: one diagnostics request per address; a drive that answers is shown with its
/// variant, configuration and status word.
pub async fn scan<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    from: u8,
    to: u8,
    json: bool,
) -> Result<()> {
    let timeout = drive_client::scan::bonfiglioli_timeout(&m.config().line);
    let message = |a: u8, found: usize| {
        format!(
            "address {a} ({found} found, {} ms each)",
            timeout.as_millis()
        )
    };
    let shown = crate::tool::scan::Shown {
        range: 1..=247,
        message: Some(&message),
        json,
    };
    let mut bus = drive_client::scan::BonfiglioliScan { driver: m, timeout };
    crate::tool::scan::scan(&mut bus, from, to, shown, driver_error).await
}
