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
}

impl FakeClient {
    /// A drive whose reads follow `read`.
    pub fn new(read: ReadScript) -> Self {
        Self {
            read,
            written: Vec::new(),
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
    async fn read(&mut self, t: &Target) -> Result<i64, ClientError> {
        (self.read)(t.index)
    }
    async fn write(
        &mut self,
        t: &Target,
        raw: i64,
        persistence: Persistence,
    ) -> Result<(), ClientError> {
        self.written.push((t.index, raw, persistence));
        Ok(())
    }
    async fn identify(&mut self) -> Result<Map<String, Value>, ClientError> {
        Ok(Map::new())
    }
}
