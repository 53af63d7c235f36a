//! `status`: the status word 411 decoded for the drive's variant, the fault 260 and the
//! warnings 270.

use super::*;

/// The status word's set bits by name, for `variant`.
pub fn bits_text(word: u16, variant: Variant) -> String {
    variant.set_bits(word).collect::<Vec<_>>().join(" | ")
}

pub async fn read_word<IO: CharIo>(m: &mut MasterDriver<IO>, addr: Address, p: u16) -> Result<u16> {
    let t = resolve(&p.to_string(), 0)?;
    m.read(addr, p, DataSet::ALL, Width::Word)
        .await
        .map(|v| v as u16)
        .map_err(|e| t.error(client_error(Width::Word, e)))
}

/// `status`: 411, 260 and 270 with their meanings ([`crate::tool::meaning`]), 411 for the
/// drive's variant (`None`: neither given nor shown by the drive; decoded for what both share).
pub async fn status<IO: CharIo>(
    m: &mut MasterDriver<IO>,
    addr: Address,
    variant: Option<KnownVariant>,
    json: bool,
) -> Result<()> {
    let device = Device {
        bonfiglioli: variant,
    };
    let mut read = async |p: u16| -> Result<(Target, u16, Option<crate::tool::meaning::Meaning>)> {
        let t = resolve(&p.to_string(), 0)?;
        let word = read_word(m, addr, p).await?;
        let meaning = crate::tool::meaning::meaning_in(&t, i64::from(word), &device);
        Ok((t, word, meaning))
    };
    let (_, word, status) = read(param::STATUS_WORD).await?;
    let (_, fault, fault_meaning) = read(param::CURRENT_FAULT).await?;
    let (_, warnings, warning_meaning) = read(param::WARNINGS).await?;
    let decoded = status
        .as_ref()
        .and_then(|m| m.decoded.clone())
        .unwrap_or(Value::Null);
    let key = |k: &str| decoded.get(k).cloned().unwrap_or(Value::Null);
    if key("variant_contradicted") == true {
        errln!(
            "drivectl: warning: status word 411 = 0x{word:04X} has bit 4 set, which an ACT never \
             sets (manual ch. 9.1.3): the drive looks like an ACTIVE Cube; --variant acu decodes \
             it as one"
        );
    }
    let text = |m: &Option<crate::tool::meaning::Meaning>| {
        m.as_ref().map_or_else(String::new, |m| m.text.clone())
    };
    let warning_names: Vec<&str> = bonfiglioli::warning_bits(warnings)
        .map(|w| w.name_en)
        .collect();
    let shown = variant.map(|k| k.variant).or(Variant::of_status_word(word));
    if json {
        outln!(
            "{}",
            json!({"address": addr.get(), "variant": shown.map(Variant::key),
                   "variant_from": key("variant_from"),
                   "status_word": word, "state": key("state"),
                   "bits": bits_text(word, shown.unwrap_or(Variant::Act)),
                   "decoded": decoded,
                   "fault": fault, "fault_text": text(&fault_meaning),
                   "warnings": warnings, "warning_names": warning_names})
        )
    } else {
        outln!("status word 411: 0x{word:04X} = {}", text(&status))?;
        outln!("current fault 260: {}", text(&fault_meaning))?;
        outln!(
            "warnings 270: 0x{warnings:04X} = {}",
            text(&warning_meaning)
        )
    }
}
