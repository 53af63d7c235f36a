//! The broker connection's options, built once before anything opens: the broker URL, the
//! user and the password file, TLS (rustls on the ring provider, server verification against
//! `ca_file` or the system's roots, client certificates), the last-will. The gateway speaks
//! MQTT 5, so that it can tell the broker the largest packet it takes (below).

use std::sync::Arc;
use std::time::Duration;

use rumqttc::v5::MqttOptions;
use rumqttc::v5::mqttbytes::QoS;
use rumqttc::v5::mqttbytes::v5::LastWill;
use rumqttc::{TlsConfiguration, Transport};
use rustls::pki_types::pem::PemObject as _;
use rustls::pki_types::{CertificateDer, PrivateKeyDer};

use super::super::config::Gateway;
use crate::error::{Error, Result};

/// The largest password, certificate or key file read (a PEM bundle of the system's roots is
/// about 200 KiB).
const FILE_LIMIT: u64 = 4 << 20;

/// The largest MQTT packet taken from the broker, far above the 4 KiB a `set` may carry. The
/// gateway announces it in its CONNECT (MQTT 5 Maximum Packet Size), and the broker then never
/// sends it a larger packet: it drops such a message for this client as if delivered (MQTT 5,
/// 3.1.2.11.4). Under MQTT 3.1.1 there is no such property, and a larger packet (a retained
/// message on a `set` topic) ended the connection at every reconnection, twice a second for
/// ever.
pub const MAX_INCOMING_PACKET: u32 = 1 << 20;

/// The broker's address as the URL gives it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BrokerUrl {
    /// `mqtts://`.
    pub tls: bool,
    /// The user before `@`.
    pub user: Option<String>,
    /// Host name or address (an IPv6 address keeps its brackets).
    pub host: String,
    /// Port (1883, or 8883 with TLS, when the URL gives none).
    pub port: u16,
}

/// Parse `mqtt://host[:port]` or `mqtts://[user@]host[:port]`.
pub fn parse_url(url: &str) -> std::result::Result<BrokerUrl, String> {
    let url = url.trim();
    let bad = || format!("broker {url:?}: give mqtt://host:port or mqtts://[user@]host:port");
    let (tls, rest) = if let Some(r) = url.strip_prefix("mqtts://") {
        (true, r)
    } else if let Some(r) = url.strip_prefix("mqtt://") {
        (false, r)
    } else {
        return Err(bad());
    };
    let rest = rest.trim_end_matches('/');
    let (user, host_port) = match rest.rsplit_once('@') {
        Some((u, hp)) => {
            if u.is_empty() || u.contains(':') {
                return Err(format!(
                    "broker {url:?}: give the user as user@host (the password goes in \
                     password_file, never in the URL)"
                ));
            }
            (Some(u.to_owned()), hp)
        }
        None => (None, rest),
    };
    let default_port = if tls { 8883 } else { 1883 };
    // `[v6]:port`, `[v6]`, `host:port`, `host`.
    let (host, port) = if host_port.starts_with('[') {
        match host_port.split_once(']') {
            Some((h, "")) => (format!("{h}]"), None),
            Some((h, p)) => (format!("{h}]"), Some(p.strip_prefix(':').ok_or_else(bad)?)),
            None => return Err(bad()),
        }
    } else {
        match host_port.rsplit_once(':') {
            Some((h, p)) => (h.to_owned(), Some(p)),
            None => (host_port.to_owned(), None),
        }
    };
    if host.is_empty() || host == "[]" || host.contains('/') {
        return Err(bad());
    }
    let port = match port {
        None => default_port,
        Some(p) => match p.parse::<u16>() {
            Ok(n) if n != 0 => n,
            _ => return Err(format!("broker {url:?}: port {p:?}: give 1–65535")),
        },
    };
    Ok(BrokerUrl {
        tls,
        user,
        host,
        port,
    })
}

/// A small file read whole (a regular file, at most [`FILE_LIMIT`] bytes); `what` names the
/// `[gateway]` key.
fn read_file(path: &str, what: &str) -> Result<Vec<u8>> {
    crate::config::read_small_file(path, &format!("[gateway] {what}"), FILE_LIMIT)
}

