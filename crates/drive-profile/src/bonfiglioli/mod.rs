//! Placeholder for the bonfiglioli tables and profile (filled in by the bonfiglioli work).
