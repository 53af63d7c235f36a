//! The scripted [`ParamClient`](super::client::ParamClient) of the tool layer's tests:
//! `drive_client`'s (a MOVIDRIVE whose reads answer whatever the test says, and which remembers
//! what was written), raising the command line's [`Interrupt`] as Ctrl-C would.

use super::interrupt::Interrupt;

pub use drive_client::testing::refusal;

/// The scripted drive.
pub type FakeClient = drive_client::testing::FakeClient<Interrupt>;

impl drive_client::testing::Trip for Interrupt {
    fn trip(&self) {
        self.set();
    }
}
