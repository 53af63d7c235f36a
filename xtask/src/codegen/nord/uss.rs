//! USS PKW codes (BU 0255 section 4.6.1.1): order IDs, response IDs and PWE2 error numbers
//! from `nord_ak_requests.csv`, `nord_ak_responses.csv` and `nord_pwe_errors.csv`, rendered
//! into `nord_uss.rs`.

use crate::Result;
use crate::render::{header, lit, opt};
use crate::table::{Row, Table};
use std::fmt::Write as _;
use std::path::Path;

/// One response ID.
#[derive(Debug, Clone)]
pub struct AkResponseRow {
    ak: u8,
    meaning_de: String,
    meaning_en: String,
    kind: &'static str,
    width: Option<&'static str>,
}

/// Column `width`: `word`, `dword` or empty.
fn width(row: &Row) -> Result<Option<&'static str>> {
    match row.str("width")? {
        "" => Ok(None),
        "word" => Ok(Some("Word")),
        "dword" => Ok(Some("DoubleWord")),
        other => Err(row.err(format!("width `{other}` is not word, dword or empty"))),
    }
}

/// Column `ak`: an ID in PKE bits 12..15 (0..15) that none of the rows `above` has.
fn ak(row: &Row, above: impl IntoIterator<Item = u8>) -> Result<u8> {
    let v = row.int("ak")?;
    if !(0..=15).contains(&v) {
        return Err(row.err(format!("AK {v} does not fit PKE bits 12..15 (0..15)")));
    }
    let code = v as u8;
    if above.into_iter().any(|a| a == code) {
        return Err(row.err(format!("AK {code} appears twice")));
    }
    Ok(code)
}

/// Read the response IDs: unique, 0..15, exactly one error response.
pub fn read_ak_responses(path: &Path) -> Result<Vec<AkResponseRow>> {
    let table = Table::read(path, &["ak", "meaning_de", "meaning_en", "kind", "width"])?;
    let mut out: Vec<AkResponseRow> = Vec::new();
    for row in table.rows() {
        let code = ak(row, out.iter().map(|r| r.ak))?;
        let kind = match row.req("kind")? {
            "none" => "None",
            "value" => "Value",
            "array_value" => "ArrayValue",
            "count" => "Count",
            "error" => "Error",
            other => return Err(row.err(format!("kind `{other}` is not a response kind"))),
        };
        let width = width(row)?;
        if matches!(kind, "Value" | "ArrayValue") != width.is_some() {
            return Err(row.err("value responses, and only they, need a width"));
        }
        if kind == "Error" && out.iter().any(|r| r.kind == "Error") {
            return Err(row.err("only one response ID may be the error response"));
        }
        out.push(AkResponseRow {
            ak: code,
            meaning_de: row.req("meaning_de")?.to_owned(),
            meaning_en: row.req("meaning_en")?.to_owned(),
            kind,
            width,
        });
    }
    if !out.iter().any(|r| r.kind == "Error") {
        return Err(table.err("no error response ID (kind error)"));
    }
    Ok(out)
}

/// One order ID.
#[derive(Debug, Clone)]
pub struct AkRequestRow {
    ak: u8,
    function_de: String,
    function_en: String,
    kind: &'static str,
    width: Option<&'static str>,
    array: bool,
    eeprom: bool,
    responses: Vec<u8>,
}

/// Read the order IDs and check each positive response against the response table: it must
/// exist, not be the error response, and fit the order's kind, width and array flag.
pub fn read_ak_requests(path: &Path, responses: &[AkResponseRow]) -> Result<Vec<AkRequestRow>> {
    let table = Table::read(
        path,
        &[
            "ak",
            "function_de",
            "function_en",
            "kind",
            "width",
            "array",
            "eeprom",
            "responses",
        ],
    )?;
    let mut out: Vec<AkRequestRow> = Vec::new();
    for row in table.rows() {
        let code = ak(row, out.iter().map(|r| r.ak))?;
        let kind = match row.req("kind")? {
            "none" => "None",
            "read" => "Read",
            "write" => "Write",
            "count" => "Count",
            "reserved" => "Reserved",
            other => return Err(row.err(format!("kind `{other}` is not an order kind"))),
        };
        let width = width(row)?;
        if (kind == "Write") != width.is_some() {
            return Err(row.err("write orders, and only they, need a width"));
        }
        let array = row.flag("array")?;
        let eeprom = row.flag("eeprom")?;
        if eeprom && kind != "Write" {
            return Err(row.err("only a write order can write to EEPROM"));
        }
        let list: Vec<u8> = row.list("responses")?;
        for &n in &list {
            let resp = responses
                .iter()
                .find(|r| r.ak == n)
                .ok_or_else(|| row.err(format!("response AK {n} is not in the response table")))?;
            let fits = match kind {
                "None" => resp.kind == "None",
                "Read" => {
                    resp.kind == if array { "ArrayValue" } else { "Value" } && resp.width.is_some()
                }
                "Write" => {
                    resp.kind == if array { "ArrayValue" } else { "Value" } && resp.width == width
                }
                "Count" => resp.kind == "Count",
                _ => false,
            };
            if !fits {
                return Err(row.err(format!(
                    "response AK {n} ({}) does not answer this order",
                    resp.meaning_en
                )));
            }
        }
        if (kind == "Reserved") != list.is_empty() {
            return Err(row.err("reserved orders, and only they, have no positive response"));
        }
        out.push(AkRequestRow {
            ak: code,
            function_de: row.req("function_de")?.to_owned(),
            function_en: row.req("function_en")?.to_owned(),
            kind,
            width,
            array,
            eeprom,
            responses: list,
        });
    }
    Ok(out)
}

