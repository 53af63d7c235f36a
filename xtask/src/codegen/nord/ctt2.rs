//! CTT2 (BU 0255 sections 4.3.1 to 4.3.5): message codes, indices, error codes and object
//! layouts from `nord_ctt2_*.csv`, rendered into `nord_ctt2.rs`.

use crate::Result;
use crate::render::{header, lit, opt_display};
use crate::table::Table;
use std::fmt::Write as _;
use std::path::Path;

/// One CTT2 message code.
#[derive(Debug, Clone)]
pub struct MessageRow {
    code: u8,
    message_type: &'static str,
    role: &'static str,
    name_de: String,
    name_en: String,
    contents_de: String,
    contents_en: String,
    printed: Option<u8>,
}

/// Read the CTT2 message codes: unique; per message type one request, one OK and one not-OK
/// response, with OK = request + 40h and not OK = request + 80h.
pub fn read_ctt2_messages(path: &Path) -> Result<Vec<MessageRow>> {
    let table = Table::read(
        path,
        &[
            "code",
            "message_type",
            "role",
            "name_de",
            "name_en",
            "contents_de",
            "contents_en",
            "printed",
        ],
    )?;
    let mut out: Vec<MessageRow> = Vec::new();
    for row in table.rows() {
        let code = row.byte("code")?;
        if out.iter().any(|m| m.code == code) {
            return Err(row.err(format!("code {code} appears twice")));
        }
        let message_type = match row.req("message_type")? {
            "standard_read" => "StandardRead",
            "nord_read" => "NordRead",
            "nord_write" => "NordWrite",
            "nord_write_read" => "NordWriteRead",
            other => return Err(row.err(format!("message_type `{other}` is unknown"))),
        };
        let role = match row.req("role")? {
            "request" => "Request",
            "ok" => "ResponseOk",
            "error" => "ResponseError",
            other => return Err(row.err(format!("role `{other}` is not request, ok or error"))),
        };
        if out
            .iter()
            .any(|m| m.message_type == message_type && m.role == role)
        {
            return Err(row.err(format!("{message_type} has a second {role} code")));
        }
        let printed = match row.opt_int("printed")? {
            None => None,
            Some(p) => Some(
                u8::try_from(p)
                    .ok()
                    .filter(|p| *p != code)
                    .ok_or_else(|| row.err("printed must be a byte that differs from code"))?,
            ),
        };
        let (contents_de, contents_en) = row.text_pair("contents_de", "contents_en")?;
        out.push(MessageRow {
            code,
            message_type,
            role,
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
            contents_de: contents_de.to_owned(),
            contents_en: contents_en.to_owned(),
            printed,
        });
    }
    for (row, m) in table.rows().iter().zip(&out) {
        if m.role == "Request" {
            if m.code & 0xC0 != 0 {
                return Err(row.err(format!("request code {} has bit 6 or 7 set", m.code)));
            }
            continue;
        }
        let request = out
            .iter()
            .find(|r| r.message_type == m.message_type && r.role == "Request")
            .ok_or_else(|| row.err(format!("{} has no request code", m.message_type)))?;
        let expected = request.code | if m.role == "ResponseOk" { 0x40 } else { 0x80 };
        if m.code != expected {
            return Err(row.err(format!(
                "response code {} (0x{:02X}) must be request {} + 0x{:02X} = {expected} (0x{expected:02X})",
                m.code,
                m.code,
                request.code,
                if m.role == "ResponseOk" { 0x40 } else { 0x80 }
            )));
        }
    }
    for t in ["StandardRead", "NordRead", "NordWrite", "NordWriteRead"] {
        for r in ["Request", "ResponseOk", "ResponseError"] {
            if !out.iter().any(|m| m.message_type == t && m.role == r) {
                return Err(table.err(format!("message type {t} has no {r} code")));
            }
        }
    }
    Ok(out)
}

/// One CTT2 index (object).
#[derive(Debug, Clone)]
pub struct IndexRow {
    index: u8,
    standard: bool,
    object_de: String,
    object_en: String,
    max_len: u8,
    write_lengths: Vec<u8>,
    address: bool,
}

