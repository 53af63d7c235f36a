//! Placeholder for the sew tables and profile (filled in by the sew work).
