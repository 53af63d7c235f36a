//! USS serial telegrams: addresses, the layout of the net data, and the codec.
//!
//! A telegram on the RS-485 line is (USS specification, as the Siemens drive manuals publish
//! it; see `docs/protocols/uss.md`):
//!
//! | byte | field | meaning |
//! |---|---|---|
//! | 0 | STX | start of text, always 02h |
//! | 1 | LGE | the number of bytes after LGE: ADR + net data + BCC |
//! | 2 | ADR | bits 0–4 the slave address 0–31, bit 5 broadcast, bit 6 mirror, bit 7 special |
//! | 3 … | PKW | the parameter channel, 0, 3 or 4 words (PKE, IND, PWE1, PWE2; the 3-word form has one PWE word) |
//! | … | PZD | process data, 0–16 words (control/status word first) |
//! | last | BCC | XOR of every byte before it |
//!
//! Every word travels high byte first. The net data are not self-describing: how many PKW
//! and PZD words a telegram carries is a fixed setting on both sides ([`Layout`]), and
//! [`Telegram::decode`] checks LGE against it.
//!
//! ```
//! use ctt2_uss::serial::telegram::{Adr, Layout, Telegram, UssAddress};
//! use ctt2_uss::uss::pkw::{Ind, Order};
//!
//! // Read P102 in parameter set 1 from drive 3, with control word 047Eh and setpoint 0.
//! let layout = Layout::new(4, 2).unwrap();
//! let order = Order::read(102, Ind::ZERO).unwrap().to_pkw();
//! let t = Telegram::new(Adr::new(UssAddress::new(3).unwrap()), layout, order, &[0x047E, 0])
//!     .unwrap();
//! let mut wire = [0u8; 64];
//! let n = t.encode(&mut wire).unwrap();
//! assert_eq!(n, 16);
//! assert_eq!(&wire[..4], [0x02, 0x0E, 0x03, 0x10]); // STX, LGE 14, ADR 3, PKE high byte
//! assert_eq!(Telegram::decode(&wire[..n], layout), Ok(t));
//! ```

use core::fmt;

use crate::uss::pkw::Pkw;

/// Start of text, the first byte of every telegram.
pub const STX: u8 = 0x02;

/// The most process-data words a telegram carries.
pub const MAX_PZD: usize = 16;

/// The most PKW words a telegram carries.
pub const MAX_PKW: usize = 4;

/// The longest telegram: STX, LGE, ADR, 4 PKW and 16 PZD words, BCC.
pub const MAX_TELEGRAM: usize = 4 + 2 * (MAX_PKW + MAX_PZD);

/// The shortest telegram: STX, LGE, ADR, BCC (no net data).
pub const MIN_TELEGRAM: usize = 4;

/// A slave address, 0–31 (ADR bits 0–4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct UssAddress(u8);

impl UssAddress {
    /// The highest address.
    pub const MAX: u8 = 31;

    /// The address `a`, if it is 0–31.
    pub const fn new(a: u8) -> Option<UssAddress> {
        if a <= Self::MAX {
            Some(UssAddress(a))
        } else {
            None
        }
    }

    /// The number.
    pub const fn get(self) -> u8 {
        self.0
    }
}

impl fmt::Display for UssAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// The ADR byte: the slave address and three flags. Every byte value is a valid ADR on the
/// wire; what a receiver makes of the flags is its business (see the constructors).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Adr(pub u8);

impl Adr {
    /// Bit 5: every slave executes the telegram and none answers; the address bits are not
    /// evaluated.
    pub const BROADCAST: u8 = 0x20;
    /// Bit 6: the addressed slave sends the telegram back unchanged.
    pub const MIRROR: u8 = 0x40;
    /// Bit 7: a special telegram (reserved by the USS specification; drivebus sends none and
    /// its slave ignores them).
    pub const SPECIAL: u8 = 0x80;

    /// A normal telegram to (or answer from) `address`.
    pub const fn new(address: UssAddress) -> Adr {
        Adr(address.0)
    }

    /// A broadcast (address bits 0).
    pub const fn broadcast() -> Adr {
        Adr(Self::BROADCAST)
    }

    /// A mirror telegram to `address`.
    pub const fn mirror(address: UssAddress) -> Adr {
        Adr(Self::MIRROR | address.0)
    }

    /// The address bits 0–4.
    pub const fn address(self) -> UssAddress {
        UssAddress(self.0 & 0x1F)
    }

    /// Bit 5.
    pub const fn is_broadcast(self) -> bool {
        self.0 & Self::BROADCAST != 0
    }

    /// Bit 6.
    pub const fn is_mirror(self) -> bool {
        self.0 & Self::MIRROR != 0
    }