/// The password in `path`: its first line, without a byte-order mark or CR LF. An empty
/// password is refused (a file saved empty by mistake would log in as nobody knows whom).
pub fn read_password(path: &str) -> Result<String> {
    let bytes = read_file(path, "password_file")?;
    let text = String::from_utf8(bytes).map_err(|_| {
        Error::config(format!(
            "[gateway] password_file = {path:?}: not UTF-8 text; write the password on its \
             first line"
        ))
    })?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let line = text.split('\n').next().unwrap_or("");
    let line = line.strip_suffix('\r').unwrap_or(line);
    if line.is_empty() {
        return Err(Error::config(format!(
            "[gateway] password_file = {path:?}: the first line is empty; write the password \
             on it"
        )));
    }
    Ok(line.to_owned())
}

fn certificates(path: &str, what: &str) -> Result<Vec<CertificateDer<'static>>> {
    let pem = read_file(path, what)?;
    let certs = CertificateDer::pem_slice_iter(&pem)
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(|e| {
            Error::config(format!(
                "[gateway] {what} = {path:?}: not a PEM certificate file ({e})"
            ))
        })?;
    if certs.is_empty() {
        return Err(Error::config(format!(
            "[gateway] {what} = {path:?}: no certificate in it; give a PEM file with \
             -----BEGIN CERTIFICATE-----"
        )));
    }
    Ok(certs)
}

/// The rustls client configuration: server verification against `ca_file` (or the system's
/// roots), a client certificate when configured.
fn tls_config(g: &Gateway) -> Result<rustls::ClientConfig> {
    let mut roots = rustls::RootCertStore::empty();
    match &g.ca_file {
        Some(path) => {
            for c in certificates(path, "ca_file")? {
                roots.add(c).map_err(|e| {
                    Error::config(format!(
                        "[gateway] ca_file = {path:?}: a certificate in it is not a usable CA \
                         ({e})"
                    ))
                })?;
            }
        }
        None => {
            let found = rustls_native_certs::load_native_certs();
            for c in found.certs {
                // A system root rustls cannot parse is skipped, as browsers do.
                let _ = roots.add(c);
            }
            if roots.is_empty() {
                return Err(Error::config(format!(
                    "mqtts: no CA certificates found on this system{}; give [gateway] ca_file \
                     (the PEM of the CA that signed the broker's certificate) or install the \
                     ca-certificates package",
                    found
                        .errors
                        .first()
                        .map(|e| format!(" ({e})"))
                        .unwrap_or_default()
                )));
            }
        }
    }
    let builder = rustls::ClientConfig::builder_with_provider(Arc::new(
        rustls::crypto::ring::default_provider(),
    ))
    .with_safe_default_protocol_versions()
    .map_err(|e| Error::failed(format!("TLS set-up: {e}")))?
    .with_root_certificates(roots);
    match &g.client_cert {
        None => Ok(builder.with_no_client_auth()),
        Some((cert, key)) => {
            let chain = certificates(cert, "client_cert")?;
            let key_pem = read_file(key, "client_key")?;
            let key_der = PrivateKeyDer::from_pem_slice(&key_pem).map_err(|e| {
                Error::config(format!(
                    "[gateway] client_key = {key:?}: no PEM private key in it ({e})"
                ))
            })?;
            builder.with_client_auth_cert(chain, key_der).map_err(|e| {
                Error::config(format!(
                    "[gateway] client_cert = {cert:?} and client_key = {key:?} do not go \
                     together: {e}"
                ))
            })
        }
    }
}

/// The `reason` of the last will's `offline`.
pub const LOST: &str = "connection lost";

/// What the broker connections depend on, as one number: the `[gateway]` keys that make a
/// connection (broker, client id, user, keep-alive, the topic prefix and name of the last
/// will) and the contents of its files (password, CA, client certificate and key), read now.
/// A reload that changes it connects again; one that keeps it keeps the connection.
pub fn fingerprint(g: &Gateway, extra: &str) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    (
        &g.broker,
        &g.client_id,
        &g.username,
        &g.password_file,
        &g.ca_file,
        &g.client_cert,
        g.keep_alive,
        &g.prefix,
        &g.name,
        extra,
    )
        .hash(&mut h);
    let files = [
        g.password_file.as_deref(),
        g.ca_file.as_deref(),
        g.client_cert.as_ref().map(|c| c.0.as_str()),
        g.client_cert.as_ref().map(|c| c.1.as_str()),
    ];
    for f in files.into_iter().flatten() {
        match read_file(f, "file") {
            Ok(bytes) => bytes.hash(&mut h),
            Err(e) => e.to_string().hash(&mut h),
        }
    }
    h.finish()
}

/// The topic of the gateway's own status.
pub fn gateway_status_topic(g: &Gateway) -> String {
    format!("{}/{}/status", g.prefix, g.name)
}

