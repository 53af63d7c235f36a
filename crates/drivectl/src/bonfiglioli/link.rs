//! The line: the character format of the mode, the driver's configuration, opening the port,
//! and the command line that reaches the drive again (after a link setting changed, too).

use super::*;

pub fn address(a: u8) -> Result<Address> {
    Address::new(a)
        .filter(|a| !a.is_broadcast())
        .ok_or_else(|| {
            CliError::usage(format!(
                "address {a} cannot be asked for an answer; use 1–247 (parameter 1376)"
            ))
        })
}

pub fn mode_of(s: &str) -> Mode {
    if s.eq_ignore_ascii_case("ascii") {
        Mode::Ascii
    } else {
        Mode::Rtu
    }
}

/// The character format of `mode` on the command line's line (ch. 6.7): RTU 8 data bits,
/// ASCII 7 unless `data_bits` says otherwise; one stop bit with parity and two without, or two
/// where `--stop-bits 2` asks for them.
pub fn line_of(mode: Mode, line: &LineArgs, data_bits: Option<u8>) -> drive_core::LineSettings {
    let mut settings = mode.line_settings(line.baud, line.parity);
    if let Some(bits) = data_bits {
        settings.data_bits = bits;
    }
    if line.stop_bits == drive_core::StopBits::Two {
        settings.stop_bits = drive_core::StopBits::Two;
    }
    settings
}

pub use bonfiglioli_modbus::master::{least_response_timeout as least_timeout, longest_frame};

/// The driver configuration of the command-line options. A response timeout shorter than an
/// exchange takes at the line's baud rate ([`least_timeout`]) is refused: no answer could come
/// in time.
pub fn driver_config(args: &BonfiglioliArgs) -> Result<DriverConfig> {
    let mode = mode_of(&args.mode);
    let line = line_of(mode, &args.line, args.data_bits);
    let timeout = Duration::from_millis(args.timeout);
    let least = least_timeout(mode, &line);
    let frame = longest_frame(mode);
    crate::tool::line::check_timeout(
        timeout,
        least,
        &format!(
            "an exchange takes at {} baud ({:.2} ms: the request and the answer, up to {frame} \
             characters each, {:.1} ms each, and the drive's answer delay of 10 ms, manual ch. \
             6.8)",
            line.baud,
            least.as_secs_f64() * 1e3,
            (line.char_time() * frame).as_secs_f64() * 1e3,
        ),
    )?;
    Ok(DriverConfig {
        response_timeout: timeout,
        retries: args.retries,
        ..DriverConfig::new(mode, line)
    })
}

/// The command line that reaches the same drive again (for hints): every line option that
/// differs from its default.
pub fn again(args: &BonfiglioliArgs) -> Again {
    again_with_data_bits(args, args.data_bits)
}

/// [`again`] with `--data-bits` as `data_bits` says.
pub fn again_with_data_bits(args: &BonfiglioliArgs, data_bits: Option<u8>) -> Again {
    let mut a = Again::new("bonfiglioli")
        .arg("--port", &args.port)
        .arg_unless("--mode", args.mode.as_str(), "rtu")
        .line(&args.line)
        .adapter(&args.adapter);
    if let Some(bits) = data_bits {
        a = a.arg("--data-bits", bits);
    }
    a.arg_unless("--timeout", args.timeout, 500)
        .arg_unless("--retries", args.retries, 2)
        .arg_unless("--variant", args.variant.as_str(), "auto")
        .arg("--addr", args.addr)
}

/// The command that reaches the drive of `args` once `raw` written to the link setting `index`
/// applies: the same line options with the new address, baud rate, parity or mode (ASCII with
/// 7 data bits unless `--data-bits` was given), asking for the drive's status; `None` for a
/// setting after which no Modbus master reaches it, or that changes nothing of the line.
pub fn reach_after(args: &BonfiglioliArgs, index: u16, raw: i64) -> Option<String> {
    let mut line = args.line.clone();
    let mut mode = args.mode.as_str();
    let mut addr = args.addr;
    match index {
        param::ADDRESS => addr = u8::try_from(raw).ok().filter(|a| (1..=247).contains(a))?,
        param::BAUD_RATE => line.baud = bonfiglioli::link::baud_of_code(raw)?,
        param::PARITY => line.parity = bonfiglioli::link::parity_of_code(raw)?,
        param::PROTOCOL => {
            mode = match u16::try_from(raw).ok()? {
                bonfiglioli::link::PROTOCOL_RTU => "rtu",
                bonfiglioli::link::PROTOCOL_ASCII => "ascii",
                _ => return None,
            }
        }
        _ => return None,
    }
    let mut a = Again::new("bonfiglioli")
        .arg("--port", &args.port)
        .arg_unless("--mode", mode, "rtu")
        .line(&line);
    if let Some(bits) = args.data_bits {
        a = a.arg("--data-bits", bits);
    }
    Some(
        a.arg_unless("--timeout", args.timeout, 500)
            .arg_unless("--retries", args.retries, 2)
            .arg_unless("--variant", args.variant.as_str(), "auto")
            .arg("--addr", addr)
            .then("status"),
    )
}

/// The `--variant` given (none for `auto`).
pub fn given_variant(args: &BonfiglioliArgs) -> Option<Variant> {
    Variant::from_key(&args.variant)
}

/// Open the port of `args` with `settings` (the mode's data bits). A port that refuses ASCII's
/// 7 data bits (every pseudo-terminal does) is told apart: the manual's ASCII is 7 data bits,
/// and a pty runs only with 8 on both sides.
pub fn open(
    args: &BonfiglioliArgs,
    settings: drive_core::LineSettings,
) -> Result<crate::tool::line::EchoPort> {
    let path = &args.port;
    args.adapter.open(path, settings).map_err(|e| match e.refused_setting() {
        Some(drive_transport::LineOption::DataBits) if settings.data_bits == 7 => {
            let sim = Again::new("sim bonfiglioli --pty --parity none --mode ascii --data-bits 8")
                .arg_unless("--baud", args.line.baud, 9600)
                .arg_unless("--addr", args.addr, 1);
            CliError::usage(format!(
                "{path} does not take 7 data bits (a pseudo-terminal takes only 8). Modbus ASCII \
                 uses 7 data bits (manual ch. 6.7.2.1), and so does a drive set to ASCII: on a \
                 real line use an adapter that takes 7. Against a simulator on a pty, run both \
                 sides with 8 data bits: `{sim}` and `{}`",
                again_with_data_bits(args, Some(8))
            ))
        }
        _ => crate::tool::line::open_cli_error(&e),
    })
}
