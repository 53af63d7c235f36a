//! USS telegrams: STX, LGE, ADR, the net data (PKW and PZD) and the BCC.

use super::pkw::{explain_pkw, explain_pzd};
use super::{Capture, Message, SettingNames, UssLayout};

/// Explain one USS telegram (`bytes` from STX on, as long as LGE says or the capture has).
fn explain_uss(bytes: &[u8], offset: usize, layout: UssLayout, from_master: bool) -> Message {
    let mut m = Message {
        offset,
        len: bytes.len(),
        bytes: bytes.to_vec(),
        direction: if from_master { "master" } else { "drive" },
        kind: "USS telegram".to_owned(),
        ..Message::default()
    };
    m.push(bytes, 0, 1, "STX", "02h: start of text".to_owned());
    let Some(&lge) = bytes.get(1) else {
        m.fail("no LGE".to_owned());
        return m;
    };
    let total = usize::from(lge) + 2;
    m.push(
        bytes,
        1,
        1,
        "LGE",
        format!("{lge}: ADR, net data and BCC; the telegram is {total} bytes"),
    );
    if lge < 2 {
        m.fail(format!("LGE {lge} is less than ADR + BCC"));
        return m;
    }
    if bytes.len() < total {
        m.fail(format!(
            "the telegram is cut short: LGE announces {total} bytes, the capture has {}",
            bytes.len()
        ));
    }
    let Some(&adr) = bytes.get(2) else {
        return m;
    };
    m.address = Some(adr & 0x1F);
    let mut flags = Vec::new();
    if adr & 0x20 != 0 {
        flags.push("broadcast (bit 5: every drive executes it, none answers)");
    }
    if adr & 0x40 != 0 {
        flags.push("mirror (bit 6: the drive sends it back unchanged)");
    }
    if adr & 0x80 != 0 {
        flags.push("special (bit 7)");
    }
    m.push(
        bytes,
        2,
        1,
        "ADR",
        format!(
            "{adr:02X}h: address {}{}",
            adr & 0x1F,
            if flags.is_empty() {
                String::new()
            } else {
                format!(", {}", flags.join(", "))
            }
        ),
    );
    let net = total.saturating_sub(4);
    let pkw_bytes = 2 * usize::from(layout.pkw);
    if net < pkw_bytes || (net - pkw_bytes) % 2 != 0 {
        m.fail(format!(
            "{net} bytes of net data do not hold {} PKW words and whole PZD words{}",
            layout.pkw,
            SettingNames::named(layout.names.pkw)
        ));
    } else {
        let pzd = (net - pkw_bytes) / 2;
        if let Some(want) = layout.pzd.filter(|w| usize::from(*w) != pzd) {
            m.fail(format!(
                "{pzd} PZD words where the layout has {want}{}: LGE should be {}",
                SettingNames::named(layout.names.pzd),
                2 * (usize::from(layout.pkw) + usize::from(want)) + 2
            ));
        }
        if layout.pkw > 0 {
            explain_pkw(&mut m, bytes, 3, layout.pkw, from_master);
        }
        explain_pzd(&mut m, bytes, 3 + pkw_bytes, pzd, from_master);
    }
    if bytes.len() >= total {
        let body = bytes.get(..total - 1).unwrap_or(&[]);
        let expected = body.iter().fold(0u8, |a, b| a ^ b);
        let got = bytes.get(total - 1).copied().unwrap_or(0);
        if got == expected {
            m.push(
                bytes,
                total - 1,
                1,
                "BCC",
                format!("{got:02X}h: correct (XOR of all bytes before it)"),
            );
        } else {
            m.push(
                bytes,
                total - 1,
                1,
                "BCC",
                format!("{got:02X}h: WRONG, the XOR of the bytes before it is {expected:02X}h"),
            );
            m.fail(format!("BCC {got:02X}h, expected {expected:02X}h"));
        }
    }
    m
}

/// Split a USS capture at its STX characters and LGE lengths (see the [module docs](super)).
pub fn split_uss(capture: &Capture, layout: UssLayout) -> Vec<Message> {
    let bytes = &capture.bytes;
    let mut out = Vec::new();
    let mut master = !layout.drive_first;
    let mut at = 0;
    while at < bytes.len() {
        let rest = bytes.get(at..).unwrap_or(&[]);
        if rest.first() != Some(&0x02) {
            let skip = rest.iter().position(|b| *b == 0x02).unwrap_or(rest.len());
            let mut m = Message {
                offset: at,
                len: skip,
                bytes: rest.get(..skip).unwrap_or(rest).to_vec(),
                direction: "unrecognised",
                kind: "bytes before an STX".to_owned(),
                ..Message::default()
            };
            m.push(
                rest,
                0,
                skip,
                "bytes",
                "no STX (02h): no telegram starts here".to_owned(),
            );
            m.fail("bytes that start no telegram (a USS telegram starts with STX 02h)".to_owned());
            out.push(m);
            at += skip;
            continue;
        }
        let total = rest.get(1).map_or(rest.len(), |l| usize::from(*l) + 2);
        let len = total.clamp(1, rest.len());
        let m = explain_uss(rest.get(..len).unwrap_or(rest), at, layout, master);
        // A broadcast gets no answer: the next telegram is the master's again.
        let broadcast = master && m.address.is_some() && rest.get(2).is_some_and(|a| a & 0x20 != 0);
        if !broadcast {
            master = !master;
        }
        out.push(m);
        at += len;
    }
    out
}
