//! A scripted [`ParamClient`] for the tool layer's tests: a MOVIDRIVE whose reads answer
//! whatever the test says, and which remembers what was written.

use drive_profile::{Family, Persistence};
use serde_json::{Map, Value};

use super::client::{ClientError, DeviceError, DeviceErrorKind, ParamClient, Target};

/// What a read of `index` answers.
pub type ReadScript = fn(index: u16) -> Result<i64, ClientError>;

/// The scripted drive.
pub struct FakeClient {
    /// Answers reads.
    pub read: ReadScript,
    /// Every write taken: index, raw value, persistence.
    pub written: Vec<(u16, i64, Persistence)>,
    /// After this many writes, every write fails as a dead link (no answer).
    pub link_dies_after: Option<usize>,
    /// Set (as Ctrl-C would) after this many writes.
    pub interrupt_after: Option<(usize, super::interrupt::Interrupt)>,
    /// What `identify` answers.
    pub identity: Map<String, Value>,
    /// What `link_settings` answers.
    pub link_settings: &'static [u16],
    /// What `not_restored` answers.
    pub not_restored: &'static [u16],
}

impl FakeClient {
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
        message: message.into(),
    })
}

impl ParamClient for FakeClient {
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
            return Err(ClientError::Link("no answer from drive 1".into()));
        }
        self.written.push((t.index, raw, persistence));
        if let Some((n, stop)) = &self.interrupt_after
            && self.written.len() >= *n
        {
            stop.set();
        }
        Ok(())
    }
    async fn identify(&mut self) -> Result<Map<String, Value>, ClientError> {
        Ok(self.identity.clone())
    }
}
