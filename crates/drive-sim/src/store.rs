//! The parameter store: RAM and EEPROM values, access checks, write counters.
//!
//! # Model
//!
//! * Every parameter is stored in **cells** keyed by `(bus_index, sub_index)`; a table row
//!   without a sub-index uses sub-index 0. Several rows with the same key (SEW P010…P013 all
//!   live at index 8310) share one cell; the first row in table order supplies the metadata, the
//!   first row that has a default / range supplies those.
//! * Rows flagged [`Access::DATA_SET`] (Bonfiglioli) get one cell per data set, sub-indices
//!   `1..=data_sets`. Sub-index 0 addresses all data sets: a write sets all of them, a read
//!   succeeds only while all hold the same value ([`SimError::DataSetsDiffer`] otherwise), as the
//!   Bonfiglioli manual describes.
//! * Each cell holds a RAM value (what reads return and what the drive uses) and an EEPROM
//!   value, both initialised from [`ParamMeta::default_raw`] (0 where the table has none).
//! * A cell **has EEPROM backing** when its row carries the `N` flag
//!   ([`Access::NON_VOLATILE`]), or, with [`StoreOptions::eeprom_for_unflagged`], when it is
//!   writable (for families whose drives store every parameter, such as NORD and Bonfiglioli).
//! * [`Persistence::Volatile`] writes change RAM only. [`Persistence::NonVolatile`] writes change
//!   RAM and, for cells with EEPROM backing, the EEPROM value too, incrementing that cell's
//!   non-volatile write counter and recording the time. A non-volatile write to a cell without
//!   EEPROM backing (SEW's command parameters such as P802 factory setting) changes RAM only and
//!   is not counted.
//! * [`ParamStore::restart`] (power cycle) copies EEPROM into RAM for every cell. For cells with
//!   EEPROM backing this restores the last non-volatile value and drops volatile writes; cells
//!   without backing never change their EEPROM value, so they return to their default — the
//!   manual's "N = at restart the value is copied from EEPROM into RAM", and values of other
//!   parameters are lost.
//!
//! # Write checks, in order
//!
//! unknown index / sub-index → read-only (`RO`, or no `RW`) → parameter lock (unless `S`) →
//! needs controller inhibit (`R`) → not in operation → range (`raw_range`) → value list (only
//! where the list is exhaustive, see [`StoreOptions::value_lists_exhaustive`]) → EEPROM
//! endurance. A refused write changes nothing.

use std::collections::BTreeMap;

use drive_profile::{Access, ParamMeta};

use crate::error::SimError;
use drive_core::Instant;

/// A parameter row as the store keeps it: any family's metadata, shareable across threads.
pub type Meta = &'static (dyn ParamMeta + Sync);

pub use drive_profile::Persistence;

/// Store-wide options; [`StoreOptions::default`] suits SEW MOVIDRIVE.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StoreOptions {
    /// Give every writable parameter EEPROM backing, not only those flagged `N`.
    pub eeprom_for_unflagged: bool,
    /// Treat every non-empty value list as exhaustive, so that values outside it are refused
    /// with [`SimError::ValueNotAllowed`]. Per-parameter overrides:
    /// [`ParamStore::set_value_list_exhaustive`].
    pub value_lists_exhaustive: bool,
    /// Bus index of the parameter-lock parameter (SEW P803, index 8595): while its value is
    /// non-zero, only `S`-flagged parameters can be written. See also
    /// [`ParamStore::set_param_lock`].
    pub lock_index: Option<u16>,
    /// Non-volatile writes a cell survives; further ones fail with [`SimError::EepromWornOut`].
    /// `None`: unlimited.
    pub eeprom_endurance: Option<u64>,
    /// Number of data sets for [`Access::DATA_SET`] parameters (Bonfiglioli: 4).
    pub data_sets: u16,
}

impl Default for StoreOptions {
    fn default() -> StoreOptions {
        StoreOptions {
            eeprom_for_unflagged: false,
            value_lists_exhaustive: false,
            lock_index: None,
            eeprom_endurance: None,
            data_sets: 4,
        }
    }
}

/// The drive's operating condition, which the `R` and not-in-operation checks consult.
///
/// [`crate::SimDrive`] keeps it up to date; a bare [`ParamStore`] starts inhibited and stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct OperatingCondition {
    /// Controller inhibit is active (writes of `R` parameters allowed).
    pub controller_inhibited: bool,
    /// The output stage is on or the motor still turns (writes of not-in-operation parameters
    /// refused).
    pub in_operation: bool,
}

impl Default for OperatingCondition {
    fn default() -> OperatingCondition {
        OperatingCondition {
            controller_inhibited: true,
            in_operation: false,
        }
    }
}

