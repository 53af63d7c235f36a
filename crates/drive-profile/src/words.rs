//! Control and status words as typed bit sets: one mechanism for the families whose words are
//! plain named bits (SEW control/status word 1, Bonfiglioli 410/411).
//!
//! [`bit_word!`] defines a `u16` newtype with a constant per named bit, `NAMED` (each bit with
//! its English name), `bits`/`from_bits`, `contains`, `union`, `difference`, `names`,
//! `unnamed_bits`, `|`, conversions from and to `u16`, and a `Debug` that lists the set bits by
//! name and the rest as hex.

/// Define a control or status word; see the [module docs](self).
macro_rules! bit_word {
    (
        $(#[$meta:meta])*
        $name:ident {
            $( $(#[$fmeta:meta])* $flag:ident = $bit:literal, $en:literal; )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
        pub struct $name(u16);

        impl $name {
            $( $(#[$fmeta])* pub const $flag: $name = $name(1 << $bit); )*

            /// Every named bit with its English name, lowest bit first.
            pub const NAMED: &'static [($name, &'static str)] = &[ $( ($name::$flag, $en), )* ];

            /// No bit set.
            pub const fn empty() -> Self {
                Self(0)
            }

            /// From the raw 16-bit word (every bit is kept).
            pub const fn from_bits(bits: u16) -> Self {
                Self(bits)
            }

            /// The raw 16-bit word.
            pub const fn bits(self) -> u16 {
                self.0
            }

            /// Whether every bit of `other` is set.
            pub const fn contains(self, other: Self) -> bool {
                self.0 & other.0 == other.0
            }

            /// Both bit sets combined.
            #[must_use]
            pub const fn union(self, other: Self) -> Self {
                Self(self.0 | other.0)
            }

            /// The bits of `self` without those of `other`.
            #[must_use]
            pub const fn difference(self, other: Self) -> Self {
                Self(self.0 & !other.0)
            }

            /// The English names of the set named bits.
            pub fn names(self) -> impl Iterator<Item = &'static str> {
                Self::NAMED.iter().filter(move |(f, _)| self.contains(*f)).map(|(_, n)| *n)
            }

            /// The set bits that have no name in the manual.
            pub fn unnamed_bits(self) -> u16 {
                let named = Self::NAMED.iter().fold(0u16, |a, (f, _)| a | f.0);
                self.0 & !named
            }
        }

        impl core::ops::BitOr for $name {
            type Output = Self;
            fn bitor(self, rhs: Self) -> Self {
                self.union(rhs)
            }
        }

        impl From<u16> for $name {
            fn from(bits: u16) -> Self {
                Self(bits)
            }
        }

        impl From<$name> for u16 {
            fn from(w: $name) -> u16 {
                w.0
            }
        }

        impl core::fmt::Debug for $name {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                f.write_str(concat!(stringify!($name), "("))?;
                let mut first = true;
                for n in self.names() {
                    if !first {
                        f.write_str(" | ")?;
                    }
                    f.write_str(n)?;
                    first = false;
                }
                let rest = self.unnamed_bits();
                if rest != 0 {
                    if !first {
                        f.write_str(" | ")?;
                    }
                    write!(f, "{rest:#06x}")?;
                }
                f.write_str(")")
            }
        }
    };
}

pub(crate) use bit_word;