/// Read the CTT2 indices: unique; write lengths within the maximum length.
pub fn read_ctt2_indices(path: &Path) -> Result<Vec<IndexRow>> {
    let table = Table::read(
        path,
        &[
            "index",
            "scope",
            "object_de",
            "object_en",
            "max_len",
            "write_lengths",
            "address",
        ],
    )?;
    let mut out: Vec<IndexRow> = Vec::new();
    for row in table.rows() {
        let index = row.byte("index")?;
        if out.iter().any(|i| i.index == index) {
            return Err(row.err(format!("index {index} appears twice")));
        }
        let standard = match row.req("scope")? {
            "standard" => true,
            "nord" => false,
            other => return Err(row.err(format!("scope `{other}` is not standard or nord"))),
        };
        let max_len = row.byte("max_len")?;
        if max_len == 0 {
            return Err(row.err("max_len must be at least 1"));
        }
        let write_lengths: Vec<u8> = row.list("write_lengths")?;
        if let Some(n) = write_lengths.iter().find(|&&n| n == 0 || n > max_len) {
            return Err(row.err(format!("write length {n} is outside 1..{max_len}")));
        }
        if standard && !write_lengths.is_empty() {
            return Err(row.err("standard-read objects cannot be written"));
        }
        out.push(IndexRow {
            index,
            standard,
            object_de: row.req("object_de")?.to_owned(),
            object_en: row.req("object_en")?.to_owned(),
            max_len,
            write_lengths,
            address: row.flag("address")?,
        });
    }
    Ok(out)
}

/// One CTT2 error code.
#[derive(Debug, Clone)]
pub struct Ctt2ErrorRow {
    code: u8,
    meaning_de: String,
    meaning_en: String,
}

/// Read the CTT2 error codes: unique, non-zero.
pub fn read_ctt2_errors(path: &Path) -> Result<Vec<Ctt2ErrorRow>> {
    let table = Table::read(path, &["code", "meaning_de", "meaning_en"])?;
    let mut out: Vec<Ctt2ErrorRow> = Vec::new();
    for row in table.rows() {
        let code = row.byte("code")?;
        if code == 0 || out.iter().any(|e| e.code == code) {
            return Err(row.err(format!("error code {code} is zero or appears twice")));
        }
        out.push(Ctt2ErrorRow {
            code,
            meaning_de: row.req("meaning_de")?.to_owned(),
            meaning_en: row.req("meaning_en")?.to_owned(),
        });
    }
    Ok(out)
}

/// One byte of a standard-read object.
#[derive(Debug, Clone)]
pub struct ObjectByteRow {
    index: u8,
    byte: u8,
    name_de: String,
    name_en: String,
}

/// Read the object layouts: every byte 1..max_len of each described standard object, once.
pub fn read_ctt2_objects(path: &Path, indices: &[IndexRow]) -> Result<Vec<ObjectByteRow>> {
    let table = Table::read(path, &["index", "byte", "name_de", "name_en"])?;
    let mut out: Vec<ObjectByteRow> = Vec::new();
    for row in table.rows() {
        let index = row.byte("index")?;
        let ix = indices
            .iter()
            .find(|i| i.index == index && i.standard)
            .ok_or_else(|| row.err(format!("index {index} is not a standard-read object")))?;
        let b = row.byte("byte")?;
        if b == 0 || b > ix.max_len {
            return Err(row.err(format!("byte {b} is outside 1..{}", ix.max_len)));
        }
        if out.iter().any(|o| o.index == index && o.byte == b) {
            return Err(row.err(format!("byte {b} of index {index} appears twice")));
        }
        out.push(ObjectByteRow {
            index,
            byte: b,
            name_de: row.req("name_de")?.to_owned(),
            name_en: row.req("name_en")?.to_owned(),
        });
    }
    for ix in indices
        .iter()
        .filter(|i| out.iter().any(|o| o.index == i.index))
    {
        let n = out.iter().filter(|o| o.index == ix.index).count();
        if n != usize::from(ix.max_len) {
            return Err(table.err(format!(
                "index {} describes {n} of its {} bytes",
                ix.index, ix.max_len
            )));
        }
    }
    out.sort_by_key(|o| (o.index, o.byte));
    Ok(out)
}