/// One PWE2 error number.
#[derive(Debug, Clone)]
pub struct PweRow {
    number: u16,
    meaning_de: String,
    meaning_en: String,
}

/// Read the PWE2 error numbers: unique; a meaning in both languages or in neither.
pub fn read_pwe_errors(path: &Path) -> Result<Vec<PweRow>> {
    let table = Table::read(path, &["number", "meaning_de", "meaning_en"])?;
    let mut out: Vec<PweRow> = Vec::new();
    for row in table.rows() {
        let n = row.int("number")?;
        let number =
            u16::try_from(n).map_err(|_| row.err(format!("error number {n} is not 0..65535")))?;
        if out.iter().any(|r| r.number == number) {
            return Err(row.err(format!("error number {number} appears twice")));
        }
        let (de, en) = row.text_pair("meaning_de", "meaning_en")?;
        out.push(PweRow {
            number,
            meaning_de: de.to_owned(),
            meaning_en: en.to_owned(),
        });
    }
    Ok(out)
}

/// Render `nord_uss.rs`.
pub(super) fn render_uss(
    requests: &[AkRequestRow],
    responses: &[AkResponseRow],
    pwe: &[PweRow],
) -> String {
    let mut s =
        header("nord/nord_ak_requests.csv, nord/nord_ak_responses.csv, nord/nord_pwe_errors.csv");
    s.push_str(
        "use crate::nord::{AkInfo, AkRequest, AkRequestKind, AkResponseKind, PweError, Width};\n\n",
    );
    s.push_str("/// USS order IDs (AK in PKE bits 12..15), BU 0255 section 4.6.1.1.\n");
    let _ = writeln!(
        s,
        "pub static AK_REQUESTS: [AkRequest; {}] = [",
        requests.len()
    );
    for r in requests {
        let list: Vec<String> = r.responses.iter().map(u8::to_string).collect();
        let _ = writeln!(
            s,
            "    AkRequest {{ ak: {}, function_de: {}, function_en: {}, kind: AkRequestKind::{}, \
             width: {}, array: {}, eeprom: {}, responses: &[{}] }},",
            r.ak,
            lit(&r.function_de),
            lit(&r.function_en),
            r.kind,
            opt(r.width, |w| format!("Width::{w}")),
            r.array,
            r.eeprom,
            list.join(", "),
        );
    }
    s.push_str("];\n\n");
    s.push_str("/// USS response IDs, BU 0255 section 4.6.1.1.\n");
    let _ = writeln!(
        s,
        "pub static AK_RESPONSES: [AkInfo; {}] = [",
        responses.len()
    );
    for r in responses {
        let _ = writeln!(
            s,
            "    AkInfo {{ ak: {}, meaning_de: {}, meaning_en: {}, kind: AkResponseKind::{}, \
             width: {} }},",
            r.ak,
            lit(&r.meaning_de),
            lit(&r.meaning_en),
            r.kind,
            opt(r.width, |w| format!("Width::{w}")),
        );
    }
    s.push_str("];\n\n");
    s.push_str("/// Error numbers in PWE2 of a response with AK 7, BU 0255 section 4.6.1.1.\n");
    let _ = writeln!(s, "pub static PWE_ERRORS: [PweError; {}] = [", pwe.len());
    for e in pwe {
        let _ = writeln!(
            s,
            "    PweError {{ number: {}, meaning_de: {}, meaning_en: {} }},",
            e.number,
            lit(&e.meaning_de),
            lit(&e.meaning_en),
        );
    }
    s.push_str("];\n");
    s
}

#[cfg(test)]
mod tests {
    use super::super::tests::{edited, expect_err, line_of, real};
    use super::*;

    #[test]
    fn duplicate_ak_is_rejected() {
        let f = "nord_ak_responses.csv";
        let n = line_of(f, "2,");
        let d = edited("dupak", f, "2,", "1,x,x,value,dword");
        expect_err(read_ak_responses(&d.file(f)), f, n, "AK 1 appears twice");
    }

    #[test]
    fn request_response_mismatch_is_rejected() {
        let responses = read_ak_responses(&real("nord_ak_responses.csv")).unwrap();
        let f = "nord_ak_requests.csv";
        let n = line_of(f, "7,");
        // A word array write answered with a double-word response.
        let d = edited("akmismatch", f, "7,", "7,x,x,write,word,1,1,5");
        let r = read_ak_requests(&d.file(f), &responses);
        expect_err(r, f, n, "response AK 5");
    }
}