    /// Bit 7.
    pub const fn is_special(self) -> bool {
        self.0 & Self::SPECIAL != 0
    }
}

impl fmt::Debug for Adr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Adr(0x{:02X}: address {}", self.0, self.address().0)?;
        for (bit, name) in [
            (self.is_broadcast(), ", broadcast"),
            (self.is_mirror(), ", mirror"),
            (self.is_special(), ", special"),
        ] {
            if bit {
                f.write_str(name)?;
            }
        }
        f.write_str(")")
    }
}

/// How many PKW and PZD words the net data hold: a fixed setting of master and slave.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Layout {
    pkw_words: u8,
    pzd_words: u8,
}

/// Why a [`Layout`] cannot be made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum LayoutError {
    /// The PKW part is 0, 3 or 4 words.
    #[error("a PKW part of {0} words (must be 0, 3 or 4)")]
    PkwWords(u8),
    /// At most 16 PZD words.
    #[error("{0} PZD words (at most 16)")]
    PzdWords(u8),
}

impl Layout {
    /// The typical USS telegram: 4 PKW words, 2 PZD words (16 bytes).
    pub const PKW4_PZD2: Layout = Layout {
        pkw_words: 4,
        pzd_words: 2,
    };

    /// The NORD process data in full: 4 PKW words, control/status word and 3 setpoints/actual
    /// values (20 bytes).
    pub const PKW4_PZD4: Layout = Layout {
        pkw_words: 4,
        pzd_words: 4,
    };

    /// `pkw_words` (0, 3 or 4) PKW words and `pzd_words` (0–16) PZD words.
    pub const fn new(pkw_words: u8, pzd_words: u8) -> Result<Layout, LayoutError> {
        if !matches!(pkw_words, 0 | 3 | 4) {
            return Err(LayoutError::PkwWords(pkw_words));
        }
        if pzd_words as usize > MAX_PZD {
            return Err(LayoutError::PzdWords(pzd_words));
        }
        Ok(Layout {
            pkw_words,
            pzd_words,
        })
    }

    /// PKW words: 0, 3 or 4.
    pub const fn pkw_words(self) -> u8 {
        self.pkw_words
    }

    /// PZD words: 0–16.
    pub const fn pzd_words(self) -> u8 {
        self.pzd_words
    }

    /// Bytes of net data (PKW and PZD).
    pub const fn net_len(self) -> usize {
        2 * (self.pkw_words as usize + self.pzd_words as usize)
    }

    /// The LGE byte of a telegram of this layout: ADR + net data + BCC.
    pub const fn lge(self) -> u8 {
        (self.net_len() + 2) as u8
    }

    /// The whole telegram's length on the wire: STX + LGE + [`Layout::lge`].
    pub const fn telegram_len(self) -> usize {
        self.net_len() + 4
    }
}

/// Why a [`Telegram`] cannot be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum TelegramError {
    /// The process data do not have the layout's number of words.
    #[error("{got} PZD words for a layout of {expected}")]
    PzdWords {
        /// The layout's.
        expected: u8,
        /// Given.
        got: usize,
    },
    /// The 3-word PKW carries one value word: PWE1 must be 0000h or the sign of PWE2 (FFFFh
    /// with bit 15 of PWE2 set), else the value would be cut.
    #[error("the 3-word PKW cannot carry PWE1 = {pwe1:#06x} with PWE2 = {pwe2:#06x}")]
    PkwValueTooWide {
        /// PWE1 of the channel.
        pwe1: u16,
        /// PWE2 of the channel.
        pwe2: u16,
    },
}

/// Why bytes are not a telegram of the expected layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum FrameError {
    /// The receiver dropped the characters (a UART error, a gap, a character right after the
    /// telegram, too long).
    #[error("{0}")]
    Line(#[from] drive_core::LineError),
    /// The first byte is not STX.
    #[error("telegram starts with {0:#04x}, not STX (02h)")]
    BadStx(u8),
    /// LGE does not fit the layout (or is below 2).
    #[error("LGE {got} does not match the layout (LGE {expected})")]
    BadLength {
        /// The layout's LGE.
        expected: u8,
        /// The LGE received.
        got: u8,
    },
    /// The block check character does not match.
    #[error("BCC error: computed {expected:#04x}, received {got:#04x}")]
    BadBcc {
        /// The XOR computed over the received bytes.
        expected: u8,
        /// The BCC received.
        got: u8,
    },
    /// Fewer bytes than LGE announces.
    #[error("telegram of {got} bytes, {needed} expected")]
    Truncated {
        /// Bytes the telegram needs.
        needed: u8,
        /// Bytes present.
        got: u8,
    },
    /// More bytes than LGE announces.
    #[error("{extra} bytes after the telegram's BCC")]
    TrailingBytes {
        /// Bytes after the BCC.
        extra: u8,
    },
    /// A telegram addressed to another slave (a slave's receiver drops it at its ADR byte).
    #[error("telegram for another slave ({0:?})")]
    NotAddressed(Adr),
    /// The telegram took longer on the line than the USS residual run time allows (the
    /// characters trickled in with gaps).
    #[error("telegram took {took_us} µs after STX, at most {limit_us} µs allowed")]
    RuntimeExceeded {
        /// From the end of STX to the end of BCC, µs.
        took_us: u32,
        /// The limit, µs.
        limit_us: u32,
    },
    /// The output buffer is too small.
    #[error("output buffer too small: {needed} bytes needed")]
    BufferTooSmall {
        /// Bytes needed.
        needed: u8,
    },
}