#[derive(Clone, Copy)]
struct Cell {
    sub: u16,
    /// `meta.access()`, kept at hand for the write paths (the row is `'static`, so it never
    /// changes).
    access: Access,
    meta: Meta,
    default: Option<i64>,
    range: Option<(i64, i64)>,
    ram: i64,
    eeprom: i64,
    nv_writes: u64,
    last_nv_write: Option<Instant>,
}

impl Cell {
    fn new(sub: u16, meta: Meta) -> Cell {
        Cell::with_default(sub, meta, meta.default_raw())
    }

    /// A cell of `meta` whose default (and initial value, 0 when `None`) is `default`.
    fn with_default(sub: u16, meta: Meta, default: Option<i64>) -> Cell {
        let initial = default.unwrap_or(0);
        Cell {
            sub,
            access: meta.access(),
            meta,
            default,
            range: meta.raw_range(),
            ram: initial,
            eeprom: initial,
            nv_writes: 0,
            last_nv_write: None,
        }
    }

    /// A later row with the same key fills in what the first row lacks.
    fn merge(&mut self, meta: Meta) {
        if self.default.is_none() {
            self.default = meta.default_raw();
            if let Some(d) = self.default {
                self.ram = d;
                self.eeprom = d;
            }
        }
        if self.range.is_none() {
            self.range = meta.raw_range();
        }
    }
}

/// One bus index: its cells are `cells[start..start + len]`, in ascending sub-index order.
#[derive(Clone, Copy)]
struct Entry {
    index: u16,
    data_set: bool,
    start: u32,
    len: u32,
}

impl Entry {
    fn range(&self) -> core::ops::Range<usize> {
        let start = self.start as usize;
        start..start + self.len as usize
    }
}

/// Index → position in [`ParamStore::entries`], one slot per index from `base` to the highest
/// index held ([`Lookup::NONE`] where there is no parameter): a parameter is found with one
/// subtraction and two loads, without a search. The slots span the table's indices only (SEW:
/// 8300–8891, 592 slots, 2.3 kB).
#[derive(Default)]
struct Lookup {
    base: u16,
    slots: Vec<u32>,
}

impl Lookup {
    const NONE: u32 = u32::MAX;

    /// The lookup of `entries` (ascending by index).
    fn of(entries: &[Entry]) -> Lookup {
        let (Some(first), Some(last)) = (entries.first(), entries.last()) else {
            return Lookup::default();
        };
        let base = first.index;
        let mut slots = vec![Lookup::NONE; usize::from(last.index - base) + 1];
        for (position, entry) in entries.iter().enumerate() {
            if let Some(slot) = slots.get_mut(usize::from(entry.index - base)) {
                // At most 65 536 entries (one per u16 index): the position fits.
                *slot = position as u32;
            }
        }
        Lookup { base, slots }
    }

    /// The position of `index` in the entries.
    #[inline]
    fn get(&self, index: u16) -> Option<usize> {
        // Below `base` the difference wraps to a huge value that no slot has.
        let slot = usize::from(index).wrapping_sub(usize::from(self.base));
        match self.slots.get(slot) {
            Some(&p) if p != Lookup::NONE => Some(p as usize),
            _ => None,
        }
    }
}

/// Simulated parameter memory of one drive.
///
/// The cells are one flat vector, grouped by bus index in ascending order and by sub-index
/// within an index; a table of slots from the lowest to the highest index finds an index's
/// group in constant time (the simulated drives read dozens of parameters on every telegram).
pub struct ParamStore {
    /// Ascending by index.
    entries: Vec<Entry>,
    cells: Vec<Cell>,
    lookup: Lookup,
    options: StoreOptions,
    exhaustive: BTreeMap<u16, bool>,
    manual_lock: bool,
    condition: OperatingCondition,
}

impl core::fmt::Debug for ParamStore {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("ParamStore")
            .field("indices", &self.entries.len())
            .field("cells", &self.len())
            .field("options", &self.options)
            .field("manual_lock", &self.manual_lock)
            .field("condition", &self.condition)
            .finish_non_exhaustive()
    }
}

