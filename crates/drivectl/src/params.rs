//! `drivectl params <family> [--search TERM] [--json]` and `params <family> show <P|index>`.

use crate::error::{CliError, Result};
use crate::tool::output::{physical_text, trim_float};
use clap::{Args, Subcommand};
use drive_client::meaning::access_codes;
use drive_profile::{Access, Family, ParamMeta};
use serde_json::Value;
use std::fmt::Write as _;

/// Examples and the access codes, below `drivectl params --help`.
const PARAMS_AFTER_HELP: &str = "\
Examples:
  drivectl params movidrive                            the whole MOVIDRIVE table
  drivectl params movidrive --search ueberwachung      names with \"Überwachung\"
  drivectl params nord --json                          one JSON object per parameter
  drivectl params sew show P813                        one parameter in full
  drivectl params bonfiglioli show 1376 --json

Access codes (the access column, joined by /):
  N    non-volatile: SEW copies the value from EEPROM into RAM at restart; Bonfiglioli
       writes it to EEPROM automatically (RAM data sets 5-9 spare the EEPROM)
  S    SEW: may be stored even while the parameter lock (P803) is on
  R    SEW: writing needs controller inhibit (the drive must not be enabled)
  RO   read-only
  RW   read/write
  NOP  Bonfiglioli: not writable while the drive is in operation
  DS   Bonfiglioli: exists once per data set 1-4; data set 0 addresses all four
NORD tables give only RO and RW.";

/// Examples below `drivectl params FAMILY show --help`.
const SHOW_AFTER_HELP: &str = "\
Examples:
  drivectl params movidrive show P813       by P-number
  drivectl params movidrive show 0x2198     by bus index (hex or decimal)
  drivectl params nord show P102 --json";

/// Arguments of `drivectl params`.
#[derive(Debug, Args)]
#[command(after_help = PARAMS_AFTER_HELP)]
pub struct ParamsArgs {
    /// Drive family: movidrive (sew), nord or bonfiglioli.
    family: String,
    /// Only parameters whose German or English name contains TERM, ignoring case; umlauts and ß
    /// need not be typed (`ueberwachung` or `uberwachung` finds "Überwachung", `grosse` "Größe").
    #[arg(long, value_name = "TERM")]
    search: Option<String>,
    /// One JSON object per parameter instead of a table.
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    action: Option<ParamsAction>,
}

#[derive(Debug, Subcommand)]
enum ParamsAction {
    /// Show one parameter in full: P-number (P813, 813) or bus index (8600, 0x2198).
    #[command(after_help = SHOW_AFTER_HELP)]
    Show {
        /// P-number or bus index.
        param: String,
    },
}

/// Parse a family name as given on the command line.
pub fn parse_family(s: &str) -> Result<Family> {
    Family::parse(s).ok_or_else(|| {
        CliError::usage(format!(
            "unknown drive family `{s}`; use one of: movidrive (or sew), nord, bonfiglioli"
        ))
    })
}

/// Every parameter of `family`, in table order.
pub fn all(family: Family) -> Vec<&'static dyn ParamMeta> {
    drive_profile::family::params(family)
        .map(|p| p as &dyn ParamMeta)
        .collect()
}

/// Look up one parameter by P-number or bus index.
pub fn lookup(family: Family, key: &str) -> Result<&'static dyn ParamMeta> {
    drive_profile::family::lookup(family, key)
        .map(|p| p as &dyn ParamMeta)
        .ok_or_else(|| {
            CliError::usage(format!(
                "no {family} parameter `{key}`; try `drivectl params {family} --search NAME` to find it"
            ))
        })
}

fn scaling_text(p: &dyn ParamMeta) -> String {
    let mut s = String::new();
    let _ = p.describe_scaling(&mut s);
    s
}

/// The JSON object describing a parameter (`docs/params-json.md`): the client layer's.
pub use drive_client::meaning::param_json as to_json;

/// Run `drivectl params`.
pub fn run(args: &ParamsArgs) -> Result<()> {
    let family = parse_family(&args.family)?;
    match &args.action {
        Some(ParamsAction::Show { param }) => show(family, param, args.json),
        None => list(family, args.search.as_deref(), args.json),
    }
}

