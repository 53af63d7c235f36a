//! The trend's memory: the last [`WINDOW`] of every polled point's values, kept in the hub so
//! that a page which adds a point to its trend sees at once what was read before it opened
//! (`GET /api/history/{bus}/{drive}/{point}`, `docs/ui.md`).
//!
//! # Memory
//!
//! A sample is the raw value and the bus read's time in [`SAMPLE_BYTES`] (12) bytes: the raw
//! value whole (two 32-bit halves, nothing cut) and the low 32 bits of its time in
//! milliseconds. The full time is rebuilt from the point's newest sample: every kept sample is
//! at most [`WINDOW`] older than it, far less than the 49 days the low bits cover.
//!
//! Each point has a ring sized from its poll period: [`WINDOW`] / period samples and a sixteenth
//! more for reads that come early (a read-back after a write, a poll caught up after a late
//! one). A period stretched because the bus's demand exceeds 1 brings fewer samples in 10
//! minutes, so the ring still covers the window. A point read only after writes keeps
//! [`UNPOLLED`] samples. A ring grows as samples arrive (doubling, never past its size), so a
//! plant that has run for a minute holds a minute of samples.
//!
//! All rings together hold at most [`MAX_SAMPLES`] samples (48 MiB of samples, [`bound`]).
//! When the periods of a large plant ask for more, every ring is shrunk by the same factor:
//! the fastest points then keep less than 10 minutes, and the answer says how much
//! (`capacity`, with `period_ms`).

use std::collections::VecDeque;
use std::time::Duration;

use serde_json::{Value, json};

use crate::config::Plant;
use crate::mqtt::payload;

/// How long a point's values are kept.
pub const WINDOW: Duration = Duration::from_secs(600);

/// [`WINDOW`] in milliseconds.
const WINDOW_MS: u64 = 600_000;

/// The most samples every ring together holds.
pub const MAX_SAMPLES: usize = 4 * 1024 * 1024;

/// The samples a point without a poll period keeps (it is read after writes only).
pub const UNPOLLED: usize = 64;

/// Bytes one sample takes in a ring.
pub const SAMPLE_BYTES: usize = std::mem::size_of::<Sample>();

/// The most bytes the samples of every ring together take ([`MAX_SAMPLES`] ×
/// [`SAMPLE_BYTES`]); the rings' own bookkeeping adds 40 bytes per point.
pub const fn bound() -> usize {
    MAX_SAMPLES * SAMPLE_BYTES
}

/// One kept value: 12 bytes, 4-aligned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Sample {
    /// Low 32 bits of the read's time in ms since the Unix epoch.
    ts: u32,
    /// The raw value's low and high 32 bits.
    raw: [u32; 2],
}

impl Sample {
    fn new(ts: u64, raw: i64) -> Sample {
        let bits = raw as u64;
        Sample {
            ts: ts as u32,
            raw: [bits as u32, (bits >> 32) as u32],
        }
    }

    fn raw(self) -> i64 {
        let [lo, hi] = self.raw;
        ((u64::from(hi) << 32) | u64::from(lo)) as i64
    }
}

/// One point's ring.
#[derive(Debug)]
struct Ring {
    samples: VecDeque<Sample>,
    /// The most samples it holds.
    size: usize,
    /// The newest sample's full time (ms since the epoch).
    newest: u64,
}

impl Ring {
    fn new(size: usize) -> Ring {
        Ring {
            samples: VecDeque::new(),
            size: size.max(1),
            newest: 0,
        }
    }

    /// The full time of `s`, rebuilt from the newest sample's.
    fn time(&self, s: Sample) -> u64 {
        let back = (self.newest as u32).wrapping_sub(s.ts);
        self.newest.saturating_sub(u64::from(back))
    }

    fn push(&mut self, ts: u64, raw: i64) {
        if ts < self.newest {
            // The clock was set back: the samples kept are not older than this one any more.
            self.samples.clear();
        }
        self.newest = ts;
        let oldest = ts.saturating_sub(WINDOW_MS);
        while let Some(&s) = self.samples.front() {
            if self.time(s) >= oldest {
                break;
            }
            self.samples.pop_front();
        }
        if self.samples.len() >= self.size {
            self.samples.pop_front();
        } else if self.samples.len() == self.samples.capacity() {
            // Grow by doubling, never past the ring's size.
            let want = (self.samples.len() * 2).max(16).min(self.size);
            self.samples
                .reserve_exact(want.saturating_sub(self.samples.len()));
        }
        self.samples.push_back(Sample::new(ts, raw));
    }

    /// (time in ms, raw value) of the samples read at `from` or later, oldest first.
    fn since(&self, from: u64) -> Vec<(u64, i64)> {
        self.samples
            .iter()
            .map(|&s| (self.time(s), s.raw()))
            .filter(|&(t, _)| t >= from)
            .collect()
    }
}

/// The samples a point's poll period asks for in [`WINDOW`].
fn wanted(period: Option<Duration>) -> usize {
    match period {
        None => UNPOLLED,
        Some(p) => {
            let n = WINDOW.as_millis() / p.as_millis().max(1) + 1;
            let n = usize::try_from(n).unwrap_or(MAX_SAMPLES);
            n.saturating_add(n / 16).min(MAX_SAMPLES)
        }
    }
}