/// One telegram: ADR, the PKW part (if the layout has one) and the PZD words. `Copy`, stored
/// inline, no allocation.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Telegram {
    adr: Adr,
    layout: Layout,
    pkw: Pkw,
    pzd: [u16; MAX_PZD],
}

/// PWE1 of the 3-word PKW on reception: the sign of the one value word.
const fn sign_of(pwe2: u16) -> u16 {
    if pwe2 & 0x8000 != 0 { 0xFFFF } else { 0 }
}

impl Telegram {
    /// A telegram with `adr` and `layout` carrying `pkw` (ignored when the layout has no PKW
    /// part) and `pzd` (exactly the layout's number of words).
    pub fn new(adr: Adr, layout: Layout, pkw: Pkw, pzd: &[u16]) -> Result<Telegram, TelegramError> {
        if pzd.len() != usize::from(layout.pzd_words) {
            return Err(TelegramError::PzdWords {
                expected: layout.pzd_words,
                got: pzd.len(),
            });
        }
        let pkw = match layout.pkw_words {
            0 => Pkw::default(),
            3 if pkw.pwe1 != 0 && pkw.pwe1 != sign_of(pkw.pwe2) => {
                return Err(TelegramError::PkwValueTooWide {
                    pwe1: pkw.pwe1,
                    pwe2: pkw.pwe2,
                });
            }
            // The 3-word form is received with PWE1 as the sign of PWE2: store it that way,
            // so that a telegram equals its own decoding.
            3 => Pkw {
                pwe1: sign_of(pkw.pwe2),
                ..pkw
            },
            _ => pkw,
        };
        let mut words = [0u16; MAX_PZD];
        for (d, s) in words.iter_mut().zip(pzd) {
            *d = *s;
        }
        Ok(Telegram {
            adr,
            layout,
            pkw,
            pzd: words,
        })
    }

    /// The ADR byte.
    pub const fn adr(&self) -> Adr {
        self.adr
    }

    /// The same telegram with another ADR byte.
    #[must_use]
    pub const fn with_adr(self, adr: Adr) -> Telegram {
        Telegram { adr, ..self }
    }

    /// The layout.
    pub const fn layout(&self) -> Layout {
        self.layout
    }

    /// The PKW part, if the layout has one (the 3-word form with PWE1 = the sign of PWE2).
    pub const fn pkw(&self) -> Option<Pkw> {
        if self.layout.pkw_words == 0 {
            None
        } else {
            Some(self.pkw)
        }
    }

    /// The PZD words.
    pub fn pzd(&self) -> &[u16] {
        self.pzd
            .get(..usize::from(self.layout.pzd_words))
            .unwrap_or(&self.pzd)
    }

    /// Bytes on the wire.
    pub const fn len(&self) -> usize {
        self.layout.telegram_len()
    }

    /// Never empty (STX, LGE, ADR and BCC are always there).
    pub const fn is_empty(&self) -> bool {
        false
    }

    /// Write the telegram to the front of `out`; returns its length.
    #[inline]
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, FrameError> {
        let len = self.len();
        let Some(dst) = out.get_mut(..len) else {
            return Err(FrameError::BufferTooSmall { needed: len as u8 });
        };
        let pkw = match self.layout.pkw_words {
            4 => [self.pkw.pke.0, self.pkw.ind.0, self.pkw.pwe1, self.pkw.pwe2],
            3 => [self.pkw.pke.0, self.pkw.ind.0, self.pkw.pwe2, 0],
            _ => [0; 4],
        };
        let pkw = pkw.get(..usize::from(self.layout.pkw_words)).unwrap_or(&[]);
        let words = pkw.iter().chain(self.pzd());
        let (head, rest) = dst.split_at_mut(3);
        head.copy_from_slice(&[STX, self.layout.lge(), self.adr.0]);
        let mut bcc = STX ^ self.layout.lge() ^ self.adr.0;
        let (net, last) = rest.split_at_mut(rest.len().saturating_sub(1));
        for (pair, w) in net.chunks_exact_mut(2).zip(words) {
            let [h, l] = w.to_be_bytes();
            pair.copy_from_slice(&[h, l]);
            bcc ^= h ^ l;
        }
        if let Some(b) = last.first_mut() {
            *b = bcc;
        }
        Ok(len)
    }