fn list(family: Family, search: Option<&str>, json: bool) -> Result<()> {
    let params: Vec<_> = all(family)
        .into_iter()
        .filter(|p| search.is_none_or(|t| p.name_matches(t)))
        .collect();
    if params.is_empty()
        && let Some(t) = search
    {
        return Err(CliError::usage(format!(
            "no {family} parameter name contains `{t}` (German or English); try a shorter term"
        )));
    }
    let mut out = String::new();
    if json {
        for p in &params {
            let _ = writeln!(out, "{}", to_json(*p));
        }
    } else {
        let _ = writeln!(
            out,
            "{:<10} {:>6}  {:<34} {:<34} {:<7} {:<8} {:>10}  range",
            "number", "index", "name (de)", "name (en)", "unit", "access", "default"
        );
        for p in &params {
            let default = p
                .default_raw()
                .map(|d| trim_float(p.to_physical(d), p.decimals()));
            let range = p.raw_range().map(|(lo, hi)| {
                format!(
                    "{} … {}",
                    trim_float(p.to_physical(lo), p.decimals()),
                    trim_float(p.to_physical(hi), p.decimals())
                )
            });
            let _ = writeln!(
                out,
                "{:<10} {:>6}  {:<34} {:<34} {:<7} {:<8} {:>10}  {}",
                p.label(),
                p.bus_index(),
                clip(p.name_de(), 34),
                clip(p.name_en(), 34),
                p.unit(),
                p.access().to_string(),
                default.unwrap_or_default(),
                range.unwrap_or_else(|| clip(p.range_en(), 40)),
            );
        }
        let _ = writeln!(out, "{} parameters", params.len());
        let present = params
            .iter()
            .fold(Access::NONE, |acc, p| acc.union(p.access()));
        let codes = access_codes(family, present);
        if !codes.is_empty() {
            let _ = writeln!(out, "access:");
            for (code, meaning) in codes {
                let _ = writeln!(out, "  {code:<4} {meaning}");
            }
        }
    }
    out!("{out}")?;
    Ok(())
}

fn show(family: Family, key: &str, json: bool) -> Result<()> {
    let p = lookup(family, key)?;
    if json {
        outln!("{}", to_json(p))?;
        return Ok(());
    }
    let mut out = String::new();
    let _ = writeln!(out, "{} {} / {}", p.label(), p.name_de(), p.name_en());
    let _ = writeln!(out, "  family     {}", p.family());
    let _ = writeln!(
        out,
        "  index      {} (0x{:04X})",
        p.bus_index(),
        p.bus_index()
    );
    if let Some(s) = p.sub_index() {
        let _ = writeln!(out, "  sub-index  {s}");
    }
    let _ = writeln!(
        out,
        "  unit       {}",
        if p.unit().is_empty() { "-" } else { p.unit() }
    );
    let _ = writeln!(out, "  scaling    {}", scaling_text(p));
    let _ = writeln!(out, "  access     {}", p.access());
    for (code, meaning) in access_codes(family, p.access()) {
        let _ = writeln!(out, "    {code:<4} {meaning}");
    }
    // Bonfiglioli columns that qualify RW.
    let row = to_json(p);
    if row.get("bus_access").and_then(Value::as_str) == Some("write_only") {
        let _ = writeln!(out, "    write-only on the bus: it cannot be read back");
    }
    if row.get("ram_only").and_then(Value::as_bool) == Some(true) {
        let _ = writeln!(out, "    kept in RAM only, never written to EEPROM");
    }
    if let Some(d) = p.default_raw() {
        let _ = writeln!(out, "  default    {} (raw {d})", physical_text(p, d));
    }
    if let Some((lo, hi)) = p.raw_range() {
        let _ = writeln!(
            out,
            "  range      {} … {} (raw {lo} … {hi})",
            physical_text(p, lo),
            physical_text(p, hi)
        );
    }
    if !p.range_de().is_empty() {
        let _ = writeln!(out, "  meaning    {}", p.range_en());
        let _ = writeln!(out, "  (de)       {}", p.range_de());
    }
    if !p.values().is_empty() {
        let _ = writeln!(out, "  values");
        for v in p.values() {
            let _ = writeln!(out, "    {:>6} = {} ({})", v.value, v.en, v.de);
        }
    }
    out!("{out}")?;
    Ok(())
}

fn clip(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_owned()
    } else {
        let mut t: String = s.chars().take(n.saturating_sub(1)).collect();
        t.push('…');
        t
    }
}