impl ParamStore {
    /// A store holding every row of a family table, with default options.
    pub fn new<P: ParamMeta + Sync + 'static>(table: &'static [P]) -> ParamStore {
        ParamStore::with_options(table, StoreOptions::default())
    }

    /// A store holding every row of a family table.
    pub fn with_options<P: ParamMeta + Sync + 'static>(
        table: &'static [P],
        options: StoreOptions,
    ) -> ParamStore {
        ParamStore::from_rows(table.iter().map(|p| p as Meta), options)
    }

    /// A store from arbitrary rows (for example several tables chained).
    pub fn from_rows<I: IntoIterator<Item = Meta>>(rows: I, options: StoreOptions) -> ParamStore {
        // Collected in maps (index → data set flag and cells by sub-index), then laid out flat.
        let mut map: BTreeMap<u16, (bool, BTreeMap<u16, Cell>)> = BTreeMap::new();
        for meta in rows {
            let data_set = meta.access().contains(Access::DATA_SET);
            let (data_set, cells) = map
                .entry(meta.bus_index())
                .or_insert_with(|| (data_set, BTreeMap::new()));
            let subs: Vec<u16> = if *data_set {
                (1..=options.data_sets.max(1)).collect()
            } else {
                vec![meta.sub_index().unwrap_or(0)]
            };
            for sub in subs {
                cells
                    .entry(sub)
                    .and_modify(|c| c.merge(meta))
                    .or_insert_with(|| Cell::new(sub, meta));
            }
        }
        let mut entries = Vec::with_capacity(map.len());
        let mut all_cells = Vec::new();
        for (index, (data_set, cells)) in map {
            entries.push(Entry {
                index,
                data_set,
                start: u32::try_from(all_cells.len()).unwrap_or(u32::MAX),
                len: u32::try_from(cells.len()).unwrap_or(u32::MAX),
            });
            all_cells.extend(cells.into_values());
        }
        ParamStore {
            lookup: Lookup::of(&entries),
            entries,
            cells: all_cells,
            options,
            exhaustive: BTreeMap::new(),
            manual_lock: false,
            condition: OperatingCondition::default(),
        }
    }

    /// The options the store was built with.
    pub fn options(&self) -> &StoreOptions {
        &self.options
    }

    /// Number of cells (a data-set parameter counts once per data set).
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Whether the store holds no parameter.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Whether a parameter with this bus index exists.
    pub fn contains(&self, index: u16) -> bool {
        self.lookup.get(index).is_some()
    }

    /// Every `(bus_index, sub_index)` cell, in ascending order.
    pub fn keys(&self) -> impl Iterator<Item = (u16, u16)> + '_ {
        self.entries.iter().flat_map(|e| {
            self.cells
                .get(e.range())
                .unwrap_or_default()
                .iter()
                .map(move |c| (e.index, c.sub))
        })
    }

    /// The metadata of the cell (for a data-set parameter, sub-index 0 is accepted).
    pub fn meta(&self, index: u16, sub: u16) -> Result<Meta, SimError> {
        self.cell(index, sub).map(|c| c.meta)
    }

    /// The current (RAM) value.
    #[inline]
    pub fn read(&self, index: u16, sub: u16) -> Result<i64, SimError> {
        let (entry, cells) = self.entry(index)?;
        if entry.data_set && sub == 0 {
            let mut values = cells.iter().map(|c| c.ram);
            let first = values
                .next()
                .ok_or(SimError::UnknownSubIndex { index, sub })?;
            if values.all(|v| v == first) {
                Ok(first)
            } else {
                Err(SimError::DataSetsDiffer { index })
            }
        } else {
            self.cell(index, sub).map(|c| c.ram)
        }
    }

    /// The value held in EEPROM (what a restart restores).
    pub fn read_eeprom(&self, index: u16, sub: u16) -> Result<i64, SimError> {
        self.cell(index, sub).map(|c| c.eeprom)
    }

    /// Smallest raw value (`None` where the table gives no range).
    pub fn min_raw(&self, index: u16, sub: u16) -> Result<Option<i64>, SimError> {
        self.cell(index, sub).map(|c| c.range.map(|r| r.0))
    }

    /// Largest raw value (`None` where the table gives no range).
    pub fn max_raw(&self, index: u16, sub: u16) -> Result<Option<i64>, SimError> {
        self.cell(index, sub).map(|c| c.range.map(|r| r.1))
    }

    /// Default (factory setting) raw value; 0 where the table gives none.
    pub fn default_raw(&self, index: u16, sub: u16) -> Result<i64, SimError> {
        self.cell(index, sub).map(|c| c.default.unwrap_or(0))
    }

    /// Whether the cell has EEPROM backing (see the module docs).
    pub fn has_eeprom(&self, index: u16, sub: u16) -> Result<bool, SimError> {
        self.cell(index, sub).map(|c| self.backed(c))
    }

    /// Non-volatile writes the cell has received (EEPROM wear).
    pub fn nv_writes(&self, index: u16, sub: u16) -> Result<u64, SimError> {
        self.cell(index, sub).map(|c| c.nv_writes)
    }

    /// Time of the cell's last non-volatile write.
    pub fn last_nv_write(&self, index: u16, sub: u16) -> Result<Option<Instant>, SimError> {
        self.cell(index, sub).map(|c| c.last_nv_write)
    }

    /// Non-volatile writes across all cells.
    pub fn total_nv_writes(&self) -> u64 {
        self.cells.iter().map(|c| c.nv_writes).sum()
    }

    /// Switch the manual parameter lock on or off (in addition to
    /// [`StoreOptions::lock_index`]).
    pub fn set_param_lock(&mut self, on: bool) {
        self.manual_lock = on;
    }

    /// Whether the parameter lock is active (manual switch, or lock parameter non-zero).
    pub fn is_locked(&self) -> bool {
        self.manual_lock
            || self
                .options
                .lock_index
                .is_some_and(|i| self.read(i, 0).is_ok_and(|v| v != 0))
    }

    /// Override [`StoreOptions::value_lists_exhaustive`] for one parameter.
    pub fn set_value_list_exhaustive(&mut self, index: u16, exhaustive: bool) {
        self.exhaustive.insert(index, exhaustive);
    }

    /// The operating condition the access checks use.
    pub fn condition(&self) -> OperatingCondition {
        self.condition
    }

    /// Set the operating condition (done by [`crate::SimDrive`] on every state change).
    pub fn set_condition(&mut self, condition: OperatingCondition) {
        self.condition = condition;
    }

    /// Write a value as a bus master would, with every access check (see the module docs).
    pub fn write(
        &mut self,
        index: u16,
        sub: u16,
        raw: i64,
        persistence: Persistence,
        now: Instant,
    ) -> Result<(), SimError> {
        let locked = self.is_locked();
        let exhaustive = self
            .exhaustive
            .get(&index)
            .copied()
            .unwrap_or(self.options.value_lists_exhaustive);
        let condition = self.condition;
        let first = *self.cell(index, sub)?;
        let access = first.access;

        if !access.is_writable() {
            return Err(SimError::ReadOnly { index });
        }
        if locked && !access.contains(Access::STORE_LOCKED) {
            return Err(SimError::Locked { index });
        }
        if access.contains(Access::NEEDS_INHIBIT) && !condition.controller_inhibited {
            return Err(SimError::NeedsInhibit { index });
        }
        if access.contains(Access::NOT_IN_OPERATION) && condition.in_operation {
            return Err(SimError::NotInOperation { index });
        }
        if let Some((min, max)) = first.range {
            if raw > max {
                return Err(SimError::TooLarge { index, max });
            }
            if raw < min {
                return Err(SimError::TooSmall { index, min });
            }
        }
        let values = first.meta.values();
        if exhaustive && !values.is_empty() && !values.iter().any(|v| v.value == raw) {
            return Err(SimError::ValueNotAllowed { index, value: raw });
        }

        let to_eeprom = persistence == Persistence::NonVolatile;
        let endurance = self.options.eeprom_endurance;
        let eeprom_for_unflagged = self.options.eeprom_for_unflagged;
        let backed = |c: &Cell| backed(eeprom_for_unflagged, c);
        let (all, cells) = self.entry_mut(index, sub)?;
        let is_target = |c: &Cell| all || c.sub == sub;
        if to_eeprom
            && let Some(limit) = endurance
            && let Some(worn) = cells
                .iter()
                .find(|c| is_target(c) && backed(c) && c.nv_writes >= limit)
        {
            return Err(SimError::EepromWornOut {
                index,
                writes: worn.nv_writes,
            });
        }
        for cell in cells.iter_mut().filter(|c| is_target(c)) {
            cell.ram = raw;
            if to_eeprom && backed(cell) {
                cell.eeprom = raw;
                cell.nv_writes = cell.nv_writes.saturating_add(1);
                cell.last_nv_write = Some(now);
            }
        }
        Ok(())
    }

    /// Add a cell at `(index, 0)` that shares `meta`'s access flags, range and value list but has
    /// its own value, initialised to `default` (0 when `None`): the second index of a two-word
    /// parameter such as SEW P852 "user unit" (indices 8772 and 8773).
    ///
    /// Fails with [`SimError::ValueNotAllowed`] (value `index`) if `index` is already in use;
    /// the store is then unchanged.
    pub fn add_second_index(
        &mut self,
        index: u16,
        meta: Meta,
        default: Option<i64>,
    ) -> Result<(), SimError> {
        let position = match self.entries.binary_search_by_key(&index, |e| e.index) {
            Ok(_) => {
                return Err(SimError::ValueNotAllowed {
                    index,
                    value: i64::from(index),
                });
            }
            Err(position) => position,
        };
        let start = self
            .entries
            .get(position)
            .map_or(self.cells.len(), |e| e.start as usize);
        self.cells
            .insert(start, Cell::with_default(0, meta, default));
        for later in self.entries.get_mut(position..).unwrap_or_default() {
            later.start += 1;
        }
        self.entries.insert(
            position,
            Entry {
                index,
                data_set: false,
                start: u32::try_from(start).unwrap_or(u32::MAX),
                len: 1,
            },
        );
        self.lookup = Lookup::of(&self.entries);
        Ok(())
    }

    /// Set a value the drive itself produces (actual speed, status, fault memory), bypassing
    /// every access check. Writes sub-index 0 (all data sets for a data-set parameter).
    ///
    /// The EEPROM value follows only for `N`-flagged parameters (the drive keeps those across a
    /// restart, e.g. its fault memory); no write is counted.
    pub fn set_internal(&mut self, index: u16, raw: i64) -> Result<(), SimError> {
        self.set_internal_sub(index, 0, raw)
    }

    /// [`ParamStore::set_internal`] for one sub-index.
    pub fn set_internal_sub(&mut self, index: u16, sub: u16, raw: i64) -> Result<(), SimError> {
        let (all, cells) = self.entry_mut(index, sub)?;
        let mut found = false;
        for cell in cells.iter_mut().filter(|c| all || c.sub == sub) {
            found = true;
            cell.ram = raw;
            if cell.access.contains(Access::NON_VOLATILE) {
                cell.eeprom = raw;
            }
        }
        if found {
            Ok(())
        } else {
            Err(SimError::UnknownSubIndex { index, sub })
        }
    }

    /// Factory setting: every writable cell's RAM value returns to its default; with
    /// [`Persistence::NonVolatile`] the EEPROM value of cells with EEPROM backing too (counted
    /// as one non-volatile write per cell whose EEPROM value changes). Read-only values (produced
    /// by the drive) are left alone; no access check applies.
    pub fn reset_to_defaults(&mut self, persistence: Persistence, now: Instant) {
        let eeprom_for_unflagged = self.options.eeprom_for_unflagged;
        for cell in &mut self.cells {
            if !cell.access.is_writable() {
                continue;
            }
            let default = cell.default.unwrap_or(0);
            cell.ram = default;
            if persistence == Persistence::NonVolatile
                && backed(eeprom_for_unflagged, cell)
                && cell.eeprom != default
            {
                cell.eeprom = default;
                cell.nv_writes = cell.nv_writes.saturating_add(1);
                cell.last_nv_write = Some(now);
            }
        }
    }

    /// Restart (power cycle): RAM ← EEPROM for every cell. Write counters are kept.
    pub fn restart(&mut self) {
        for cell in &mut self.cells {
            cell.ram = cell.eeprom;
        }
    }

    /// The entry of `index` and its cells.
    #[inline]
    fn entry(&self, index: u16) -> Result<(&Entry, &[Cell]), SimError> {
        self.lookup
            .get(index)
            .and_then(|p| self.entries.get(p))
            .and_then(|e| Some((e, self.cells.get(e.range())?)))
            .ok_or(SimError::UnknownIndex { index })
    }

    /// The cells of `index`, mutably, and whether `sub` addresses all of them (sub-index 0 of
    /// a data-set parameter).
    fn entry_mut(&mut self, index: u16, sub: u16) -> Result<(bool, &mut [Cell]), SimError> {
        let entry = self
            .lookup
            .get(index)
            .and_then(|p| self.entries.get(p))
            .ok_or(SimError::UnknownIndex { index })?;
        let all = entry.data_set && sub == 0;
        let cells = self
            .cells
            .get_mut(entry.range())
            .ok_or(SimError::UnknownIndex { index })?;
        Ok((all, cells))
    }

    /// The addressed cell; data set 0 resolves to the first data set.
    #[inline]
    fn cell(&self, index: u16, sub: u16) -> Result<&Cell, SimError> {
        let (entry, cells) = self.entry(index)?;
        let found = if entry.data_set && sub == 0 {
            cells.first()
        } else {
            cells.iter().find(|c| c.sub == sub)
        };
        found.ok_or(SimError::UnknownSubIndex { index, sub })
    }

    fn backed(&self, cell: &Cell) -> bool {
        backed(self.options.eeprom_for_unflagged, cell)
    }
}

fn backed(eeprom_for_unflagged: bool, cell: &Cell) -> bool {
    let access = cell.access;
    access.contains(Access::NON_VOLATILE) || (eeprom_for_unflagged && access.is_writable())
}