    /// The length a telegram starting at `bytes` announces (LGE + 2), once STX and LGE are
    /// there: for cutting a capture into telegrams.
    pub fn announced_len(bytes: &[u8]) -> Option<usize> {
        match *bytes {
            [STX, lge, ..] => Some(usize::from(lge) + 2),
            _ => None,
        }
    }

    /// Check and decode exactly one telegram of `layout`: STX, LGE against the layout, the
    /// length, the BCC.
    #[inline]
    pub fn decode(bytes: &[u8], layout: Layout) -> Result<Telegram, FrameError> {
        let got = bytes.len().min(255) as u8;
        let len = layout.telegram_len();
        // Slice patterns and `get`, not `split_first`/`split_last` chains: they keep the slice in
        // registers (the chains made the compiler spill and reload it in pieces, which cost more
        // than the decode itself).
        let lge = match *bytes {
            [STX, lge, ..] => lge,
            [stx, ..] if stx != STX => return Err(FrameError::BadStx(stx)),
            _ => {
                return Err(FrameError::Truncated {
                    needed: MIN_TELEGRAM as u8,
                    got,
                });
            }
        };
        if lge != layout.lge() {
            return Err(FrameError::BadLength {
                expected: layout.lge(),
                got: lge,
            });
        }
        if bytes.len() > len {
            return Err(FrameError::TrailingBytes {
                extra: (bytes.len() - len).min(255) as u8,
            });
        }
        let (Some(body), Some(&got_bcc)) = (bytes.get(..len.saturating_sub(1)), bytes.get(len - 1))
        else {
            return Err(FrameError::Truncated {
                needed: len as u8,
                got,
            });
        };
        let expected = bcc(body);
        if expected != got_bcc {
            return Err(FrameError::BadBcc {
                expected,
                got: got_bcc,
            });
        }
        let (adr, net) = match body {
            [_, _, adr, net @ ..] => (Adr(*adr), net),
            _ => (Adr(0), &[][..]),
        };
        let be = |b: &[u8], i: usize| match b.get(i..i + 2) {
            Some(&[h, l]) => u16::from_be_bytes([h, l]),
            _ => 0,
        };
        let k = 2 * usize::from(layout.pkw_words);
        let (pkw_bytes, pzd_bytes) = net.split_at(k.min(net.len()));
        let pkw = match layout.pkw_words {
            4 => match pkw_bytes.first_chunk::<8>() {
                Some(b) => Pkw::from_array(b),
                None => Pkw::default(),
            },
            3 => {
                let pwe2 = be(pkw_bytes, 4);
                Pkw::from_words([be(pkw_bytes, 0), be(pkw_bytes, 2), sign_of(pwe2), pwe2])
            }
            _ => Pkw::default(),
        };
        let mut pzd = [0u16; MAX_PZD];
        for (w, pair) in pzd.iter_mut().zip(pzd_bytes.chunks_exact(2)) {
            if let [h, l] = *pair {
                *w = u16::from_be_bytes([h, l]);
            }
        }
        Ok(Telegram {
            adr,
            layout,
            pkw,
            pzd,
        })
    }
}

impl fmt::Debug for Telegram {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut d = f.debug_struct("Telegram");
        d.field("adr", &self.adr);
        if let Some(pkw) = self.pkw() {
            d.field("pkw", &pkw);
        }
        d.field("pzd", &self.pzd()).finish()
    }
}

/// The XOR of `bytes` (the BCC of a telegram is the XOR of every byte before it).
#[inline]
pub fn bcc(bytes: &[u8]) -> u8 {
    // Eight bytes at a time, then the rest.
    let chunks = bytes.chunks_exact(8);
    let rest = chunks.remainder();
    let wide = chunks.fold(0u64, |a, c| {
        a ^ c.first_chunk::<8>().map_or(0, |c| u64::from_ne_bytes(*c))
    });
    let wide = wide ^ (wide >> 32);
    let wide = wide ^ (wide >> 16);
    let folded = (wide ^ (wide >> 8)) as u8;
    rest.iter().fold(folded, |a, b| a ^ b)
}
