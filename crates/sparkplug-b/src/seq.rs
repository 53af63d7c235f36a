//! Sequence numbers: the `seq` of every message an edge node publishes (NBIRTH at 0, one more
//! per message, 0 after 255) and the `bdSeq` of its births and deaths (one more per MQTT
//! connection, 0 after 255).

use core::fmt;

/// A sequence number, 0 to 255; [`next`](Seq::next) after 255 is 0.
///
/// One type for both counters: the message `seq` (payload field `seq`) and the birth/death
/// `bdSeq` (the [`BD_SEQ`](crate::node::BD_SEQ) metric). The payload carries either as a
/// `u64`: [`take`](Seq::take) gives it in that form.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Hash, PartialOrd, Ord)]
pub struct Seq(u8);

impl Seq {
    /// The sequence number `v`.
    pub const fn new(v: u8) -> Seq {
        Seq(v)
    }

    /// Its value.
    pub const fn get(self) -> u8 {
        self.0
    }

    /// The number after this one: one more, 0 after 255.
    #[must_use]
    pub const fn next(self) -> Seq {
        Seq(self.0.wrapping_add(1))
    }

    /// Take the current value, as the payload carries it, and advance to the next: what each
    /// published message does with the message `seq` (and each new connection with `bdSeq`).
    pub fn take(&mut self) -> u64 {
        let current = self.0;
        *self = self.next();
        u64::from(current)
    }
}

impl From<u8> for Seq {
    fn from(v: u8) -> Seq {
        Seq(v)
    }
}

impl TryFrom<u64> for Seq {
    type Error = SeqOutOfRange;

    /// A sequence number from a payload's `u64`; above 255 is no Sparkplug sequence number.
    fn try_from(v: u64) -> Result<Seq, SeqOutOfRange> {
        u8::try_from(v).map(Seq).map_err(|_| SeqOutOfRange(v))
    }
}

impl fmt::Display for Seq {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

/// A `seq` or `bdSeq` value above 255.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("sequence number {0} is out of range 0..=255")]
pub struct SeqOutOfRange(pub u64);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_wraps_after_255() {
        assert_eq!(Seq::new(0).next(), Seq::new(1));
        assert_eq!(Seq::new(254).next(), Seq::new(255));
        assert_eq!(Seq::new(255).next(), Seq::new(0));
    }

    #[test]
    fn take_returns_the_current_value_and_advances() {
        let mut seq = Seq::new(255);
        assert_eq!(seq.take(), 255);
        assert_eq!(seq, Seq::new(0));
        assert_eq!(seq.take(), 0);
        assert_eq!(seq.get(), 1);
        assert_eq!(Seq::default().get(), 0);
    }

    #[test]
    fn a_payload_value_above_255_is_refused() {
        assert_eq!(Seq::try_from(255u64), Ok(Seq::new(255)));
        assert_eq!(Seq::try_from(256u64), Err(SeqOutOfRange(256)));
        assert_eq!(
            SeqOutOfRange(256).to_string(),
            "sequence number 256 is out of range 0..=255"
        );
    }
}
