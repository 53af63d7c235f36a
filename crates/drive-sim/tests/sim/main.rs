//! Integration tests of the drive-sim crate (one test binary).

mod drive;
mod inject;
mod movidrive;
mod props;
mod ramp;
mod sew;
mod state;
mod store;
mod table;
