//! Several parameters sampled at a steady rhythm, for every family (it needs only a
//! [`ParamClient`]): a [`Sampler`] a front end drives ([`Sampler::next`]) and reads typed
//! [`Sample`]s from, each with its wall-clock and monotonic time and per parameter its raw value
//! or the drive's refusal.
//!
//! The rhythm is an interval with [`MissedTickBehavior::Skip`]: polls start on a fixed grid
//! (0, T, 2T, …); a poll that overruns its slot (a slow line, many parameters) lets the slots
//! it overran pass instead of firing them back to back, so polls never bunch up and the
//! timestamps stay evenly spaced.
//!
//! A drive's refusal for one parameter is a value of its sample and the polls go on; a link
//! failure (no answer) ends the watch ([`WatchError`]). [`Sampler::next`] may be cancelled at
//! any point (a front end's stop, also in the middle of a poll); what was read so far still
//! counts. At the end, [`Sampler::unread`] names every parameter no complete poll could read,
//! with the drive's last answer: a watch with one is a failure unless none was complete.

use std::time::{Duration, SystemTime, UNIX_EPOCH};

use drive_core::rt::time::{self, Instant, Interval, MissedTickBehavior};
use serde_json::{Value, json};

use crate::client::{ClientError, DeviceError, ParamClient};
use crate::meaning::{Device, target_json, value_json_in};
use crate::target::Target;

/// The shortest interval between polls, in milliseconds: a MOVILINK parameter read at 9600
/// baud takes about 25 ms, and a watch is for people and logs, not for control loops.
pub const MIN_INTERVAL_MS: u64 = 50;
/// The longest interval between polls, in milliseconds (one hour).
pub const MAX_INTERVAL_MS: u64 = 3_600_000;

/// One complete poll.
#[derive(Debug, Clone)]
pub struct Sample {
    /// Which poll (1 for the first).
    pub poll: u64,
    /// The wall-clock time the poll started (for the record).
    pub time: SystemTime,
    /// The monotonic time the poll started (for spacing and plotting).
    pub at: Instant,
    /// Per target, in order: its raw value or the drive's refusal.
    pub values: Vec<Result<i64, DeviceError>>,
    /// What is known of the drive, for the meaning of the values.
    pub device: Device,
    /// The link's running total of bytes discarded as stale ([`ParamClient::stale_bytes`]).
    pub stale_bytes: u64,
}

impl Sample {
    /// The sample as JSON: `{"type": "sample", "time": …` ([`timestamp`]) `, "values": [per
    /// target its read's object ([`value_json_in`]), or the target's keys (`index`, `number`,
    /// `label`, names, `selector`, `unit`) with the drive's `error`]}`; `targets` are the
    /// sampler's.
    ///
    pub fn to_json(&self, targets: &[Target]) -> Value {
        let values: Vec<Value> = targets
            .iter()
            .zip(&self.values)
            .map(|(t, cell)| match cell {
                Ok(raw) => value_json_in(t, *raw, &self.device),
                Err(d) => {
                    let mut o = target_json(t);
                    o.insert("error".into(), d.message.as_str().into());
                    Value::Object(o)
                }
            })
            .collect();
        json!({"type": "sample", "time": timestamp(self.time), "values": values})
    }
}

/// Why a watch ended early.
#[derive(Debug, Clone, thiserror::Error)]
#[non_exhaustive]
pub enum WatchError {
    /// Reading `target` failed on the link (or the request could not be made).
    #[error("{}: {error}", .target.label())]
    Link {
        /// The parameter being read.
        target: Target,
        /// What failed.
        error: ClientError,
        /// The complete polls before it.
        polls: u64,
    },
}

/// Parameters no poll of a watch could read: `no parameter could be read in 3 poll(s): P130
/// (its answer)`, or `1 of 2 parameter(s) could not be read in any of the 3 poll(s): …`.
#[derive(Debug, Clone, thiserror::Error)]
#[error("{}", unread_text(self))]
pub struct Unread {
    /// The complete polls.
    pub polls: u64,
    /// How many parameters were polled.
    pub total: usize,
    /// Each parameter never read, with the drive's last refusal.
    pub unread: Vec<(Target, DeviceError)>,
}

impl Unread {
    /// Whether no parameter at all was read.
    pub fn none_read(&self) -> bool {
        self.unread.len() == self.total
    }
}

fn unread_text(u: &Unread) -> String {
    let list: Vec<String> = u
        .unread
        .iter()
        .map(|(t, why)| format!("{} ({why})", t.label()))
        .collect();
    if u.none_read() {
        format!(
            "no parameter could be read in {} poll(s): {}",
            u.polls,
            list.join(", ")
        )
    } else {
        format!(
            "{} of {} parameter(s) could not be read in any of the {} poll(s): {}",
            list.len(),
            u.total,
            u.polls,
            list.join(", ")
        )
    }
}

