//! The gateway's bus tasks under load: BUSESxDRIVES simulated MOVILINK buses (9600 baud 8E1,
//! on the wire model, every drive's P130 polled every PERIOD) run SECONDS of virtual time on
//! tokio's paused clock, then the figures: per bus the transactions against what the wire
//! allows, the processor time per transaction and the memory per bus.
//!
//! ```text
//! cargo run --release -p drivebus-gateway --example load -- 64x31 [SECONDS [PERIOD]]
//! ```
//!
//! Each bus keeps within 5 % of its wire bound (the figures `docs/gateway.md` reports; the
//! gateway's tests check the same on 1 to 64 buses).

// An example prints its figures.
#![allow(clippy::print_stdout)]

use std::time::Duration;

use drivebus_gateway::{bus, families, load};

fn main() -> std::process::ExitCode {
    let mut args = std::env::args().skip(1);
    let spec = args.next().unwrap_or_else(|| "64x31".to_owned());
    let seconds = args.next().map_or(Ok(20), |s| s.parse::<u64>());
    let period = args.next().unwrap_or_else(|| "1s".to_owned());
    let result = match seconds {
        Ok(seconds) => run(&spec, seconds, &period),
        Err(_) => Err("SECONDS: give a whole number of virtual seconds, 1–3600".to_owned()),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("load: {e}");
            std::process::ExitCode::from(2)
        }
    }
}

fn run(spec: &str, seconds: u64, period: &str) -> Result<(), String> {
    let bad = || format!("{spec}: give BUSESxDRIVES, e.g. 64x31 (1–256 buses, 1–31 drives)");
    let (b, d) = spec.split_once(['x', 'X']).ok_or_else(bad)?;
    let buses: usize = b.trim().parse().map_err(|_| bad())?;
    let drives: usize = d.trim().parse().map_err(|_| bad())?;
    // The buses report their figures every FIGURES_EVERY (5 s); the last report before the
    // end is the one counted, so a run needs more than one period.
    let every = drivebus_gateway::task::FIGURES_EVERY.as_secs();
    if !(1..=256).contains(&buses) || !(1..=31).contains(&drives) {
        return Err(bad());
    }
    if !(every + 1..=3600).contains(&seconds) {
        return Err(format!(
            "SECONDS {seconds}: give {}–3600 (the buses report every {every} s)",
            every + 1
        ));
    }
    // The time of the last report the run sees: the last multiple of the period before its end
    // (the one at the end itself races with it).
    let at = (seconds - 1) / every * every;
    let plant = load::plant(buses, drives, period).map_err(|e| e.to_string())?;
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .start_paused(true)
        .build()
        .map_err(|e| format!("cannot start the runtime: {e}"))?;
    let local = tokio::task::LocalSet::new();
    let wire = families::WireDesc::of(plant.buses.first().ok_or_else(bad)?).time(bus::Op::Read);
    let cpu0 = cpu_time();
    let report = local.block_on(
        &rt,
        load::load(&plant, Duration::from_secs(seconds), |bus| {
            families::simulated_bus(bus).access
        }),
    );
    let cpu = cpu_time().zip(cpu0).map(|(a, b)| a.saturating_sub(b));
    let mut util: Vec<f64> = report.buses.iter().map(|b| b.figures.utilisation).collect();
    util.sort_by(f64::total_cmp);
    let pick = |q: f64| {
        let i = ((util.len() - 1) as f64 * q).round() as usize;
        util.get(i).copied().unwrap_or(0.0)
    };
    let tx = report.transactions.max(1);
    println!(
        "{buses} buses x {drives} drives, {seconds} s virtual, P130 every {period} per drive (demand {:.0} %)",
        report.buses.first().map_or(0.0, |b| b.figures.demand) * 100.0
    );
    println!(
        "wire time of a read (9600 baud 8E1): {:.3} ms; bound per bus {:.1} transactions/s",
        wire.as_secs_f64() * 1e3,
        1.0 / wire.as_secs_f64()
    );
    println!(
        "transactions: {} in the first {at} s ({:.1}/s per bus)",
        report.transactions,
        report.transactions as f64 / buses as f64 / at as f64
    );
    println!(
        "utilisation of the wire bound per bus: min {:.4}, median {:.4}, max {:.4}",
        pick(0.0),
        pick(0.5),
        pick(1.0)
    );
    println!(
        "real time per transaction: {:.2} us; processor time per transaction: {}",
        report.cpu_per_transaction.as_secs_f64() * 1e6,
        cpu.map_or("unknown".to_owned(), |c| format!(
            "{:.2} us",
            c.as_secs_f64() * 1e6 / tx as f64
        ))
    );
    let kib = |m: Option<u64>| {
        m.map_or("unknown".to_owned(), |m| {
            format!("{:.1} KiB", m as f64 / 1024.0)
        })
    };
    println!(
        "memory per bus (RSS growth / buses): the gateway's side {}, the simulated drives and links {}",
        kib(report.rss_per_bus),
        kib(report.rss_per_bus_made)
    );
    println!(
        "(processor time includes the simulated drives and the character-level wire model, which run in this process)"
    );
    Ok(())
}

/// The processor time this process used (user + system), from `/proc/self/stat`.
fn cpu_time() -> Option<Duration> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name in parentheses; utime and stime are the 14th and 15th.
    let rest = stat.rsplit_once(')')?.1;
    let mut f = rest.split_whitespace().skip(11);
    let utime: u64 = f.next()?.parse().ok()?;
    let stime: u64 = f.next()?.parse().ok()?;
    // Clock ticks: 100 per second on Linux.
    Some(Duration::from_millis((utime + stime) * 10))
}
