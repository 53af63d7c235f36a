//! Copies of the settings the process-data path reads on every telegram (P480/P481 functions,
//! P543/P546, P509, P560, P607/P608 and the parameter-set values of P102, P105 and P112),
//! refreshed whenever the store changes. Each read from the store is two map lookups; a
//! telegram's process data read some thirty settings, which cost more than the rest of the
//! telegram together (the simulated drive answered fewer than a million PKW reads per second
//! through the USS state machines because of them).

use crate::store::ParamStore;

use super::params::sub;

/// Parameters without sets and how many elements of each are kept.
const ELEMENTS: [(u16, usize); 8] = [
    (480, 12),
    (481, 10),
    (543, 3),
    (546, 3),
    (509, 1),
    (560, 1),
    (607, 1),
    (608, 1),
];

/// Parameters with parameter sets (element 0 of each of the four sets).
const SETS: [u16; 3] = [102, 105, 112];

/// The cached values (0 where the store has none, as a read from the store would give).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Settings {
    elements: [[i64; 12]; ELEMENTS.len()],
    sets: [[i64; 4]; SETS.len()],
}

impl Settings {
    /// The values `store` holds now.
    pub(super) fn load(store: &ParamStore) -> Settings {
        let mut s = Settings::default();
        for ((number, len), slots) in ELEMENTS.iter().zip(s.elements.iter_mut()) {
            for (element, slot) in slots.iter_mut().take(*len).enumerate() {
                *slot = store.read(*number, sub(element as u8, 0)).unwrap_or(0);
            }
        }
        for (number, slots) in SETS.iter().zip(s.sets.iter_mut()) {
            for (set, slot) in slots.iter_mut().enumerate() {
                *slot = store.read(*number, sub(0, set as u8)).unwrap_or(0);
            }
        }
        s
    }

    /// Element `element` of `number`, if it is kept.
    pub(super) fn element(&self, number: u16, element: u8) -> Option<i64> {
        let k = ELEMENTS.iter().position(|(n, _)| *n == number)?;
        let len = ELEMENTS.get(k)?.1;
        let element = usize::from(element);
        if element >= len {
            return None;
        }
        self.elements.get(k)?.get(element).copied()
    }

    /// Parameter set `set` (0…3) of `number`, if it is kept.
    pub(super) fn in_set(&self, number: u16, set: u8) -> Option<i64> {
        let k = SETS.iter().position(|n| *n == number)?;
        self.sets.get(k)?.get(usize::from(set)).copied()
    }
}
