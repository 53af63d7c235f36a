//! Shared helpers of the workspace integration tests: simulated drives built from each family's
//! generated table, and iteration over every parameter of every family.

// Test-helper crate: only the integration tests use it, and they want a panic on bad fixtures.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

pub mod movilink_bus;

use drive_profile::{Family, ParamMeta};
use drive_sim::{ParamStore, SimDrive, StoreOptions};

/// Every parameter of `family` as a trait object.
pub fn params(family: Family) -> Vec<&'static (dyn ParamMeta + Sync)> {
    drive_profile::family::params(family).collect()
}

/// A simulated drive of `family` whose parameter store is built from the generated table.
pub fn sim_drive(family: Family) -> SimDrive {
    let options = match family {
        Family::Movidrive => StoreOptions::default(),
        _ => StoreOptions {
            eeprom_for_unflagged: true,
            ..StoreOptions::default()
        },
    };
    SimDrive::new(ParamStore::from_rows(params(family), options))
}
