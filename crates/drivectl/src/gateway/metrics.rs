//! Prometheus metrics of the gateway and the `/metrics` endpoint.
//!
//! INTERFACE STUB: the signatures below are what the bus tasks and the MQTT task call.

use std::time::Duration;

use super::config::Plant;

/// The gateway's metrics registry.
#[derive(Debug)]
pub struct Metrics {}

impl Metrics {
    /// A registry for `plant`'s buses and drives.
    pub fn new(_plant: &Plant) -> Self {
        Self {}
    }

    /// One transaction on `bus` with `drive`: `op` is `read`, `write`, `process_data`;
    /// `outcome` is `ok`, `timeout`, `device_error` or `link_error`; `latency` from the
    /// request to the answer or the give-up.
    pub fn transaction(
        &self,
        _bus: &str,
        _drive: &str,
        _op: &'static str,
        _outcome: &'static str,
        _latency: Duration,
    ) {
    }

    /// Repeated attempts on `bus`.
    pub fn retries(&self, _bus: &str, _n: u64) {}

    /// Received frames refused on `bus` for `reason`.
    pub fn rejected(&self, _bus: &str, _reason: &str, _n: u64) {}

    /// The bus's wire utilisation (0–1) and the share its polls ask for.
    pub fn utilisation(&self, _bus: &str, _utilisation: f64, _demand: f64) {}

    /// A drive's status (`online`, `timeout`, `fault`).
    pub fn drive_status(&self, _bus: &str, _drive: &str, _state: &'static str) {}

    /// The broker connection is up or down.
    pub fn broker_connected(&self, _up: bool) {}

    /// MQTT messages published (`kind`: value, status, result, figures).
    pub fn published(&self, _kind: &'static str) {}

    /// `set` messages by outcome (`written`, a refusal reason, `device_refused`, `link_failed`).
    pub fn set_outcome(&self, _outcome: &str) {}

    /// The text exposition.
    pub fn encode(&self) -> String {
        String::new()
    }
}

/// Bind the metrics endpoint (an error names the address and what to change).
pub async fn bind(addr: std::net::SocketAddr) -> crate::error::Result<tokio::net::TcpListener> {
    tokio::net::TcpListener::bind(addr).await.map_err(|e| {
        crate::error::CliError::failed(format!(
            "cannot listen on {addr} for /metrics: {e}; set [gateway] metrics to another \
             host:port or \"off\""
        ))
    })
}

/// Serve `GET /metrics` on `listener` until the task is dropped.
pub async fn serve(_listener: tokio::net::TcpListener, _metrics: std::sync::Arc<Metrics>) {}
