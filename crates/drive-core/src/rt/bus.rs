//! Simulated devices on a line: one alone ([`serve_alone`]) or several ([`Bus`]), and the line
//! time they keep between serves ([`LineTime`]). What every protocol's simulator is.

use core::time::Duration;
use std::io;
use std::vec::Vec;

use super::clock::{Clock, Timebase};
use super::io::CharIo;
use super::serve::serve;
use crate::endpoint::Endpoint;
use crate::line::LineSettings;

/// The clock a simulated device (or bus) is served on, and its time base once it has been
/// served: a second serve goes on where the first stopped, and a clock switch keeps the time
/// (the device keeps its line history).
#[derive(Debug, Clone, Copy, Default)]
pub struct LineTime {
    clock: Clock,
    time: Option<Timebase>,
}

impl LineTime {
    /// [`Clock::Real`], not served yet.
    pub const fn new() -> Self {
        Self {
            clock: Clock::Real,
            time: None,
        }
    }

    /// The clock.
    pub fn clock(&self) -> Clock {
        self.clock
    }

    /// Serve on `clock` from now on, the time going on from where it is.
    pub fn set_clock(&mut self, clock: Clock) {
        self.clock = clock;
        self.time = self.time.map(|t| t.switched_to(clock));
    }

    /// Serve `stations` on `io` (see [`serve`]) with this line time, created on first use for
    /// a line with `char_time`, and kept for the next serve.
    pub async fn serve<S: Endpoint, IO: CharIo>(
        &mut self,
        stations: &mut [S],
        char_time: Duration,
        io: IO,
    ) -> io::Result<()> {
        let clock = self.clock;
        let mut time = *self
            .time
            .get_or_insert_with(|| Timebase::new(clock, char_time));
        let r = serve(stations, &mut time, io).await;
        self.time = Some(time);
        r
    }
}

/// A simulated device that can share a line with others: an [`Endpoint`] with an address and
/// its own [`LineTime`] for when it is served alone.
pub trait Station: Endpoint {
    /// The address the device answers now (it may change when the device's address parameter
    /// is written).
    fn address(&self) -> u8;

    /// The character time of the device's line.
    fn char_time(&self) -> Duration;

    /// The device's line time for serving it alone.
    fn line_time(&mut self) -> &mut LineTime;

    /// Run the device (alone, and its own timers) on `clock` from now on.
    fn set_clock(&mut self, clock: Clock) {
        self.line_time().set_clock(clock);
    }
}

/// Serve `station` alone on `io` until it closes (`Ok`) or fails, with its own line time.
pub async fn serve_alone<S: Station, IO: CharIo>(station: &mut S, io: IO) -> io::Result<()> {
    let mut line = *station.line_time();
    let char_time = station.char_time();
    let r = line
        .serve(core::slice::from_mut(station), char_time, io)
        .await;
    *station.line_time() = line;
    r
}

/// Simulated devices on one line, each answering its own address, served by [`serve`].
///
/// The line keeps its time between calls of [`Bus::serve`]: a second serve goes on where the
/// first stopped.
#[derive(Debug)]
pub struct Bus<S> {
    stations: Vec<S>,
    time: LineTime,
    line: LineSettings,
}

impl<S: Station> Bus<S> {
    /// The `stations` on a line with `line`'s settings, on [`Clock::Real`]. Of two stations with
    /// the same address only the first is kept.
    pub fn new(stations: impl IntoIterator<Item = S>, line: LineSettings) -> Self {
        let mut kept: Vec<S> = Vec::new();
        for s in stations {
            if !kept.iter().any(|k| k.address() == s.address()) {
                kept.push(s);
            }
        }
        Self {
            stations: kept,
            time: LineTime::new(),
            line,
        }
    }

    /// Serve requests on `io` until it closes (`Ok`) or fails.
    pub async fn serve<IO: CharIo>(&mut self, io: IO) -> io::Result<()> {
        self.time
            .serve(&mut self.stations, self.line.char_time(), io)
            .await
    }

    /// The station that answers `address` now.
    pub fn station(&self, address: u8) -> Option<&S> {
        self.stations.iter().find(|s| s.address() == address)
    }

    /// The station that answers `address` now, for changing.
    pub fn station_mut(&mut self, address: u8) -> Option<&mut S> {
        self.stations.iter_mut().find(|s| s.address() == address)
    }

    /// All stations.
    pub fn stations(&self) -> &[S] {
        &self.stations
    }

    /// All stations, for changing.
    pub fn stations_mut(&mut self) -> &mut [S] {
        &mut self.stations
    }

    /// The line's settings.
    pub fn line(&self) -> LineSettings {
        self.line
    }

    /// [`Clock::Real`] (tokio's clock, the default) or [`Clock::Virtual`] (waits for nothing),
    /// for the line and every station. The line keeps its history: its time goes on from where
    /// it is.
    pub fn set_clock(&mut self, clock: Clock) {
        self.time.set_clock(clock);
        for s in &mut self.stations {
            s.set_clock(clock);
        }
    }
}
