//! A real Mosquitto broker for tests, and a test MQTT client.
//!
//! [`Mosquitto::start`] finds the `mosquitto` binary and starts it on 127.0.0.1 at a free port
//! with a config generated in a temporary directory: no persistence, optionally a password file
//! (`mosquitto_passwd -b`) and a TLS listener whose CA and server certificate are generated with
//! the `openssl` CLI. The broker can be stopped and restarted on the same port and is killed
//! when dropped. [`Mosquitto::start_with`] adds files and config lines of the test's own (a
//! bridge, an ACL, persistence); [`Mosquitto::terminate`] stops it cleanly.
//!
//! The harness installs nothing: `scripts/test` runs `scripts/setup-mosquitto` (apt-get) before
//! the tests. Where a tool is missing, `start` fails the test under CI (the `CI` variable set
//! and not empty: a check that cannot run must not pass) with a message naming
//! `scripts/setup-mosquitto`; elsewhere it prints one `SKIPPED` line saying why and returns
//! `None`, and the test returns early.
//!
//! Used by the gateway's in-crate tests (`#[path]` include) and by integration tests; it needs
//! only std, tokio and rumqttc.

// Test code: helpers outside `#[test]` fns (not exempted by clippy.toml) panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic,
    // The one line saying why a test is skipped.
    clippy::print_stderr,
    dead_code
)]

use std::io::Write as _;
use std::net::{Ipv4Addr, TcpListener, TcpStream};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use rumqttc::{AsyncClient, Event, MqttOptions, Packet, Publish, QoS};
use tokio::sync::mpsc;

/// What the broker is started with.
#[derive(Debug, Clone, Default)]
pub struct BrokerOptions {
    /// Users and passwords; when not empty, anonymous clients are refused.
    pub users: Vec<(String, String)>,
    /// A TLS listener (certificate for `localhost` and 127.0.0.1, signed by a generated CA)
    /// instead of plain TCP.
    pub tls: bool,
    /// With `tls`: clients must show a certificate signed by the CA (its CN is the user
    /// name). The harness makes `gw.pem`/`gw.key` and `scada.pem`/`scada.key` signed by the
    /// CA, and `rogue.pem`/`rogue.key` signed by another CA.
    pub client_certificates: bool,
}

/// The binaries the harness runs, found once.
#[derive(Debug, Clone)]
struct Tools {
    mosquitto: PathBuf,
    passwd: PathBuf,
    openssl: Option<PathBuf>,
}

fn find(name: &str) -> Option<PathBuf> {
    let mut dirs: Vec<PathBuf> = std::env::var_os("PATH")
        .map(|p| std::env::split_paths(&p).collect())
        .unwrap_or_default();
    // Debian installs the broker in /usr/sbin, which a non-login PATH may lack.
    dirs.extend(["/usr/sbin", "/usr/bin", "/usr/local/sbin", "/usr/local/bin"].map(PathBuf::from));
    dirs.into_iter().map(|d| d.join(name)).find(|p| p.is_file())
}

fn find_tools() -> Option<Tools> {
    Some(Tools {
        mosquitto: find("mosquitto")?,
        passwd: find("mosquitto_passwd")?,
        openssl: find("openssl"),
    })
}

/// The tools, found once; `Err` says which one is missing and how to install it.
fn tools() -> Result<Tools, String> {
    static TOOLS: OnceLock<Result<Tools, String>> = OnceLock::new();
    TOOLS
        .get_or_init(|| {
            find_tools().ok_or_else(|| {
                let missing: Vec<&str> = ["mosquitto", "mosquitto_passwd"]
                    .into_iter()
                    .filter(|name| find(name).is_none())
                    .collect();
                format!(
                    "no Mosquitto broker here ({} not on PATH, nor in /usr/sbin, /usr/bin, \
                     /usr/local/sbin, /usr/local/bin); install it with scripts/setup-mosquitto, \
                     which scripts/test runs",
                    missing.join(" and ")
                )
            })
        })
        .clone()
}

/// Under CI (the `CI` variable set and not empty) a broker test that cannot run fails.
fn under_ci() -> bool {
    std::env::var_os("CI").is_some_and(|v| !v.is_empty())
}

