//! Placeholder for the nord tables and profile (filled in by the nord work).