/// What a connection to the broker needs, read now: a missing or bad file is an error here.
struct Resolved {
    url: BrokerUrl,
    credentials: Option<(String, String)>,
    tls: Option<rustls::ClientConfig>,
}

fn resolve(g: &Gateway) -> Result<Resolved> {
    let url = parse_url(&g.broker).map_err(|e| Error::config(format!("[gateway] {e}")))?;
    if !url.tls && (g.ca_file.is_some() || g.client_cert.is_some()) {
        return Err(Error::config(format!(
            "[gateway] ca_file and client_cert are for TLS: the broker {:?} is mqtt://; use \
             mqtts://",
            g.broker
        )));
    }
    let user = url.user.clone().or_else(|| g.username.clone());
    let password = g.password_file.as_deref().map(read_password).transpose()?;
    if password.is_some() && user.is_none() {
        return Err(Error::config(
            "[gateway] password_file without a user: give username, or user@ in the broker URL",
        ));
    }
    let tls = if url.tls { Some(tls_config(g)?) } else { None };
    Ok(Resolved {
        credentials: user.map(|u| (u, password.unwrap_or_default())),
        url,
        tls,
    })
}

/// MQTT carries the keep-alive in 16 bits of seconds: a longer one would be cut.
fn keep_alive(g: &Gateway) -> Duration {
    g.keep_alive.clamp(
        Duration::from_secs(1),
        Duration::from_secs(u64::from(u16::MAX)),
    )
}

/// The JSON connection's options (MQTT 5): everything read now, a missing or bad file is an
/// error here.
pub fn options(g: &Gateway) -> Result<(MqttOptions, BrokerUrl)> {
    let r = resolve(g)?;
    let mut o = MqttOptions::new(g.client_id.clone(), r.url.host.clone(), r.url.port);
    o.set_keep_alive(keep_alive(g));
    // A clean start and a session that ends with the connection (expiry 0, the default):
    // nothing is kept at the broker across connections, as 3.1.1's clean session.
    o.set_clean_start(true);
    o.set_max_packet_size(Some(MAX_INCOMING_PACKET));
    o.set_last_will(LastWill::new(
        gateway_status_topic(g),
        super::payload::gateway_offline(LOST, None),
        QoS::AtLeastOnce,
        true,
        None,
    ));
    if let Some((u, p)) = r.credentials {
        o.set_credentials(u, p);
    }
    if let Some(config) = r.tls {
        o.set_transport(Transport::tls_with_config(TlsConfiguration::Rustls(
            Arc::new(config),
        )));
    }
    Ok((o, r.url))
}

/// The largest packet the Sparkplug connection takes. MQTT 3.1.1 cannot tell the broker (the
/// JSON connection's MQTT 5 can), so a larger one ends the connection; this is far above any
/// command or STATE message, and a retained command is cleared when it arrives.
pub const MAX_INCOMING_PACKET_V4: usize = 16 << 20;

