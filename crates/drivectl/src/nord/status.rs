//! `status`: the status word with its state A–H, the actual values IW1–IW3 and P700.

use ctt2_uss::client::{NordClient, ParameterChannel, ProcessChannel};
use drive_client::status::{ActualValue, PRESENT_NAMES};
use drive_profile::nord::ControlWord;

use drive_client::nord::NordParamClient;

use super::{Session, link_error, param_client, state_text};
use crate::error::Result;
use crate::tool::client::OnTarget as _;
use crate::tool::client::{ClientError, ParamClient, Target};
use crate::tool::output::trim_float;

/// One actual value as text: `0x2000 = 50 % = 25 Hz (P543 function 1: actual frequency)`.
pub fn actual_text(v: &ActualValue) -> String {
    let mut s = format!("0x{:04X} = {} %", v.word, trim_float(v.percent, 2));
    if let (Some(x), Some(unit)) = (v.value, v.unit) {
        s.push_str(&format!(" = {} {unit}", trim_float(x, 2)));
    }
    match (v.function, v.function_name) {
        (Some(f), Some(n)) => s.push_str(&format!(" (P543 function {f}: {n})")),
        (Some(f), None) => s.push_str(&format!(" (P543 function {f})")),
        _ => {}
    }
    s
}

/// `status`: see [`NordCommand::Status`](super::NordCommand::Status).
pub async fn status<C>(c: &mut NordClient<C>, s: &Session) -> Result<()>
where
    C: ParameterChannel + ProcessChannel,
{
    // Bit 10 clear: the drive does not evaluate this control word (section 4.5.1 footnote 2),
    // it only answers its status word and actual values.
    let answer = c
        .process(ControlWord(0), &[], s.actuals)
        .await
        .map_err(link_error)?;
    let sw = answer.status();
    let mut pc = param_client(c, s);
    let st = drive_client::status::nord(&mut pc, sw, answer.actuals())
        .await
        .map_err(|f| f.target.error(f.error))?;
    for r in st.refusals() {
        if let Err(d) = &r.value {
            errln!("drivectl: warning: {}: {d}", r.target.label());
        }
    }
    if s.json {
        return outln!("{}", st.json());
    }
    let bits: Vec<&str> = sw.set_bits().map(|b| b.name_en).collect();
    outln!("status word 0x{:04X}: {}", sw.0, state_text(sw.state()))?;
    outln!("  bits: {}", bits.join(", "))?;
    outln!(
        "  parameter set {}; P105 maximum frequency {} (the 100 % of frequencies)",
        sw.parameter_set(),
        st.max_frequency_hz().map_or_else(
            || "unreadable".to_owned(),
            |h| format!("{} Hz", trim_float(h, 1))
        )
    )?;
    for (i, a) in (1..).zip(st.actual_values()) {
        outln!("  actual value {i} (IW{i}): {}", actual_text(&a))?;
    }
    for (i, (p, name)) in st.present_texts().iter().zip(PRESENT_NAMES).enumerate() {
        outln!(
            "  P700 [-{:02}] {name}: {}",
            i + 1,
            match p {
                Some((_, Some(t))) => t.clone(),
                Some((v, None)) => v.to_string(),
                None => "unreadable".to_owned(),
            }
        )?;
    }
    Ok(())
}

/// A raw value, `None` when the drive refuses it (a link failure is an error).
pub async fn read_optional<C: ParameterChannel>(
    pc: &mut NordParamClient<'_, C>,
    t: &Target,
) -> Result<Option<i64>> {
    match pc.read(t).await {
        Ok(v) => Ok(Some(v)),
        Err(ClientError::Device(d)) => {
            errln!("drivectl: warning: {}: {d}", t.label());
            Ok(None)
        }
        Err(e) => Err(t.error(e)),
    }
}
