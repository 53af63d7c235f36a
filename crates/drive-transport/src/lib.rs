//! Transports (filled in by the drive-transport work).