/// The Sparkplug connection's options (MQTT 3.1.1: an edge node publishes its NDEATH before
/// a DISCONNECT, which MQTT 5 would have to send with the reason code "disconnect with will
/// message", and rumqttc's MQTT 5 client sends only a normal disconnection). The will is set
/// for each connection by the Sparkplug task (its `bdSeq`).
pub fn options_v4(g: &Gateway, client_id: &str) -> Result<rumqttc::MqttOptions> {
    let r = resolve(g)?;
    let mut o = rumqttc::MqttOptions::new(client_id, r.url.host.clone(), r.url.port);
    o.set_keep_alive(keep_alive(g));
    // Sparkplug: a clean session at every connection.
    o.set_clean_session(true);
    o.set_max_packet_size(MAX_INCOMING_PACKET_V4, MAX_INCOMING_PACKET_V4);
    if let Some((u, p)) = r.credentials {
        o.set_credentials(u, p);
    }
    if let Some(config) = r.tls {
        o.set_transport(Transport::tls_with_config(TlsConfiguration::Rustls(
            Arc::new(config),
        )));
    }
    Ok(o)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn urls() {
        let u = parse_url("mqtts://gw1@broker.plant.local").unwrap();
        assert_eq!(
            u,
            BrokerUrl {
                tls: true,
                user: Some("gw1".into()),
                host: "broker.plant.local".into(),
                port: 8883
            }
        );
        let u = parse_url("mqtt://10.0.0.5:1884/").unwrap();
        assert_eq!(
            (u.tls, u.user, u.host.as_str(), u.port),
            (false, None, "10.0.0.5", 1884)
        );
        assert_eq!(parse_url("mqtt://h").unwrap().port, 1883);
        let u = parse_url("mqtt://[::1]:1999").unwrap();
        assert_eq!((u.host.as_str(), u.port), ("[::1]", 1999));
        assert_eq!(parse_url("mqtts://[::1]").unwrap().port, 8883);
        for bad in [
            "http://h",
            "mqtt://",
            "mqtt://h:0",
            "mqtt://h:99999",
            "mqtt://h:x",
            "mqtts://u:pw@h",
            "mqtt://@h",
            "mqtt://[::1",
            "mqtt://[::1]x",
            "mqtt://h/x",
        ] {
            assert!(parse_url(bad).is_err(), "{bad}");
        }
        assert!(
            parse_url("mqtts://u:pw@h")
                .unwrap_err()
                .contains("password_file")
        );
    }

    fn temp(name: &str, bytes: &[u8]) -> String {
        let dir = std::env::temp_dir().join(format!("drivebus-mqtt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p.display().to_string()
    }

    #[test]
    fn password_file_first_line_without_bom_and_cr() {
        assert_eq!(read_password(&temp("pw1", b"s3cret\n")).unwrap(), "s3cret");
        assert_eq!(
            read_password(&temp("pw2", "\u{feff}s3 cret\r\nsecond\r\n".as_bytes())).unwrap(),
            "s3 cret"
        );
        assert_eq!(read_password(&temp("pw3", b"nonl")).unwrap(), "nonl");
        for (name, bytes) in [("pw4", &b""[..]), ("pw5", b"\r\nx"), ("pw6", b"\xff\xfe")] {
            let p = temp(name, bytes);
            let e = read_password(&p).unwrap_err().to_string();
            assert!(e.contains(&p) && e.contains("password_file"), "{e}");
        }
        for p in ["/dev/null", "/nonexistent/pw", "/tmp"] {
            let e = read_password(p).unwrap_err().to_string();
            assert!(e.contains(p) && e.contains("regular file"), "{e}");
        }
    }

    fn gateway(broker: &str, extra: &str) -> Gateway {
        let text = format!(
            "[gateway]\nname = \"gw\"\nbroker = \"{broker}\"\n{extra}\n[[bus]]\nname = \"b\"\n\
             protocol = \"movilink\"\nsimulate = true\n[[bus.drive]]\nname = \"d\"\naddress = 1\n\
             [[bus.drive.param]]\nparam = \"P130\"\nperiod = \"1s\"\n"
        );
        crate::config::Plant::parse(&text, "test").unwrap().gateway
    }

    #[test]
    fn file_errors_name_the_file_and_key() {
        let e = options(&gateway("mqtts://h", "ca_file = \"/nonexistent/ca.pem\""))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("ca_file") && e.contains("/nonexistent/ca.pem"),
            "{e}"
        );
        let not_pem = temp("notpem", b"hello\n");
        let e = options(&gateway("mqtts://h", &format!("ca_file = \"{not_pem}\"")))
            .unwrap_err()
            .to_string();
        assert!(e.contains("ca_file") && e.contains("no certificate"), "{e}");
        let e = options(&gateway("mqtt://h", &format!("ca_file = \"{not_pem}\"")))
            .unwrap_err()
            .to_string();
        assert!(e.contains("mqtts://"), "{e}");
        let pw = temp("pw7", b"x\n");
        let e = options(&gateway("mqtt://h", &format!("password_file = \"{pw}\"")))
            .unwrap_err()
            .to_string();
        assert!(e.contains("username"), "{e}");
        let (o, _) = options(&gateway(
            "mqtt://u@h:1",
            &format!("password_file = \"{pw}\""),
        ))
        .unwrap();
        let login = o.credentials().unwrap();
        assert_eq!(
            (login.username.as_str(), login.password.as_str()),
            ("u", "x")
        );
        let will = o.last_will().unwrap();
        assert_eq!(will.topic, "drivebus/gw/status");
        assert_eq!(
            &will.message[..],
            br#"{"reason":"connection lost","state":"offline"}"#
        );
        assert!(will.retain && will.qos == QoS::AtLeastOnce);
        assert!(o.clean_start());
        assert_eq!(o.max_packet_size(), Some(MAX_INCOMING_PACKET));
        assert_eq!(o.keep_alive(), Duration::from_secs(30));
        // Longer than MQTT's 16 bits of seconds: the longest there is, not a cut value.
        let (o, _) = options(&gateway("mqtt://h", "keep_alive = \"24h\"")).unwrap();
        assert_eq!(o.keep_alive(), Duration::from_secs(65535));
    }
}
