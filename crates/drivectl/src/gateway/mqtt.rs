//! The MQTT side of the gateway. INTERFACE STUB.

use std::sync::Arc;

use tokio::sync::mpsc;

use super::config::Plant;
use super::metrics::Metrics;
use super::model::{SetRequest, Update};
use crate::error::Result;

/// The prepared MQTT client (TLS material and password read, options built).
#[derive(Debug)]
pub struct Mqtt {}

impl Mqtt {
    /// Build the client's options from `plant` (reads the password, CA and certificate files).
    pub fn prepare(_plant: &Arc<Plant>) -> Result<Mqtt> {
        Ok(Mqtt {})
    }

    /// Connect (and reconnect) to the broker, publish `updates`, hand `set`s to the bus
    /// tasks (`sets[bus]`), until `shutdown` resolves; then publish the gateway's `offline`
    /// and disconnect.
    pub async fn run(
        self,
        _updates: mpsc::Receiver<Update>,
        _sets: Vec<mpsc::Sender<SetRequest>>,
        _metrics: Arc<Metrics>,
        shutdown: impl std::future::Future<Output = ()>,
    ) -> Result<()> {
        shutdown.await;
        Ok(())
    }
}
