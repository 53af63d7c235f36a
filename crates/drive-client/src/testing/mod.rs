//! A scripted [`ParamClient`] for tests of work written over it (this crate's, and a front
//! end's with the `testing` feature): a MOVIDRIVE whose reads answer whatever the test says,
//! and which remembers what was written, can lose its link or raise an interrupt after a number
//! of writes.

pub mod nord;

use drive_profile::{Family, Persistence};
use serde_json::{Map, Value};

use crate::client::{ClientError, DeviceCode, DeviceError, DeviceErrorKind, ParamClient};
use crate::interrupt::{Cause, Interrupt};
use crate::target::Target;

/// What a read of `index` answers.
pub type ReadScript = fn(index: u16) -> Result<i64, ClientError>;

/// A flag the fake drive raises as Ctrl-C would: this crate's [`Interrupt`], or a front end's
/// own wrapper of it.
pub trait Trip: Clone {
    /// Raise it.
    fn trip(&self);
}

impl Trip for Interrupt {
    fn trip(&self) {
        self.raise(Cause {
            name: "Ctrl-C (SIGINT)".into(),
            code: 2,
        });
    }
}

/// The scripted drive; `I` is the flag it raises ([`FakeClient::interrupt_after`]).
#[derive(Debug)]
pub struct FakeClient<I = Interrupt> {
    /// Answers reads.
    pub read: ReadScript,
    /// Every write taken: index, raw value, persistence.
    pub written: Vec<(u16, i64, Persistence)>,
    /// After this many writes, every write fails as a dead link (no answer).
    pub link_dies_after: Option<usize>,
    /// Raised (as Ctrl-C would) after this many writes.
    pub interrupt_after: Option<(usize, I)>,
    /// What `identify` answers.
    pub identity: Map<String, Value>,
    /// What `link_settings` answers.
    pub link_settings: &'static [u16],
    /// What `not_restored` answers.
    pub not_restored: &'static [u16],
}

impl<I: Trip> FakeClient<I> {
    /// A drive whose reads follow `read`.
    pub fn new(read: ReadScript) -> Self {
        Self {
            read,
            written: Vec::new(),
            link_dies_after: None,
            interrupt_after: None,
            identity: Map::new(),
            link_settings: &[],
            not_restored: &[],
        }
    }
}

/// A negative answer of `kind`.
pub fn refusal(kind: DeviceErrorKind, message: &str) -> ClientError {
    ClientError::Device(DeviceError {
        kind,
        code: DeviceCode::None,
        message: message.into(),
    })
}

impl<I: Trip> ParamClient for FakeClient<I> {
    fn family(&self) -> Family {
        Family::Movidrive
    }
    async fn drive_key(&mut self) -> Result<String, ClientError> {
        Ok("fake 1".into())
    }
    fn link_settings(&self) -> &'static [u16] {
        self.link_settings
    }
    fn not_restored(&self) -> &'static [u16] {
        self.not_restored
    }
    async fn read(&mut self, t: &Target) -> Result<i64, ClientError> {
        (self.read)(t.index)
    }
    async fn write(
        &mut self,
        t: &Target,
        raw: i64,
        persistence: Persistence,
    ) -> Result<(), ClientError> {
        if self
            .link_dies_after
            .is_some_and(|n| self.written.len() >= n)
        {
            return Err(ClientError::link(
                crate::LinkFault::NoAnswer,
                "no answer from drive 1",
            ));
        }
        self.written.push((t.index, raw, persistence));
        if let Some((n, stop)) = &self.interrupt_after
            && self.written.len() >= *n
        {
            stop.trip();
        }
        Ok(())
    }
    async fn identify(&mut self) -> Result<Map<String, Value>, ClientError> {
        Ok(self.identity.clone())
    }
}
