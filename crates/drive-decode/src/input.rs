//! The input every decoder reads: hex bytes from arguments ([`parse_hex`]) or a capture of
//! text lines ([`parse_text`], [`parse_capture`]), into a [`Capture`] that remembers the line
//! each byte came from.

use std::fmt;

use crate::shape::escape;

/// A capture: the bytes, and for input read from lines the line each byte came from.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Capture {
    /// The bytes in input order.
    pub bytes: Vec<u8>,
    /// 1-based input line of each byte; empty for bytes given as arguments.
    pub lines: Vec<usize>,
}

impl Capture {
    /// A capture of `bytes` without lines (given as arguments).
    pub fn from_bytes(bytes: Vec<u8>) -> Self {
        Self {
            bytes,
            lines: Vec::new(),
        }
    }

    /// The input line of the byte at `offset`, if the capture came from lines.
    pub fn line_of(&self, offset: usize) -> Option<usize> {
        self.lines.get(offset).copied()
    }

    /// Offsets (after 0) where a new input line starts: a telegram does not cross one unless
    /// its check character proves it was wrapped.
    pub fn line_starts(&self) -> Vec<usize> {
        self.lines
            .windows(2)
            .enumerate()
            .filter(|(_, w)| w.first() != w.get(1))
            .map(|(i, _)| i + 1)
            .collect()
    }
}

/// Where a token of the input is.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Place {
    /// In the only argument, at this 1-based column.
    Column(usize),
    /// In argument `argument` (1-based), at `column`.
    Argument {
        /// The argument, counting from 1.
        argument: usize,
        /// The column in it, counting from 1.
        column: usize,
    },
    /// In line `line` of the input named `input`, at `column`.
    Line {
        /// The input's name (escaped for a terminal).
        input: String,
        /// The line, counting from 1.
        line: usize,
        /// The column, counting from 1.
        column: usize,
    },
}

impl fmt::Display for Place {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Column(c) => write!(f, "column {c}"),
            Self::Argument { argument, column } => {
                write!(f, "argument {argument}, column {column}")
            }
            Self::Line {
                input,
                line,
                column,
            } => write!(f, "{input} line {line}, column {column}"),
        }
    }
}

/// Why input is no capture. Tokens and names are shown escaped ([`escape`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum InputError {
    /// A token has a character that is no hex digit (a leading `-` too).
    #[error("{place}: `{token}` is not hex (`{bad}` is not a hex digit)")]
    NotHex {
        /// Where the token is.
        place: Place,
        /// The token.
        token: String,
        /// The first character that is no hex digit.
        bad: String,
    },
    /// A token is only the `0x` prefix.
    #[error("{place}: `{token}` has no hex digits after the prefix")]
    NoDigits {
        /// Where the token is.
        place: Place,
        /// The token.
        token: String,
    },
    /// A token has an odd number of hex digits: a byte is two.
    #[error("{place}: `{token}` has an odd number of hex digits ({digits})")]
    OddDigits {
        /// Where the token is.
        place: Place,
        /// The token.
        token: String,
        /// How many hex digits it has.
        digits: usize,
    },
    /// The arguments hold no bytes.
    #[error("no bytes given")]
    NoBytes,
    /// The input named `input` holds no bytes (only blank lines and comments).
    #[error("{input} holds no bytes")]
    Empty {
        /// The input's name.
        input: String,
    },
    /// The input named `input` is not UTF-8 text.
    #[error("{input} is not text (byte {at} is not UTF-8)")]
    NotText {
        /// The input's name.
        input: String,
        /// Offset of the first byte that is no UTF-8.
        at: usize,
    },
}

/// Characters between bytes or groups of bytes: white space, commas and colons.
fn is_separator(c: char) -> bool {
    c.is_whitespace() || c == ',' || c == ':'
}

/// The tokens of `text` with the 1-based column (in characters) where each starts.
fn tokens(text: &str) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let mut start: Option<(usize, usize)> = None;
    for (col, (i, c)) in text.char_indices().enumerate() {
        match (is_separator(c), start) {
            (true, Some((s, s_col))) => {
                out.push((s_col + 1, text.get(s..i).unwrap_or("")));
                start = None;
            }
            (false, None) => start = Some((i, col)),
            _ => {}
        }
    }
    if let Some((s, s_col)) = start {
        out.push((s_col + 1, text.get(s..).unwrap_or("")));
    }
    out
}

/// The bytes of one token: hex digits in pairs, optionally after one `0x`/`0X` prefix
/// (`02`, `0x02`, `020186`, `0x020186`).
fn token_bytes(
    token: &str,
    place: impl Fn() -> Place,
    out: &mut Vec<u8>,
) -> Result<(), InputError> {
    let digits = token
        .strip_prefix("0x")
        .or_else(|| token.strip_prefix("0X"))
        .unwrap_or(token);
    if let Some(bad) = digits.chars().find(|c| !c.is_ascii_hexdigit()) {
        return Err(InputError::NotHex {
            place: place(),
            token: escape(token),
            bad: escape(&bad.to_string()),
        });
    }
    if digits.is_empty() {
        return Err(InputError::NoDigits {
            place: place(),
            token: escape(token),
        });
    }
    if digits.len() % 2 == 1 {
        return Err(InputError::OddDigits {
            place: place(),
            token: escape(token),
            digits: digits.len(),
        });
    }
    for pair in digits.as_bytes().chunks(2) {
        let byte = std::str::from_utf8(pair)
            .ok()
            .and_then(|s| u8::from_str_radix(s, 16).ok())
            .ok_or_else(|| InputError::NotHex {
                place: place(),
                token: escape(token),
                bad: escape(&String::from_utf8_lossy(pair)),
            })?;
        out.push(byte);
    }
    Ok(())
}

