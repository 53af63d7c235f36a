//! The page's security end to end (issue 20, "Security"): `drivectl gateway` with `[ui]` on
//! simulated buses and no broker. A listener other than loopback without TLS and users does
//! not start; a page with TLS (a self-signed certificate made by `openssl` for the test) and a
//! password file made by `drivectl ui passwd` answers HTTPS only, refuses wrong passwords and
//! then rate-limits them, sets the session cookie with its attributes, refuses a viewer's POST
//! and a POST without the CSRF token, and ends the session at the log-out.

// Test code: helpers outside `#[test]` fns panic by design.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde_json::{Value, json};

#[path = "common/web.rs"]
mod web;

const DRIVECTL: &str = env!("CARGO_BIN_EXE_drivectl");

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// A directory removed at the end.
struct Dir(PathBuf);

impl Dir {
    fn new(name: &str) -> Dir {
        let p = std::env::temp_dir().join(format!("drivebus-uisec-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        Dir(p)
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A child process killed at the end.
struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The example plant on simulated drives without a broker, with `ui` as its `[ui]` table.
fn config(dir: &Dir, ui: &str) -> PathBuf {
    let example = Command::new(DRIVECTL)
        .args(["gateway", "--example-config"])
        .output()
        .unwrap();
    let text = String::from_utf8(example.stdout)
        .unwrap()
        .replacen("broker = \"mqtt://127.0.0.1:1883\"", "broker = \"off\"", 1)
        .replacen("metrics = \"127.0.0.1:9464\"", "metrics = \"off\"", 1);
    let path = dir.0.join("plant.toml");
    std::fs::write(&path, format!("{text}\n[ui]\n{ui}\n")).unwrap();
    path
}

#[test]
fn a_listener_other_than_loopback_without_tls_and_users_does_not_start() {
    let dir = Dir::new("refuse");
    let port = free_port();
    for ui in [
        format!("listen = \"0.0.0.0:{port}\""),
        format!("listen = \"0.0.0.0:{port}\"\nusers = \"/nonexistent/users\""),
    ] {
        let path = config(&dir, &ui);
        let started = Instant::now();
        let o = Command::new(DRIVECTL)
            .args(["gateway", "--simulate", "--config"])
            .arg(&path)
            .stdin(Stdio::null())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{ui}: {err}");
        assert!(
            err.contains("needs TLS and users")
                && err.contains("tls_cert")
                && err.contains("drivectl ui passwd"),
            "{ui}: {err}"
        );
        assert!(
            err.contains("plant.toml:"),
            "names the config's line: {err}"
        );
        assert!(started.elapsed() < Duration::from_secs(20));
        // `--check` says the same.
        let o = Command::new(DRIVECTL)
            .args(["gateway", "--check", "--config"])
            .arg(&path)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2));
        assert!(String::from_utf8_lossy(&o.stderr).contains("needs TLS and users"));
    }
    assert!(
        TcpStream::connect(("127.0.0.1", port)).is_err(),
        "nothing listens"
    );
}

/// A self-signed certificate for 127.0.0.1 and its key, made by `openssl` (`None` where it is
/// missing; a failure under CI).
fn certificate(dir: &Dir) -> Option<(PathBuf, PathBuf)> {
    let (cert, key) = (dir.0.join("page.crt"), dir.0.join("page.key"));
    let o = Command::new("openssl")
        .args([
            "req",
            "-x509",
            "-newkey",
            "ec",
            "-pkeyopt",
            "ec_paramgen_curve:prime256v1",
        ])
        .args(["-nodes", "-days", "1", "-subj", "/CN=drivebus test"])
        .args(["-addext", "subjectAltName=IP:127.0.0.1,DNS:localhost"])
        // A server's certificate, not a CA's (webpki refuses a CA as the server).
        .args(["-addext", "basicConstraints=critical,CA:FALSE"])
        .arg("-keyout")
        .arg(&key)
        .arg("-out")
        .arg(&cert)
        .output();
    match o {
        Ok(o) if o.status.success() => Some((cert, key)),
        other => {
            let ci = std::env::var_os("CI").is_some_and(|v| !v.is_empty());
            assert!(!ci, "openssl makes the test certificate: {other:?}");
            eprintln!("SKIPPED: openssl is not installed");
            None
        }
    }
}

/// `drivectl ui passwd` with the password on standard input.
fn passwd(file: &Path, user: &str, role: &str, password: &str) -> std::process::Output {
    let mut child = Command::new(DRIVECTL)
        .args(["ui", "passwd", "--file"])
        .arg(file)
        .args(["--user", user, "--role", role])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // A refused name is said before the password is read: the command may have exited, and
    // closed its end, before the password is written.
    match child
        .stdin
        .take()
        .unwrap()
        .write_all(format!("{password}\n").as_bytes())
    {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        other => other.unwrap(),
    }
    child.wait_with_output().unwrap()
}

/// A TLS client that trusts only `cert`.
fn tls_client(cert: &Path) -> Arc<rustls::ClientConfig> {
    use rustls::pki_types::CertificateDer;
    use rustls::pki_types::pem::PemObject as _;
    let mut roots = rustls::RootCertStore::empty();
    for c in CertificateDer::pem_file_iter(cert).unwrap() {
        roots.add(c.unwrap()).unwrap();
    }
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    Arc::new(
        rustls::ClientConfig::builder_with_provider(provider)
            .with_safe_default_protocol_versions()
            .unwrap()
            .with_root_certificates(roots)
            .with_no_client_auth(),
    )
}

/// An answer: status, headers (lowercase names), body.
#[derive(Debug)]
struct Answer {
    status: u16,
    headers: Vec<(String, String)>,
    body: String,
}

impl Answer {
    fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    fn json(&self) -> Value {
        serde_json::from_str(&self.body).unwrap_or(Value::Null)
    }
}

/// One HTTPS request on a fresh connection.
fn https(
    tls: &Arc<rustls::ClientConfig>,
    addr: SocketAddr,
    method: &str,
    path: &str,
    headers: &[(&str, &str)],
    body: Option<&Value>,
) -> Answer {
    let tcp = TcpStream::connect(addr).unwrap();
    tcp.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    let name = rustls::pki_types::ServerName::try_from("127.0.0.1").unwrap();
    let conn = rustls::ClientConnection::new(tls.clone(), name).unwrap();
    let mut s = rustls::StreamOwned::new(conn, tcp);
    let body = body.map(Value::to_string).unwrap_or_default();
    let mut head = format!(
        "{method} {path} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nConnection: close\r\nContent-Length: {}\r\n",
        addr.port(),
        body.len()
    );
    if !body.is_empty() {
        head.push_str("Content-Type: application/json\r\n");
    }
    for (k, v) in headers {
        head.push_str(&format!("{k}: {v}\r\n"));
    }
    s.write_all(format!("{head}\r\n{body}").as_bytes()).unwrap();
    let mut got = Vec::new();
    // A peer that closes without close_notify ends the read with an error after the data.
    let _ = s.read_to_end(&mut got);
    let text = String::from_utf8_lossy(&got).into_owned();
    let (head, body) = text.split_once("\r\n\r\n").unwrap_or((&text, ""));
    let mut lines = head.lines();
    let status = lines
        .next()
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    let headers = lines
        .filter_map(|l| l.split_once(':'))
        .map(|(k, v)| (k.trim().to_ascii_lowercase(), v.trim().to_owned()))
        .collect();
    Answer {
        status,
        headers,
        body: body.to_owned(),
    }
}

#[test]
fn the_page_over_https_with_users_sessions_csrf_and_roles() {
    let dir = Dir::new("https");
    let Some((cert, key)) = certificate(&dir) else {
        return;
    };
    let users = dir.0.join("page.users");
    for (user, role, password) in [
        ("anna", "operator", "anna's secret"),
        ("bert", "viewer", "bert's secret"),
        ("olga", "operator", "first"),
        // Replaced: olga's password is `olga's secret` from here on.
        ("olga", "operator", "olga's secret"),
    ] {
        let o = passwd(&users, user, role, password);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let text = std::fs::read_to_string(&users).unwrap();
    assert_eq!(
        text.lines().filter(|l| l.starts_with("olga:")).count(),
        1,
        "{text}"
    );
    assert!(text.contains("bert:viewer:$argon2id$"), "{text}");
    {
        use std::os::unix::fs::PermissionsExt as _;
        let mode = std::fs::metadata(&users).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o600);
    }
    // A bad name or an empty password changes nothing.
    let o = passwd(&users, "a:b", "viewer", "x");
    assert_eq!(o.status.code(), Some(2));
    let o = passwd(&users, "carl", "viewer", "");
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(std::fs::read_to_string(&users).unwrap(), text);

    let port = free_port();
    let plant = config(
        &dir,
        &format!(
            "listen = \"127.0.0.1:{port}\"\ntls_cert = {:?}\ntls_key = {:?}\nusers = {:?}",
            cert.display().to_string(),
            key.display().to_string(),
            users.display().to_string()
        ),
    );
    let child = Command::new(DRIVECTL)
        .args(["gateway", "--simulate", "--config"])
        .arg(&plant)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let _gateway = Killed(child);
    let addr: SocketAddr = ([127, 0, 0, 1], port).into();
    let until = Instant::now() + Duration::from_secs(30);
    while TcpStream::connect(addr).is_err() {
        assert!(Instant::now() < until, "the page did not come up");
        std::thread::sleep(Duration::from_millis(50));
    }
    let tls = tls_client(&cert);

    // A client that connects and says nothing holds up no one.
    let _silent = TcpStream::connect(addr).unwrap();
    let started = Instant::now();
    let s = https(&tls, addr, "GET", "/api/session", &[], None);
    assert!(started.elapsed() < Duration::from_secs(5));
    assert_eq!(s.status, 200, "{s:?}");
    assert_eq!(
        s.json(),
        json!({"login_required": true, "user": null, "role": null, "csrf": null})
    );
    assert_eq!(https(&tls, addr, "GET", "/", &[], None).status, 200);
    assert_eq!(https(&tls, addr, "GET", "/login.js", &[], None).status, 200);

    // Plain HTTP gets no page.
    let mut plain = TcpStream::connect(addr).unwrap();
    plain
        .set_read_timeout(Some(Duration::from_secs(15)))
        .unwrap();
    plain
        .write_all(b"GET /api/plant HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n")
        .unwrap();
    let mut got = Vec::new();
    let _ = plain.read_to_end(&mut got);
    assert!(
        !String::from_utf8_lossy(&got).contains("HTTP/1.1"),
        "{got:?}"
    );

    // Without a session: 401.
    let r = https(&tls, addr, "GET", "/api/plant", &[], None);
    assert_eq!((r.status, &r.json()["error"]), (401, &json!("login")));

    // A wrong password, then too many.
    let wrong = json!({"user": "anna", "password": "guess"});
    for _ in 0..5 {
        let r = https(&tls, addr, "POST", "/api/login", &[], Some(&wrong));
        assert_eq!(r.status, 401, "{r:?}");
        assert_eq!(r.json()["message"], "wrong user name or password");
        assert!(r.header("set-cookie").is_none());
    }
    let right = json!({"user": "anna", "password": "anna's secret"});
    let r = https(&tls, addr, "POST", "/api/login", &[], Some(&right));
    assert_eq!(r.status, 429, "{r:?}");
    let after: u64 = r.header("retry-after").unwrap().parse().unwrap();
    assert!((1..=15).contains(&after), "{after}");
    assert_eq!(r.json()["error"], "rate");

    // A viewer: the cookie with its attributes; reads, but a POST is refused for its role.
    let login = json!({"user": "bert", "password": "bert's secret"});
    let r = https(&tls, addr, "POST", "/api/login", &[], Some(&login));
    assert_eq!(r.status, 200, "{r:?}");
    let cookie = r.header("set-cookie").unwrap().to_owned();
    let mut attrs = cookie.split("; ");
    let pair = attrs.next().unwrap().to_owned();
    assert!(
        pair.starts_with("drivebus_session=") && pair.len() >= 17 + 32,
        "{cookie}"
    );
    assert_eq!(
        attrs.collect::<Vec<_>>(),
        ["HttpOnly", "Secure", "SameSite=Strict", "Path=/"]
    );
    let csrf = r.json()["csrf"].as_str().unwrap().to_owned();
    assert_eq!(r.json()["role"], "viewer");
    let r = https(&tls, addr, "GET", "/api/plant", &[("Cookie", &pair)], None);
    assert_eq!(r.status, 200);
    assert!(r.json()["buses"].is_array());
    let write = json!({"value": "1"});
    let r = https(
        &tls,
        addr,
        "POST",
        "/api/drive/0/0/write",
        &[("Cookie", &pair), ("X-CSRF-Token", &csrf)],
        Some(&write),
    );
    assert_eq!(
        (r.status, &r.json()["error"]),
        (403, &json!("role")),
        "{r:?}"
    );

    // An operator: a POST without the token is refused; with it, it passes the guard.
    let login = json!({"user": "olga", "password": "olga's secret"});
    let r = https(&tls, addr, "POST", "/api/login", &[], Some(&login));
    assert_eq!(r.status, 200, "{r:?}");
    let olga = r
        .header("set-cookie")
        .unwrap()
        .split(';')
        .next()
        .unwrap()
        .to_owned();
    let olga_csrf = r.json()["csrf"].as_str().unwrap().to_owned();
    let r = https(
        &tls,
        addr,
        "POST",
        "/api/drive/0/0/write",
        &[("Cookie", &olga)],
        Some(&write),
    );
    assert_eq!(
        (r.status, &r.json()["error"]),
        (403, &json!("csrf")),
        "{r:?}"
    );
    let r = https(
        &tls,
        addr,
        "POST",
        "/api/drive/0/0/write",
        &[("Cookie", &olga), ("X-CSRF-Token", &csrf)],
        Some(&write),
    );
    assert_eq!(r.json()["error"], "csrf", "another session's token: {r:?}");
    let r = https(
        &tls,
        addr,
        "POST",
        "/api/drive/0/0/write",
        &[("Cookie", &olga), ("X-CSRF-Token", &olga_csrf)],
        Some(&write),
    );
    assert_ne!(r.status, 403, "{r:?}");
    assert_ne!(r.status, 401, "{r:?}");

    // The log-out ends the session.
    let r = https(
        &tls,
        addr,
        "POST",
        "/api/logout",
        &[("Cookie", &pair), ("X-CSRF-Token", &csrf)],
        None,
    );
    assert_eq!(r.status, 200, "{r:?}");
    assert!(r.header("set-cookie").unwrap().contains("Max-Age=0"));
    let r = https(&tls, addr, "GET", "/api/plant", &[("Cookie", &pair)], None);
    assert_eq!(r.status, 401);
    // Olga's session goes on.
    let r = https(
        &tls,
        addr,
        "GET",
        "/api/session",
        &[("Cookie", &olga)],
        None,
    );
    assert_eq!(r.json()["user"], "olga");
}

/// In a real browser (headless Chromium, trusting the test's certificate): a viewer logs in
/// through the form, sees the drive view without an editor or a restore, and a write sent from
/// the page all the same is refused for the role; an operator's page has the editor.
#[test]
fn a_viewer_in_the_browser_reads_but_cannot_write() {
    let Some((chromium, chromedriver)) = web::browser_tools() else {
        return;
    };
    let dir = Dir::new("viewer");
    let Some((cert, key)) = certificate(&dir) else {
        return;
    };
    let users = dir.0.join("page.users");
    for (user, role, password) in [
        ("bert", "viewer", "bert's secret"),
        ("anna", "operator", "anna's secret"),
    ] {
        let o = passwd(&users, user, role, password);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let port = free_port();
    let plant = config(
        &dir,
        &format!(
            "listen = \"127.0.0.1:{port}\"\ntls_cert = {:?}\ntls_key = {:?}\nusers = {:?}",
            cert.display().to_string(),
            key.display().to_string(),
            users.display().to_string()
        ),
    );
    let child = Command::new(DRIVECTL)
        .args(["gateway", "--simulate", "--config"])
        .arg(&plant)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let _gateway = Killed(child);
    let addr: SocketAddr = ([127, 0, 0, 1], port).into();
    let until = Instant::now() + Duration::from_secs(30);
    while TcpStream::connect(addr).is_err() {
        assert!(Instant::now() < until, "the page did not come up");
        std::thread::sleep(Duration::from_millis(50));
    }
    for (user, password, role) in [
        ("bert", "bert's secret", "viewer"),
        ("anna", "anna's secret", "operator"),
    ] {
        let s = web::Session::start_with(
            &chromium,
            &chromedriver,
            1280,
            900,
            &["--ignore-certificate-errors"],
        );
        s.open(&format!("https://127.0.0.1:{port}/"));
        s.wait_for(20, "return !!document.getElementById('login-user') && !document.getElementById('login').hidden;", |v| v == &json!(true));
        s.run(&format!(
            "document.getElementById('login-user').value = {user:?}; \
             document.getElementById('login-password').value = {password:?}; \
             document.getElementById('login-submit').click();"
        ));
        let who = s.wait_for(
            20,
            "const w = document.getElementById('who'); return w ? w.textContent : '';",
            |v| v.as_str().is_some_and(|t| t.contains(user)),
        );
        assert!(who.as_str().unwrap().contains(role), "{who}");
        s.run("location.hash = '#drive/0/0';");
        s.wait_for(
            30,
            "return document.querySelectorAll('table.params tr').length;",
            |v| v.as_u64().is_some_and(|n| n > 100),
        );
        let editors = s.run("return [document.querySelectorAll('td.edit input').length, !!document.getElementById('restore-file')];");
        let write = s.run(
            "return post('/api/drive/0/0/check', {}).then(() => \
               fetch('/api/drive/0/0/write', {method: 'POST', headers: {'Content-Type': 'application/json', \
                 'X-CSRF-Token': csrfToken}, body: JSON.stringify({key: '8470.0', value: '2.5'})}))\
             .then(async r => [r.status, await r.text()]);",
        );
        if role == "viewer" {
            assert_eq!(
                editors,
                json!([0, false]),
                "a viewer's page offers no editor, no restore"
            );
            assert_eq!(write[0], json!(403), "{write}");
            assert!(write[1].as_str().unwrap().contains("role"), "{write}");
            s.screenshot("viewer-drive");
        } else {
            assert!(editors[0].as_u64().unwrap() > 100, "{editors}");
            assert_eq!(editors[1], json!(true));
            assert_eq!(write[0], json!(200), "{write}");
            assert!(
                write[1]
                    .as_str()
                    .unwrap()
                    .contains("\"outcome\":\"written\""),
                "{write}"
            );
        }
    }
}
