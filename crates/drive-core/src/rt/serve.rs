//! The serve loop of simulated devices: every [`Endpoint`] on one line hears every character
//! and answers when its protocol says so.

use std::io;

use super::clock::{Clock, Timebase};
use super::io::{CHUNK, CharIo, ReceivedChar, Woken, read_or_sleep, write_all, write_all_at};
use super::port::frame_of;
use crate::char::RxChar;
use crate::endpoint::Endpoint;
use crate::time::Instant;

/// Serve `stations` (simulated slaves sharing one line) on `io` until it closes (`Ok`) or
/// fails.
///
/// On [`Clock::Real`] every deadline of every station is waited for (frame confirmation,
/// response due, the devices' own timers); characters that are waiting are fed first, and a
/// deadline in the past goes through the timer like any other, so the loop always yields to
/// the runtime. When the timer for a deadline ends (on tokio's next 1 ms tick), the stations
/// are told the deadline as their time, and a frame sent because of that wake-up is written
/// with the deadline as its intended start ([`write_all_at`]): on the wire model it starts
/// exactly where the protocol put it. On [`Clock::Virtual`] the loop waits for nothing: it jumps to deadlines that
/// need only a quiet line (a request's end confirmation, its response falling due), so a
/// benchmark measures software only; the stations' other timers do not fire. A station's frame
/// is handed to the line only; the other stations do not hear it.
pub async fn serve<S: Endpoint, IO: CharIo>(
    stations: &mut [S],
    time: &mut Timebase,
    mut io: IO,
) -> io::Result<()> {
    let max = stations
        .iter()
        .map(Endpoint::max_frame_len)
        .max()
        .unwrap_or(0);
    let mut buf = vec![0u8; max];
    let mut rx = vec![ReceivedChar::new(0, time.epoch()); CHUNK];
    let mut sleep = Box::pin(super::time::sleep_until(time.epoch()));
    let mut armed_at = time.epoch();
    let mut last_jump = None;
    // Real clock: the time the last timer wake-up was handled at (the deadline, not tokio's
    // late tick), until the next frame or character; and the arrival of the last character.
    let mut woken: Option<Instant> = None;
    let mut last_rx: Option<Instant> = None;
    loop {
        for s in stations.iter_mut() {
            // `now` after every write: writing on the wire model waits until the frame left
            // the line.
            loop {
                let start = woken.and_then(|t| time.intended_start(t).map(|at| (t, at)));
                let now = start.map_or_else(|| time.now(), |(t, _)| t);
                let Some(n) = s.poll_transmit(now, &mut buf) else {
                    break;
                };
                woken = None;
                let frame = frame_of(&buf, n)?;
                match start {
                    Some((_, at)) => write_all_at(&mut io, frame, at).await?,
                    None => write_all(&mut io, frame).await?,
                }
                time.sent(n);
            }
        }
        let mut armed_deadline = None;
        let armed = match time.clock() {
            Clock::Real => match stations.iter().filter_map(|s| s.poll_timeout()).min() {
                Some(deadline) => {
                    armed_deadline = Some(deadline);
                    let at = time.to_tokio(deadline);
                    if at != armed_at {
                        sleep.as_mut().reset(at);
                        armed_at = at;
                    }
                    Some(sleep.as_mut())
                }
                None => None,
            },
            Clock::Virtual => {
                let quiet = stations.iter().filter_map(|s| s.poll_quiet_timeout()).min();
                if quiet.is_some() && quiet != last_jump {
                    last_jump = quiet;
                    if let Some(q) = quiet {
                        time.jump_to(q);
                    }
                    timeouts(stations, time.now());
                    continue;
                }
                None
            }
        };
        match read_or_sleep(&mut io, &mut rx, armed).await? {
            Woken::Read(0) => return Ok(()),
            Woken::Read(n) => {
                woken = None;
                for c in rx.iter().take(n) {
                    let c = RxChar {
                        byte: c.byte,
                        time: time.arrival(c.at),
                        error: c.error,
                    };
                    last_rx = Some(c.time);
                    for s in stations.iter_mut() {
                        s.handle_char(c);
                    }
                }
            }
            Woken::Timer => {
                let now = match (time.clock(), armed_deadline) {
                    (Clock::Real, Some(d)) if io.honours_write_start() => {
                        // Never before a character already fed.
                        let now = last_rx.map_or(time.woken_at(d), |f| time.woken_at(d).later(f));
                        woken = Some(now);
                        now
                    }
                    _ => time.now(),
                };
                timeouts(stations, now);
            }
        }
    }
}

fn timeouts<S: Endpoint>(stations: &mut [S], now: Instant) {
    for s in stations.iter_mut() {
        s.handle_timeout(now);
    }
}