/// Parse hex arguments: `02 01 85`, `020185`, `0x02,0x01` and mixtures. Every token must be
/// whole bytes: an odd number of digits or a non-hex character (a leading `-` too) is an error
/// naming the argument and the token.
///
/// # Errors
///
/// [`InputError`]: a token that is no hex bytes, or no bytes at all.
pub fn parse_hex<S: AsRef<str>>(args: &[S]) -> Result<Vec<u8>, InputError> {
    let mut bytes = Vec::new();
    for (n, a) in args.iter().enumerate() {
        for (column, token) in tokens(a.as_ref()) {
            let place = || {
                if args.len() == 1 {
                    Place::Column(column)
                } else {
                    Place::Argument {
                        argument: n + 1,
                        column,
                    }
                }
            };
            token_bytes(token, place, &mut bytes)?;
        }
    }
    if bytes.is_empty() {
        return Err(InputError::NoBytes);
    }
    Ok(bytes)
}

/// Parse a capture of text lines (`input` names it in errors): hex bytes as for
/// [`parse_hex`], one telegram per line or a stream over several lines. A UTF-8 byte order
/// mark, CR LF line ends, blank lines and `#` comments (to the end of the line) are allowed.
///
/// # Errors
///
/// [`InputError`]: a token that is no hex bytes, or no bytes at all.
pub fn parse_text(text: &str, input: &str) -> Result<Capture, InputError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut capture = Capture::default();
    for (n, line) in text.lines().enumerate() {
        let content = line.split_once('#').map_or(line, |(before, _)| before);
        let before = capture.bytes.len();
        for (column, token) in tokens(content) {
            let place = || Place::Line {
                input: escape(input),
                line: n + 1,
                column,
            };
            token_bytes(token, place, &mut capture.bytes)?;
        }
        let added = capture.bytes.len() - before;
        capture.lines.extend(std::iter::repeat_n(n + 1, added));
    }
    if capture.bytes.is_empty() {
        return Err(InputError::Empty {
            input: escape(input),
        });
    }
    Ok(capture)
}

/// [`parse_text`] of raw input (a file's bytes), which must be UTF-8.
///
/// # Errors
///
/// [`InputError::NotText`], or those of [`parse_text`].
pub fn parse_capture(raw: Vec<u8>, input: &str) -> Result<Capture, InputError> {
    let text = String::from_utf8(raw).map_err(|e| InputError::NotText {
        input: escape(input),
        at: e.utf8_error().valid_up_to(),
    })?;
    parse_text(&text, input)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A read request of P070 (index 8301) to address 1, with its correct BCC.
    const READ_8301: [u8; 12] = [
        0x02, 0x01, 0x86, 0x31, 0x00, 0x20, 0x6D, 0x00, 0x00, 0x00, 0x00, 0xF9,
    ];
    /// Its response: 60 001 553, BCC correct.
    const ANSWER_8301: [u8; 12] = [
        0x1D, 0x01, 0x86, 0x31, 0x00, 0x20, 0x6D, 0x03, 0x93, 0x8D, 0x11, 0xEA,
    ];

    fn message<T: std::fmt::Debug>(r: Result<T, InputError>) -> String {
        match r {
            Ok(v) => panic!("expected an error, got {v:?}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn hex_tokens_are_whole_bytes() {
        assert_eq!(
            parse_hex(&["02 01", "0x86,0x31", "00:20:6D", "00000000F9"]).unwrap(),
            READ_8301
        );
        let odd = message(parse_hex(&["02", "1", "86"]));
        assert!(odd.contains("argument 2") && odd.contains("`1`"), "{odd}");
        assert!(odd.contains("odd number"), "{odd}");
        let odd = message(parse_hex(&["02 01 860"]));
        assert!(odd.contains("column 7") && odd.contains("`860`"), "{odd}");
        let dash = message(parse_hex(&["-02", "01"]));
        assert!(dash.contains("`-02` is not hex"), "{dash}");
        let bare = message(parse_hex(&["0x"]));
        assert!(bare.contains("no hex digits"), "{bare}");
        assert_eq!(parse_hex(&["  "]), Err(InputError::NoBytes));
    }

    #[test]
    fn text_captures_allow_bom_crlf_blank_lines_and_comments() {
        let text = "\u{feff}# read P070\r\n02 01 86 31 00 20 6D 00 00 00 00 F9\r\n\r\n\
                    1D 01 86 31 00 20 6D 03 93 8D 11 EA # answer\r\n";
        let c = parse_text(text, "capture.txt").unwrap();
        assert_eq!(c.bytes, [READ_8301, ANSWER_8301].concat());
        assert_eq!(c.lines.first(), Some(&2));
        assert_eq!(c.lines.last(), Some(&4));
        let bad = message(parse_text("02 01\n86 3\n", "capture.txt"));
        assert!(bad.contains("capture.txt line 2, column 4"), "{bad}");
        assert!(parse_text("# nothing\n\n", "capture.txt").is_err());
        assert_eq!(
            parse_capture(vec![0x30, 0xFF], "x"),
            Err(InputError::NotText {
                input: "x".into(),
                at: 1
            })
        );
    }
}
