//! The gateway's errors: a config it cannot run (the user's to change) or a failure while
//! starting (a port, a listener, the TLS set-up). Each message is one line in the config's
//! terms (`plant.toml:LINE: …`); a front end adds its own words and exit codes.

/// Why the gateway does not start.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The config, or a setting given beside it, is not one the gateway can run.
    #[error("{0}")]
    Config(String),
    /// Starting failed: a port, a listener, the runtime, the TLS set-up.
    #[error("{0}")]
    Failed(String),
}

impl Error {
    /// A config error.
    pub fn config(message: impl Into<String>) -> Self {
        Error::Config(message.into().replace('\n', " "))
    }

    /// A failure while starting.
    pub fn failed(message: impl Into<String>) -> Self {
        Error::Failed(message.into().replace('\n', " "))
    }
}

/// Result alias of the gateway.
pub type Result<T> = std::result::Result<T, Error>;