/// Render `nord_ctt2.rs`.
pub(super) fn render_ctt2(
    messages: &[MessageRow],
    indices: &[IndexRow],
    errors: &[Ctt2ErrorRow],
    objects: &[ObjectByteRow],
) -> String {
    let mut s = header(
        "nord/nord_ctt2_messages.csv, nord/nord_ctt2_indices.csv, nord/nord_ctt2_errors.csv, \
         nord/nord_ctt2_objects.csv",
    );
    s.push_str(
        "use crate::nord::{Ctt2Error, Ctt2Index, Ctt2Message, Ctt2MessageType, Ctt2ObjectByte, \
         Ctt2Role};\n\n",
    );
    s.push_str("/// CTT2 message codes, BU 0255 sections 4.3.1 to 4.3.4.\n");
    let _ = writeln!(
        s,
        "pub static MESSAGES: [Ctt2Message; {}] = [",
        messages.len()
    );
    for m in messages {
        let _ = writeln!(
            s,
            "    Ctt2Message {{ code: {}, message_type: Ctt2MessageType::{}, role: Ctt2Role::{}, \
             name_de: {}, name_en: {}, contents_de: {}, contents_en: {}, printed: {} }},",
            m.code,
            m.message_type,
            m.role,
            lit(&m.name_de),
            lit(&m.name_en),
            lit(&m.contents_de),
            lit(&m.contents_en),
            opt_display(m.printed),
        );
    }
    s.push_str("];\n\n");
    s.push_str("/// CTT2 indices (objects), BU 0255 sections 4.3.1 to 4.3.4.\n");
    let _ = writeln!(s, "pub static INDICES: [Ctt2Index; {}] = [", indices.len());
    for i in indices {
        let list: Vec<String> = i.write_lengths.iter().map(u8::to_string).collect();
        let _ = writeln!(
            s,
            "    Ctt2Index {{ index: {}, standard: {}, object_de: {}, object_en: {}, max_len: {}, \
             write_lengths: &[{}], address: {} }},",
            i.index,
            i.standard,
            lit(&i.object_de),
            lit(&i.object_en),
            i.max_len,
            list.join(", "),
            i.address,
        );
    }
    s.push_str("];\n\n");
    s.push_str("/// CTT2 error codes, BU 0255 section 4.3.5.\n");
    let _ = writeln!(s, "pub static ERRORS: [Ctt2Error; {}] = [", errors.len());
    for e in errors {
        let _ = writeln!(
            s,
            "    Ctt2Error {{ code: {}, meaning_de: {}, meaning_en: {} }},",
            e.code,
            lit(&e.meaning_de),
            lit(&e.meaning_en),
        );
    }
    s.push_str("];\n\n");
    s.push_str("/// Byte layout of the standard-read objects, BU 0255 section 4.3.1.\n");
    let _ = writeln!(
        s,
        "pub static OBJECT_BYTES: [Ctt2ObjectByte; {}] = [",
        objects.len()
    );
    for o in objects {
        let _ = writeln!(
            s,
            "    Ctt2ObjectByte {{ index: {}, byte: {}, name_de: {}, name_en: {} }},",
            o.index,
            o.byte,
            lit(&o.name_de),
            lit(&o.name_en),
        );
    }
    s.push_str("];\n");
    s
}

#[cfg(test)]
mod tests {
    use super::super::tests::{edited, expect_err, line_of};
    use super::*;

    #[test]
    fn ctt2_response_code_rule_catches_the_manual_misprint() {
        let f = "nord_ctt2_messages.csv";
        let n = line_of(f, "157,");
        // What the manual prints in section 4.3.4.
        let d = edited(
            "ctt2code",
            f,
            "157,",
            "177,nord_write_read,error,Schreib-/Leseantwort nicht OK,x,Fehlercode,error code,",
        );
        let r = read_ctt2_messages(&d.file(f));
        expect_err(r, f, n, "must be request 29 + 0x80 = 157");
    }
}
