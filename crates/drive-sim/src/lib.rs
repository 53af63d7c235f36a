//! Simulated drives (filled in by the drive-sim work).
