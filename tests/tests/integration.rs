//! The one workspace-level integration-test binary: checks that cross crate boundaries.

mod movilink_faults;
mod tables_and_sim;
