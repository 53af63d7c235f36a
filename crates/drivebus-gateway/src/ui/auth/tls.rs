//! The page over HTTPS: the server's certificate and key (`[ui] tls_cert`, `tls_key`), and a
//! listener for axum that accepts TCP and does each TLS handshake in its own task, with a time
//! limit, so that a client that connects and sends nothing holds up no one else.

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use axum::serve::ListenerExt as _;
use rustls::pki_types::pem::PemObject as _;
use rustls::pki_types::{CertificateDer, PrivateKeyDer};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{Semaphore, mpsc};
use tokio_rustls::TlsAcceptor;
use tokio_rustls::server::TlsStream;

use crate::error::{Error, Result};

/// How long a client has for its TLS handshake.
pub const HANDSHAKE_LIMIT: Duration = Duration::from_secs(10);
/// Connections in their handshake at once; the next waits for one of them to end.
pub const MAX_HANDSHAKES: usize = 64;
/// The largest certificate or key file read.
const PEM_LIMIT: u64 = 1 << 20;

/// The rustls server configuration of the certificate chain in `cert` and its key in `key`
/// (PEM files): TLS 1.2 and 1.3 on the ring provider, HTTP/1.1. An error names the key and the
/// file.
pub fn server_config(cert: &str, key: &str) -> Result<rustls::ServerConfig> {
    let pem = super::read_small(cert, "tls_cert", PEM_LIMIT)?;
    let chain = CertificateDer::pem_slice_iter(&pem)
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(|e| {
            Error::config(format!(
                "[ui] tls_cert = {cert:?}: not a PEM certificate file ({e})"
            ))
        })?;
    if chain.is_empty() {
        return Err(Error::config(format!(
            "[ui] tls_cert = {cert:?}: no certificate in it; give a PEM file with -----BEGIN \
             CERTIFICATE-----"
        )));
    }
    let key_pem = super::read_small(key, "tls_key", PEM_LIMIT)?;
    let key_der = PrivateKeyDer::from_pem_slice(&key_pem).map_err(|e| {
        Error::config(format!(
            "[ui] tls_key = {key:?}: no PEM private key in it ({e})"
        ))
    })?;
    let mut config = rustls::ServerConfig::builder_with_provider(Arc::new(
        rustls::crypto::ring::default_provider(),
    ))
    .with_safe_default_protocol_versions()
    .map_err(|e| Error::failed(format!("TLS set-up: {e}")))?
    .with_no_client_auth()
    .with_single_cert(chain, key_der)
    .map_err(|e| {
        Error::config(format!(
            "[ui] tls_cert = {cert:?} and tls_key = {key:?} do not go together: {e}"
        ))
    })?;
    config.alpn_protocols = vec![b"http/1.1".to_vec()];
    Ok(config)
}

/// A listener whose connections are TLS streams whose handshake is done: an accepting task
/// takes TCP connections and gives each handshake its own task, at most [`MAX_HANDSHAKES`] at
/// once and each within [`HANDSHAKE_LIMIT`]; a failed one is logged at debug and dropped.
#[derive(Debug)]
pub struct TlsListener {
    ready: mpsc::Receiver<(TlsStream<TcpStream>, SocketAddr)>,
    local: SocketAddr,
    accepting: tokio::task::JoinHandle<()>,
}

impl TlsListener {
    /// Start accepting on `tcp` with `config` (inside a tokio runtime).
    pub fn new(tcp: TcpListener, config: Arc<rustls::ServerConfig>) -> std::io::Result<Self> {
        let local = tcp.local_addr()?;
        let (tx, ready) = mpsc::channel(MAX_HANDSHAKES);
        let accepting = tokio::spawn(accept(tcp, TlsAcceptor::from(config), tx));
        Ok(TlsListener {
            ready,
            local,
            accepting,
        })
    }
}

impl Drop for TlsListener {
    fn drop(&mut self) {
        self.accepting.abort();
    }
}

async fn accept(
    tcp: TcpListener,
    acceptor: TlsAcceptor,
    tx: mpsc::Sender<(TlsStream<TcpStream>, SocketAddr)>,
) {
    let slots = Arc::new(Semaphore::new(MAX_HANDSHAKES));
    loop {
        let Ok(slot) = slots.clone().acquire_owned().await else {
            return;
        };
        let (stream, addr) = tokio::select! {
            () = tx.closed() => return,
            r = tcp.accept() => match r {
                Ok(c) => c,
                Err(e) => {
                    accept_error(e).await;
                    continue;
                }
            },
        };
        let acceptor = acceptor.clone();
        let tx = tx.clone();
        tokio::spawn(async move {
            match tokio::time::timeout(HANDSHAKE_LIMIT, acceptor.accept(stream)).await {
                Ok(Ok(tls)) => {
                    let _ = tx.send((tls, addr)).await;
                }
                Ok(Err(e)) => tracing::debug!(%addr, error = %e, "page: TLS handshake failed"),
                Err(_) => tracing::debug!(%addr, "page: TLS handshake timed out"),
            }
            drop(slot);
        });
    }
}

/// After a failed `accept`: a connection's own error costs nothing; anything else (out of file
/// descriptors) is logged and waited out for a second, as axum's own listener does.
async fn accept_error(e: std::io::Error) {
    use std::io::ErrorKind;
    if matches!(
        e.kind(),
        ErrorKind::ConnectionRefused | ErrorKind::ConnectionAborted | ErrorKind::ConnectionReset
    ) {
        return;
    }
    tracing::error!(error = %e, "the page's listener cannot accept");
    tokio::time::sleep(Duration::from_secs(1)).await;
}

impl axum::serve::Listener for TlsListener {
    type Io = TlsStream<TcpStream>;
    type Addr = SocketAddr;

    async fn accept(&mut self) -> (Self::Io, Self::Addr) {
        match self.ready.recv().await {
            Some(c) => c,
            // The accepting task ended (it ends only when aborted): nothing more comes.
            None => std::future::pending().await,
        }
    }

    fn local_addr(&self) -> std::io::Result<Self::Addr> {
        Ok(self.local)
    }
}

/// Serve `app` on `tcp` (over TLS with `tls`) until `shutdown`; every request carries its
/// client's address (`ConnectInfo<SocketAddr>`: the log-in's rate limit and log).
pub async fn serve(
    tcp: TcpListener,
    app: Router,
    tls: Option<Arc<rustls::ServerConfig>>,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> Result<()> {
    let failed = |e: std::io::Error| Error::failed(format!("the page's listener failed: {e}"));
    match tls {
        None => axum::serve(tcp, app.into_make_service_with_connect_info::<SocketAddr>())
            .with_graceful_shutdown(shutdown)
            .await
            .map_err(failed),
        Some(config) => {
            // `tap_io` only for its `ConnectInfo`, which axum gives a tapped listener's address.
            let listener = TlsListener::new(tcp, config)
                .map_err(failed)?
                .tap_io(|_| {});
            axum::serve(
                listener,
                app.into_make_service_with_connect_info::<SocketAddr>(),
            )
            .with_graceful_shutdown(shutdown)
            .await
            .map_err(failed)
        }
    }
}
