//! The one workspace-level integration-test binary: checks that cross crate boundaries.

mod tables_and_sim;