/// The last [`WINDOW`] of every point of a plant.
#[derive(Debug)]
pub struct History {
    /// `[bus][drive][point]`.
    rings: Vec<Vec<Vec<Ring>>>,
}

impl History {
    /// A reloaded config: rings for the new plant's points, those of the buses that keep
    /// running (`kept[old bus]` is its index in `plant`) with what they hold.
    pub fn reconfigure(&mut self, plant: &Plant, kept: &[Option<usize>]) {
        let mut new = History::new(plant);
        for (old, to) in kept.iter().enumerate() {
            if let (Some(to), Some(rings)) = (to, self.rings.get_mut(old))
                && let Some(slot) = new.rings.get_mut(*to)
            {
                *slot = std::mem::take(rings);
            }
        }
        *self = new;
    }

    /// Rings for every point of `plant`, sized from their periods and shrunk together to
    /// [`MAX_SAMPLES`] where they would ask for more.
    pub fn new(plant: &Plant) -> History {
        Self::with_cap(plant, MAX_SAMPLES)
    }

    /// [`History::new`] with another total cap.
    pub fn with_cap(plant: &Plant, cap: usize) -> History {
        let total: usize = plant
            .buses
            .iter()
            .flat_map(|b| &b.drives)
            .flat_map(|d| &d.points)
            .map(|p| wanted(p.period))
            .fold(0, usize::saturating_add);
        let size = |p: Option<Duration>| {
            let w = wanted(p);
            if total <= cap {
                w
            } else {
                // The same share for every ring; u128 so that the product cannot overflow.
                let s = (w as u128 * cap as u128) / (total as u128).max(1);
                usize::try_from(s).unwrap_or(w).max(1)
            }
        };
        History {
            rings: plant
                .buses
                .iter()
                .map(|b| {
                    b.drives
                        .iter()
                        .map(|d| d.points.iter().map(|p| Ring::new(size(p.period))).collect())
                        .collect()
                })
                .collect(),
        }
    }

    fn ring(&self, bus: usize, drive: usize, point: usize) -> Option<&Ring> {
        self.rings.get(bus)?.get(drive)?.get(point)
    }

    /// Keep a value read at `ts` (ms since the epoch). A point the plant does not have is
    /// ignored.
    pub fn push(&mut self, bus: usize, drive: usize, point: usize, ts: u64, raw: i64) {
        if let Some(r) = self
            .rings
            .get_mut(bus)
            .and_then(|d| d.get_mut(drive))
            .and_then(|p| p.get_mut(point))
        {
            r.push(ts, raw);
        }
    }

    /// The samples of a point read within [`WINDOW`] before `now` (ms since the epoch), oldest
    /// first: (time in ms, raw value). `None` for a point the plant does not have.
    pub fn samples(
        &self,
        bus: usize,
        drive: usize,
        point: usize,
        now: u64,
    ) -> Option<Vec<(u64, i64)>> {
        Some(
            self.ring(bus, drive, point)?
                .since(now.saturating_sub(WINDOW_MS)),
        )
    }

    /// The most samples a point's ring holds.
    pub fn size(&self, bus: usize, drive: usize, point: usize) -> Option<usize> {
        self.ring(bus, drive, point).map(|r| r.size)
    }

    /// The most samples every ring together holds.
    pub fn total_size(&self) -> usize {
        self.rings
            .iter()
            .flatten()
            .flatten()
            .map(|r| r.size)
            .fold(0, usize::saturating_add)
    }

    /// Samples kept now, in every ring.
    pub fn len(&self) -> usize {
        self.rings
            .iter()
            .flatten()
            .flatten()
            .map(|r| r.samples.len())
            .sum()
    }

    /// Whether no sample is kept.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Bytes the rings' sample buffers take now (their allocated capacity).
    pub fn bytes(&self) -> usize {
        self.rings
            .iter()
            .flatten()
            .flatten()
            .map(|r| r.samples.capacity() * SAMPLE_BYTES)
            .sum()
    }
}

/// What `GET /api/history/{bus}/{drive}/{point}` answers for `samples` taken out of the
/// history (the hub copies them under its lock and writes the JSON outside it): the point, its
/// ring's size and each sample as the object a live `value` event carries (`value` in the
/// point's unit, `unit`, `text` where there is one, `raw`, `ts` in ms). `None` for a point the
/// plant does not have.
pub fn history_value(
    plant: &Plant,
    (bus, drive, point): (usize, usize, usize),
    samples: &[(u64, i64)],
    size: usize,
    now: u64,
) -> Option<Value> {
    let b = plant.buses.get(bus)?;
    let d = b.drives.get(drive)?;
    let p = d.points.get(point)?;
    let values: Vec<Value> = samples
        .iter()
        .map(|&(ts, raw)| payload::value_json(&p.target, raw, ts, &d.device))
        .collect();
    Some(json!({
        "bus": bus, "drive": drive, "point": point,
        "name": p.name, "label": p.target.label(),
        "period_ms": p.period.map(|d| u64::try_from(d.as_millis()).unwrap_or(u64::MAX)),
        "window_ms": WINDOW_MS,
        "capacity": size,
        "now": now,
        "samples": values,
    }))
}

#[cfg(test)]
mod tests;
