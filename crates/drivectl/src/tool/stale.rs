//! Notes about stale bytes: what drivectl discarded instead of taking it for an answer.
//!
//! Many answers do not name what they answer (a Modbus FC 3 answer carries only a byte count
//! and the value, a MOVILINK process-data response or a USS PZD part nothing at all), so an
//! answer another program left in the port would pass every check. drivectl discards what the
//! port holds when it is opened (`drive_transport::serial::open`) and every byte that arrives
//! before a request has left the port (the runtime layer's `Port` and the masters' `Exchange`);
//! these notes say so on standard error, once per batch, so a technician knows another program
//! (or a late answer) was on the line.

use std::sync::atomic::{AtomicU64, Ordering};

/// Stale bytes of the drivers already reported (this process runs one command).
static REPORTED: AtomicU64 = AtomicU64::new(0);

fn bytes(n: u64) -> String {
    if n == 1 {
        "1 byte".to_owned()
    } else {
        format!("{n} bytes")
    }
}

/// The note for `n` bytes the port held when it was opened, if any.
pub fn flushed_text(n: u32) -> Option<String> {
    (n > 0).then(|| {
        format!(
            "drivectl: note: discarded {} an earlier program left in the port when it was \
             opened; they were not taken as an answer",
            bytes(u64::from(n))
        )
    })
}

/// The note for `n` bytes that arrived before a request had left the port, if any.
pub fn stale_text(n: u64) -> Option<String> {
    (n > 0).then(|| {
        format!(
            "drivectl: note: discarded {} that arrived before the request had left the port (an \
             answer an earlier program left there, a late answer or another master on the \
             line); they were not taken as an answer",
            bytes(n)
        )
    })
}

/// The note for `n` CAN frames that arrived before a request had gone out, if any.
pub fn stale_frames_text(n: u64) -> Option<String> {
    (n > 0).then(|| {
        format!(
            "drivectl: note: discarded {n} CAN frame{} that arrived before the request had gone \
             out (an answer an earlier program left in the adapter, a late answer); {} not \
             taken as an answer",
            if n == 1 { "" } else { "s" },
            if n == 1 { "it was" } else { "they were" }
        )
    })
}

/// Say how many CAN frames the SBus master discarded as stale (its running total).
pub fn note_stale_frames(total: u64) {
    if let Some(text) = stale_frames_text(total) {
        errln!("{text}");
    }
}

/// Say that opening the port discarded `n` bytes (nothing for none).
pub fn note_flushed(n: u32) {
    if let Some(text) = flushed_text(n) {
        errln!("{text}");
    }
}

/// Say how many stale bytes the driver discarded since the last note, given its running
/// total (nothing when none came since).
pub fn note_stale(total: u64) {
    let before = REPORTED.fetch_max(total, Ordering::Relaxed);
    if let Some(text) = stale_text(total.saturating_sub(before)) {
        errln!("{text}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_notes_count_bytes_and_say_nothing_for_none() {
        assert_eq!(flushed_text(0), None);
        assert_eq!(stale_text(0), None);
        assert_eq!(
            flushed_text(7).as_deref(),
            Some(
                "drivectl: note: discarded 7 bytes an earlier program left in the port when it \
                 was opened; they were not taken as an answer"
            )
        );
        assert!(
            stale_text(1)
                .unwrap()
                .starts_with("drivectl: note: discarded 1 byte that")
        );
    }
}