/// A broker test cannot run because of `why`: a failure under CI, else one `SKIPPED` line.
fn cannot_run(why: &str) -> Option<Mosquitto> {
    if under_ci() {
        panic!("{why}; CI is set, so a broker test that cannot run fails instead of skipping");
    }
    eprintln!("SKIPPED: {why}");
    None
}

static SEQ: AtomicU32 = AtomicU32::new(0);

/// A running Mosquitto; killed, and its directory removed, when dropped.
#[derive(Debug)]
pub struct Mosquitto {
    child: Option<Child>,
    tools: Tools,
    /// The port it listens on (127.0.0.1).
    pub port: u16,
    /// Its temporary directory (config, log, certificates, password file).
    pub dir: PathBuf,
    options: BrokerOptions,
    /// Lines appended to the generated config (see [`Mosquitto::start_with`]).
    extra: String,
}

impl Mosquitto {
    /// Start a broker. Where Mosquitto (or, for TLS, the openssl CLI) is missing: a panic
    /// under CI, else `None` with one `SKIPPED` line on stderr.
    pub fn start(options: BrokerOptions) -> Option<Mosquitto> {
        Mosquitto::start_with(options, &[], "")
    }

    /// [`Mosquitto::start`] with more: `files` (name, text) are written into the broker's
    /// directory first, and `extra` is appended to the generated config, `{dir}` in it standing
    /// for that directory (a bridge block, an `acl_file`, persistence; a later line overrides
    /// an earlier one, so `persistence true` there turns it on).
    pub fn start_with(
        options: BrokerOptions,
        files: &[(&str, &str)],
        extra: &str,
    ) -> Option<Mosquitto> {
        let tools = match tools() {
            Ok(t) => t,
            Err(why) => return cannot_run(&why),
        };
        if options.tls && tools.openssl.is_none() {
            return cannot_run(
                "no openssl CLI to generate the test CA; install it with \
                 scripts/setup-mosquitto, which scripts/test runs",
            );
        }
        let dir = std::env::temp_dir().join(format!(
            "drivebus-mosquitto-{}-{}",
            std::process::id(),
            SEQ.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let mut broker = Mosquitto {
            child: None,
            tools,
            port: 0,
            dir,
            options,
            extra: extra.to_owned(),
        };
        broker.write_files();
        for (name, text) in files {
            broker.file(name, text);
        }
        // A free port can be taken by someone else before the broker binds it: try a few.
        for _ in 0..5 {
            broker.port = free_port();
            broker.write_config();
            if broker.spawn() {
                return Some(broker);
            }
        }
        panic!(
            "mosquitto did not start; its log: {}",
            std::fs::read_to_string(broker.dir.join("mosquitto.log")).unwrap_or_default()
        );
    }

    /// `mqtt://127.0.0.1:PORT`, or `mqtts://localhost:PORT` with TLS.
    pub fn url(&self) -> String {
        if self.options.tls {
            format!("mqtts://localhost:{}", self.port)
        } else {
            format!("mqtt://127.0.0.1:{}", self.port)
        }
    }

    /// The generated CA certificate (PEM) that signed the broker's certificate.
    pub fn ca_file(&self) -> PathBuf {
        self.dir.join("ca.pem")
    }

    /// Write `text` to a new file in the broker's directory; its path.
    pub fn file(&self, name: &str, text: &str) -> PathBuf {
        let p = self.dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    /// Kill the broker (SIGKILL: clients see their connection die).
    pub fn stop(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }

    /// Stop it cleanly (SIGTERM, as `systemctl stop` does: with persistence on, it saves its
    /// retained messages and sessions first) and wait for the exit (10 s at most, then
    /// SIGKILL).
    pub fn terminate(&mut self) {
        let Some(mut c) = self.child.take() else {
            return;
        };
        let sent = Command::new("kill")
            .arg("-TERM")
            .arg(c.id().to_string())
            .status()
            .is_ok_and(|s| s.success());
        let deadline = Instant::now() + Duration::from_secs(10);
        while sent && Instant::now() < deadline {
            if let Ok(Some(_)) = c.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = c.kill();
        let _ = c.wait();
        panic!(
            "mosquitto on port {} did not stop within 10 s of SIGTERM: {}",
            self.port,
            std::fs::read_to_string(self.dir.join("mosquitto.log")).unwrap_or_default()
        );
    }

    /// Start it again on the same port.
    pub fn restart(&mut self) {
        self.stop();
        // The port was just closed; binding it again can take a moment.
        let deadline = Instant::now() + Duration::from_secs(5);
        while !self.spawn() {
            assert!(
                Instant::now() < deadline,
                "mosquitto did not restart on port {}: {}",
                self.port,
                std::fs::read_to_string(self.dir.join("mosquitto.log")).unwrap_or_default()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// A test client's options for this broker (credentials and TLS as given).
    pub fn client_options(&self, id: &str, login: Option<(&str, &str)>) -> MqttOptions {
        // The server certificate names localhost.
        let host = if self.options.tls {
            "localhost"
        } else {
            "127.0.0.1"
        };
        let mut o = MqttOptions::new(id, host, self.port);
        o.set_keep_alive(Duration::from_secs(5));
        o.set_max_packet_size(1 << 20, 1 << 20);
        if let Some((u, p)) = login {
            o.set_credentials(u, p);
        }
        if self.options.tls {
            let pem = std::fs::read(self.ca_file()).unwrap();
            let mut roots = rustls::RootCertStore::empty();
            use rustls::pki_types::pem::PemObject as _;
            for c in rustls::pki_types::CertificateDer::pem_slice_iter(&pem) {
                roots.add(c.unwrap()).unwrap();
            }
            let builder = rustls::ClientConfig::builder_with_provider(std::sync::Arc::new(
                rustls::crypto::ring::default_provider(),
            ))
            .with_safe_default_protocol_versions()
            .unwrap()
            .with_root_certificates(roots);
            let config = if self.options.client_certificates {
                use rustls::pki_types::{CertificateDer, PrivateKeyDer};
                let certs = CertificateDer::pem_file_iter(self.dir.join("scada.pem"))
                    .unwrap()
                    .map(Result::unwrap)
                    .collect();
                let key = PrivateKeyDer::from_pem_file(self.dir.join("scada.key")).unwrap();
                builder.with_client_auth_cert(certs, key).unwrap()
            } else {
                builder.with_no_client_auth()
            };
            o.set_transport(rumqttc::Transport::tls_with_config(
                rumqttc::TlsConfiguration::Rustls(std::sync::Arc::new(config)),
            ));
        }
        o
    }

    fn write_files(&self) {
        if !self.options.users.is_empty() {
            let pw = self.dir.join("passwd");
            for (i, (user, pass)) in self.options.users.iter().enumerate() {
                let mut cmd = Command::new(&self.tools.passwd);
                if i == 0 {
                    cmd.arg("-c");
                }
                let out = cmd.arg("-b").arg(&pw).arg(user).arg(pass).output().unwrap();
                assert!(
                    out.status.success(),
                    "mosquitto_passwd: {}",
                    String::from_utf8_lossy(&out.stderr)
                );
            }
        }
        if self.options.tls {
            self.generate_certificates();
        }
    }

    /// A CA (EC P-256) and a server certificate for `localhost` and 127.0.0.1 signed by it.
    fn generate_certificates(&self) {
        let openssl = self.tools.openssl.clone().unwrap();
        let run = |args: &[&str]| {
            let out = Command::new(&openssl)
                .args(args)
                .current_dir(&self.dir)
                .output()
                .unwrap();
            assert!(
                out.status.success(),
                "openssl {args:?}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        };
        let ec = ["-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256"];
        let mut ca = vec!["req", "-x509", "-nodes", "-days", "2"];
        ca.extend(ec);
        ca.extend([
            "-keyout",
            "ca.key",
            "-out",
            "ca.pem",
            "-subj",
            "/CN=drivebus test CA",
            "-addext",
            "basicConstraints=critical,CA:TRUE",
            "-addext",
            "keyUsage=critical,keyCertSign,cRLSign",
        ]);
        run(&ca);
        let mut csr = vec!["req", "-nodes"];
        csr.extend(ec);
        csr.extend([
            "-keyout",
            "server.key",
            "-out",
            "server.csr",
            "-subj",
            "/CN=localhost",
        ]);
        run(&csr);
        std::fs::write(
            self.dir.join("server.ext"),
            "basicConstraints=CA:FALSE\nkeyUsage=critical,digitalSignature\n\
             extendedKeyUsage=serverAuth\nsubjectAltName=DNS:localhost,IP:127.0.0.1\n",
        )
        .unwrap();
        run(&[
            "x509",
            "-req",
            "-in",
            "server.csr",
            "-CA",
            "ca.pem",
            "-CAkey",
            "ca.key",
            "-CAcreateserial",
            "-days",
            "2",
            "-out",
            "server.pem",
            "-extfile",
            "server.ext",
        ]);
        if !self.options.client_certificates {
            return;
        }
        std::fs::write(
            self.dir.join("client.ext"),
            "basicConstraints=CA:FALSE\nkeyUsage=critical,digitalSignature\n\
             extendedKeyUsage=clientAuth\n",
        )
        .unwrap();
        // Another CA, whose client certificate the broker must refuse.
        let mut other = vec!["req", "-x509", "-nodes", "-days", "2"];
        other.extend(ec);
        other.extend([
            "-keyout",
            "other-ca.key",
            "-out",
            "other-ca.pem",
            "-subj",
            "/CN=someone else's CA",
            "-addext",
            "basicConstraints=critical,CA:TRUE",
            "-addext",
            "keyUsage=critical,keyCertSign,cRLSign",
        ]);
        run(&other);
        for (name, ca) in [("gw", "ca"), ("scada", "ca"), ("rogue", "other-ca")] {
            let key = format!("{name}.key");
            let csr = format!("{name}.csr");
            let subj = format!("/CN={name}");
            let mut req = vec!["req", "-nodes"];
            req.extend(ec);
            req.extend(["-keyout", &key, "-out", &csr, "-subj", &subj]);
            run(&req);
            let (ca_pem, ca_key, out) = (
                format!("{ca}.pem"),
                format!("{ca}.key"),
                format!("{name}.pem"),
            );
            run(&[
                "x509",
                "-req",
                "-in",
                &csr,
                "-CA",
                &ca_pem,
                "-CAkey",
                &ca_key,
                "-CAcreateserial",
                "-days",
                "2",
                "-out",
                &out,
                "-extfile",
                "client.ext",
            ]);
        }
    }

    fn write_config(&self) {
        let d = self.dir.display();
        let mut c = String::new();
        c.push_str("# generated by tests/common/mosquitto.rs\n");
        // As root, mosquitto would switch to the `mosquitto` user, who cannot read this
        // directory's files; as another user the option has no effect.
        c.push_str("user root\npersistence false\n");
        c.push_str(&format!("log_dest file {d}/mosquitto.log\nlog_type all\n"));
        c.push_str(&format!("listener {} 127.0.0.1\n", self.port));
        if self.options.users.is_empty() {
            c.push_str("allow_anonymous true\n");
        } else {
            c.push_str(&format!(
                "allow_anonymous false\npassword_file {d}/passwd\n"
            ));
        }
        if self.options.tls {
            c.push_str(&format!(
                "cafile {d}/ca.pem\ncertfile {d}/server.pem\nkeyfile {d}/server.key\n"
            ));
            if self.options.client_certificates {
                c.push_str("require_certificate true\nuse_identity_as_username true\n");
            }
        }
        if !self.extra.is_empty() {
            c.push_str(&self.extra.replace("{dir}", &d.to_string()));
            c.push('\n');
        }
        let mut f = std::fs::File::create(self.dir.join("mosquitto.conf")).unwrap();
        f.write_all(c.as_bytes()).unwrap();
    }

    /// Start the process and wait until it accepts connections; false if it exited.
    fn spawn(&mut self) -> bool {
        let mut child = Command::new(&self.tools.mosquitto)
            .arg("-c")
            .arg(self.dir.join("mosquitto.conf"))
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let deadline = Instant::now() + Duration::from_secs(5);
        loop {
            if let Ok(Some(_)) = child.try_wait() {
                return false;
            }
            if TcpStream::connect((Ipv4Addr::LOCALHOST, self.port)).is_ok() {
                self.child = Some(child);
                return true;
            }
            if Instant::now() > deadline {
                let _ = child.kill();
                let _ = child.wait();
                return false;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

impl Drop for Mosquitto {
    fn drop(&mut self) {
        self.stop();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

fn free_port() -> u16 {
    TcpListener::bind((Ipv4Addr::LOCALHOST, 0))
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// A test MQTT client: what it receives on its subscriptions, and publishing.
#[derive(Debug)]
pub struct TestClient {
    /// The client.
    pub client: AsyncClient,
    rx: mpsc::UnboundedReceiver<Publish>,
    task: tokio::task::JoinHandle<()>,
}

impl TestClient {
    /// Connect with `options` and subscribe to `topics` (QoS 1); waits for the ConnAck and
    /// the SubAcks (5 s at most).
    pub async fn connect(options: MqttOptions, topics: &[&str]) -> TestClient {
        let (client, mut el) = AsyncClient::new(options, 256);
        for t in topics {
            client.subscribe(*t, QoS::AtLeastOnce).await.unwrap();
        }
        let (tx, rx) = mpsc::unbounded_channel();
        let (ready_tx, mut ready_rx) = mpsc::unbounded_channel();
        let want = topics.len();
        let task = tokio::spawn(async move {
            let mut acks = 0;
            loop {
                match el.poll().await {
                    Ok(Event::Incoming(Packet::Publish(p))) => {
                        let _ = tx.send(p);
                    }
                    Ok(Event::Incoming(Packet::SubAck(_))) => {
                        acks += 1;
                        if acks == want {
                            let _ = ready_tx.send(());
                        }
                    }
                    Ok(Event::Incoming(Packet::ConnAck(_))) if want == 0 => {
                        let _ = ready_tx.send(());
                    }
                    Ok(_) => {}
                    Err(_) => tokio::time::sleep(Duration::from_millis(100)).await,
                }
            }
        });
        tokio::time::timeout(Duration::from_secs(5), ready_rx.recv())
            .await
            .expect("the test client connects and subscribes within 5 s");
        TestClient { client, rx, task }
    }

    /// The next message on `topic` within `wait` (others are skipped); `None` if none came.
    pub async fn next_on(&mut self, topic: &str, wait: Duration) -> Option<Publish> {
        let deadline = tokio::time::Instant::now() + wait;
        loop {
            match tokio::time::timeout_at(deadline, self.rx.recv()).await {
                Ok(Some(p)) if p.topic == topic => return Some(p),
                Ok(Some(_)) => {}
                Ok(None) | Err(_) => return None,
            }
        }
    }

    /// The next message on `topic` whose payload satisfies `pred`, within `wait`.
    pub async fn next_where(
        &mut self,
        topic: &str,
        wait: Duration,
        mut pred: impl FnMut(&Publish) -> bool,
    ) -> Option<Publish> {
        let deadline = tokio::time::Instant::now() + wait;
        loop {
            let left = deadline.saturating_duration_since(tokio::time::Instant::now());
            let p = self.next_on(topic, left).await?;
            if pred(&p) {
                return Some(p);
            }
        }
    }

    /// Everything received within `wait`.
    pub async fn collect(&mut self, wait: Duration) -> Vec<Publish> {
        let deadline = tokio::time::Instant::now() + wait;
        let mut all = Vec::new();
        while let Ok(Some(p)) = tokio::time::timeout_at(deadline, self.rx.recv()).await {
            all.push(p);
        }
        all
    }

    /// Publish `payload` on `topic` (QoS 1).
    pub async fn publish(&self, topic: &str, payload: impl Into<Vec<u8>>, retain: bool) {
        self.client
            .publish(topic, QoS::AtLeastOnce, retain, payload.into())
            .await
            .unwrap();
    }
}

impl Drop for TestClient {
    fn drop(&mut self) {
        self.task.abort();
    }
}

/// A message's payload as JSON (panics with the text if it is not).
pub fn json(p: &Publish) -> serde_json::Value {
    serde_json::from_slice(&p.payload).unwrap_or_else(|e| {
        panic!(
            "{}: not JSON ({e}): {:?}",
            p.topic,
            String::from_utf8_lossy(&p.payload)
        )
    })
}
