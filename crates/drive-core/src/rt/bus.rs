//! Several simulated devices on one line: what every protocol's simulated bus is.

use std::io;
use std::vec::Vec;

use super::clock::{Clock, Timebase};
use super::io::CharIo;
use super::serve::serve;
use crate::endpoint::Endpoint;
use crate::line::LineSettings;

/// A simulated device that can share a line with others: an [`Endpoint`] with an address.
pub trait Station: Endpoint {
    /// The address the device answers now (it may change when the device's address parameter
    /// is written).
    fn address(&self) -> u8;

    /// Run the device's own timers on `clock` from now on (the default does nothing, for
    /// devices that have none).
    fn set_clock(&mut self, clock: Clock) {
        let _ = clock;
    }
}

/// Simulated devices on one line, each answering its own address, served by [`serve`].
///
/// The line keeps its time between calls of [`Bus::serve`]: a second serve goes on where the
/// first stopped.
#[derive(Debug)]
pub struct Bus<S> {
    stations: Vec<S>,
    clock: Clock,
    time: Option<Timebase>,
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
            clock: Clock::Real,
            time: None,
            line,
        }
    }

    /// Serve requests on `io` until it closes (`Ok`) or fails.
    pub async fn serve<IO: CharIo>(&mut self, io: IO) -> io::Result<()> {
        let clock = self.clock;
        let char_time = self.line.char_time();
        let mut time = *self
            .time
            .get_or_insert_with(|| Timebase::new(clock, char_time));
        let r = serve(&mut self.stations, &mut time, io).await;
        self.time = Some(time);
        r
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
        self.clock = clock;
        self.time = self.time.map(|t| t.switched_to(clock));
        for s in &mut self.stations {
            s.set_clock(clock);
        }
    }
}
