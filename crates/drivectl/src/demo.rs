//! `drivectl demo`: the main job on an embedded default.
//!
//! It walks through what drivebus knows without any hardware: the parameter tables of every
//! family with their scaling, and the DRIVECOM-style state machines driven by control words.

use crate::error::Result;
use crate::params::{all, label, lookup, physical_text};
use clap::Args;
use drive_profile::Family;

/// Arguments of `drivectl demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {}

/// Run the demonstration.
pub fn run(_args: &DemoArgs) -> Result<()> {
    println!("drivebus demo: everything below runs without hardware.\n");
    tables()?;
    Ok(())
}

fn tables() -> Result<()> {
    println!("== Parameter tables generated from the manuals");
    for family in Family::ALL {
        println!("  {:<12} {:>4} parameters", family.name(), all(family).len());
    }
    println!();
    let samples = [
        (Family::Movidrive, "8318", 1_000_000),
        (Family::Movidrive, "P813", 5),
        (Family::Nord, "P102", 1000),
        (Family::Bonfiglioli, "1376", 1),
    ];
    for (family, key, raw) in samples {
        let p = lookup(family, key)?;
        println!(
            "  {:<12} {:<8} {:<28} index {:>5}: raw {raw} = {}",
            family.name(),
            label(p),
            p.name_en(),
            p.bus_index(),
            physical_text(p, raw)
        );
    }
    println!();
    Ok(())
}