/// Polls `targets` through a client at a steady rhythm (see the [module docs](self)).
#[derive(Debug)]
pub struct Sampler<'a, C> {
    client: &'a mut C,
    targets: &'a [Target],
    count: u64,
    ticker: Interval,
    done: u64,
    /// Per target: whether any poll read it.
    read: Vec<bool>,
    /// Per target: the drive's last refusal.
    refused: Vec<Option<DeviceError>>,
}

impl<'a, C: ParamClient> Sampler<'a, C> {
    /// Poll `targets` every `interval` (the first poll at once), `count` times (0: until the
    /// caller stops).
    pub fn new(client: &'a mut C, targets: &'a [Target], interval: Duration, count: u64) -> Self {
        let mut ticker = time::interval(interval);
        ticker.set_missed_tick_behavior(MissedTickBehavior::Skip);
        Self {
            client,
            targets,
            count,
            ticker,
            done: 0,
            read: vec![false; targets.len()],
            refused: vec![None; targets.len()],
        }
    }

    /// The next poll, at its slot of the grid; `None` once `count` polls are done.
    pub async fn next(&mut self) -> Result<Option<Sample>, WatchError> {
        if self.count != 0 && self.done >= self.count {
            return Ok(None);
        }
        self.ticker.tick().await;
        let (time, at) = (SystemTime::now(), time::now());
        let mut values = Vec::with_capacity(self.targets.len());
        let rows = self
            .targets
            .iter()
            .zip(self.read.iter_mut().zip(self.refused.iter_mut()));
        for (t, (read, refused)) in rows {
            match self.client.read(t).await {
                Ok(raw) => {
                    *read = true;
                    values.push(Ok(raw));
                }
                Err(ClientError::Device(d)) => {
                    *refused = Some(d.clone());
                    values.push(Err(d));
                }
                Err(error) => {
                    return Err(WatchError::Link {
                        target: *t,
                        error,
                        polls: self.done,
                    });
                }
            }
        }
        self.done += 1;
        Ok(Some(Sample {
            poll: self.done,
            time,
            at,
            values,
            device: self.client.device(),
            stale_bytes: self.client.stale_bytes(),
        }))
    }

    /// The complete polls so far.
    pub fn polls(&self) -> u64 {
        self.done
    }

    /// The targets polled.
    pub fn targets(&self) -> &'a [Target] {
        self.targets
    }

    /// The watch's verdict so far: a failure ([`Unread`]) when a parameter could not be read in
    /// any of the complete polls; a success before the first one (nothing to judge).
    pub fn verdict(&self) -> Result<(), Unread> {
        let unread = self.unread();
        if unread.is_empty() {
            return Ok(());
        }
        Err(Unread {
            polls: self.done,
            total: self.targets.len(),
            unread,
        })
    }

    /// Every target no poll read, with the drive's last refusal; empty before the first
    /// complete poll (nothing to judge).
    pub fn unread(&self) -> Vec<(Target, DeviceError)> {
        if self.done == 0 {
            return Vec::new();
        }
        self.targets
            .iter()
            .zip(self.read.iter().zip(&self.refused))
            .filter(|(_, (read, _))| !**read)
            .filter_map(|(t, (_, why))| why.clone().map(|d| (*t, d)))
            .collect()
    }
}

/// A point in time as RFC 3339 in UTC with milliseconds, e.g. `2024-02-29T12:34:56.789Z`
/// (times before 1970 too): how samples are stamped for a person or a log.
pub fn timestamp(t: SystemTime) -> String {
    let ms: i128 = match t.duration_since(UNIX_EPOCH) {
        Ok(d) => i128::try_from(d.as_millis()).unwrap_or(i128::MAX),
        Err(e) => -i128::try_from(e.duration().as_millis()).unwrap_or(i128::MAX),
    };
    let secs = ms.div_euclid(1000);
    let milli = ms.rem_euclid(1000);
    let (days, sod) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    let (y, m, d) = civil_from_days(days);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}.{milli:03}Z",
        sod / 3600,
        sod / 60 % 60,
        sod % 60
    )
}

/// Year, month and day of the `days`-th day after 1970-01-01 in the proleptic Gregorian
/// calendar (Howard Hinnant's `civil_from_days`: eras of 400 years, years starting in March).
fn civil_from_days(days: i128) -> (i128, i128, i128) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097; // day of the era, 0..=146096
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365; // 0..=399
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100); // day of the year from March 1st
    let mp = (5 * doy + 2) / 153; // month from March, 0..=11
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i128::from(m <= 2);
    (y, m, d)
}

#[cfg(test)]
#[path = "watch_tests.rs"]
mod tests;
