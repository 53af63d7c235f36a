//! The password file, hashing, sessions, CSRF, roles and the rate limit, through a router with
//! a test-only POST route behind [`guard`].

use axum::Extension;
use axum::body::Body;
use tower::ServiceExt as _;

use super::*;

/// A cheap argon2id hash for tests that parse files (the real one is made where it is checked).
const PHC: &str = "$argon2id$v=19$m=19456,t=2,p=1$c2FsdHNhbHRzYWx0c2FsdA$ZBmCmbXC0dmBZBz+mJa8u7+3drnJy6sv0H4GDjdGl7A";

#[test]
fn a_password_file_is_read_with_comments_blank_lines_a_bom_and_crlf() {
    let text = format!(
        "# the page's users\n\nanna:operator:{PHC}\n  # indented comment\nbert:viewer:{PHC}\n"
    );
    let u = Users::parse(&text).unwrap();
    let names: Vec<_> = u.list().iter().map(|u| (u.name.as_str(), u.role)).collect();
    assert_eq!(names, [("anna", Role::Operator), ("bert", Role::Viewer)]);
    assert_eq!(u.get("anna").unwrap().phc, PHC);
    // Notepad: a byte-order mark and CR LF.
    let notepad = format!("\u{feff}# users\r\nanna:operator:{PHC}\r\n\r\nbert:viewer:{PHC}\r\n");
    assert_eq!(Users::parse(&notepad).unwrap(), u);
    assert_eq!(Users::parse_bytes(notepad.as_bytes()).unwrap(), u);
    assert_eq!(
        Users::parse_bytes(b"\xff\xfe").unwrap_err(),
        UsersError::NotText
    );
}

#[test]
fn a_bad_line_of_the_password_file_is_named() {
    let line_of = |text: &str| match Users::parse(text) {
        Err(UsersError::Line { line, problem }) => (line, problem),
        other => panic!("{text:?}: {other:?}"),
    };
    let ok = format!("anna:operator:{PHC}\n");
    for (bad, want) in [
        ("anna\n".to_owned(), "name:role:hash"),
        ("anna:operator\n".to_owned(), "name:role:hash"),
        (format!("anna:admin:{PHC}\n"), "role \"admin\""),
        ("anna:viewer:secret\n".to_owned(), "not a PHC string"),
        (
            "anna:viewer:$argon2i$v=19$m=19456,t=2,p=1$c2FsdHNhbHRzYWx0c2FsdA$ZBmCmbXC0dmBZBz+mJa8u7+3drnJy6sv0H4GDjdGl7A\n".to_owned(),
            "not argon2id",
        ),
        (
            "anna:viewer:$argon2id$v=19$m=4000000,t=2,p=1$c2FsdHNhbHRzYWx0c2FsdA$ZBmCmbXC0dmBZBz+mJa8u7+3drnJy6sv0H4GDjdGl7A\n".to_owned(),
            "at most m=",
        ),
        (format!(" :viewer:{PHC}\n"), "user name"),
        (format!("anna:operator:{PHC}\n"), "named twice"),
    ] {
        let (line, problem) = line_of(&format!("{ok}# comment\n{bad}"));
        assert_eq!(line, 3, "{bad:?}: {problem}");
        assert!(problem.contains(want), "{bad:?}: {problem}");
    }
}

#[test]
fn user_names_are_checked() {
    for ok in ["anna", "Anna Müller", "op-1", &"x".repeat(64)] {
        assert!(check_user_name(ok).is_ok(), "{ok}");
    }
    for bad in [
        "",
        "a:b",
        "a\tb",
        "a\nb",
        " anna",
        "anna ",
        "#anna",
        &"x".repeat(65),
    ] {
        assert!(check_user_name(bad).is_err(), "{bad:?}");
    }
}

#[test]
fn a_user_is_added_or_replaced_and_every_other_line_kept() {
    let h1 = hash_password("first").unwrap();
    let new = set_user("", "anna", Role::Operator, &h1).unwrap();
    assert!(new.starts_with("# drivebus page users"), "{new}");
    assert!(new.ends_with(&format!("\nanna:operator:{h1}\n")), "{new}");
    let with_bert = set_user(&format!("{new}# bert is new\n"), "bert", Role::Viewer, PHC).unwrap();
    let u = Users::parse(&with_bert).unwrap();
    assert_eq!(u.list().len(), 2);
    // Replaced in place: the comment stays, the order stays, anna's new hash and role.
    let h2 = hash_password("second").unwrap();
    let replaced = set_user(&with_bert, "anna", Role::Viewer, &h2).unwrap();
    assert_eq!(replaced.lines().count(), with_bert.lines().count());
    assert!(replaced.contains("# bert is new\n"));
    let u = Users::parse(&replaced).unwrap();
    assert_eq!(u.list()[0].name, "anna");
    assert_eq!(u.get("anna").unwrap().role, Role::Viewer);
    assert!(verify_password(&u.get("anna").unwrap().phc, "second"));
    assert!(!verify_password(&u.get("anna").unwrap().phc, "first"));
    // A Notepad file stays one: BOM and CR LF kept.
    let notepad = format!("\u{feff}# users\r\nbert:viewer:{PHC}\r\n");
    let out = set_user(&notepad, "anna", Role::Operator, PHC).unwrap();
    assert_eq!(
        out,
        format!("\u{feff}# users\r\nbert:viewer:{PHC}\r\nanna:operator:{PHC}\r\n")
    );
    // A broken file or a bad name changes nothing.
    assert!(matches!(
        set_user("garbage\n", "anna", Role::Viewer, PHC),
        Err(UsersError::Line { line: 1, .. })
    ));
    assert!(matches!(
        set_user("", "a:b", Role::Viewer, PHC),
        Err(UsersError::BadName(_))
    ));
}

#[test]
fn argon2_hashes_verify_the_right_password_only_with_a_random_salt() {
    let a = hash_password("correct horse").unwrap();
    let b = hash_password("correct horse").unwrap();
    assert!(a.starts_with("$argon2id$v=19$m=19456,t=2,p=1$"), "{a}");
    assert_ne!(a, b, "each hash has its own salt");
    assert!(verify_password(&a, "correct horse"));
    assert!(verify_password(&b, "correct horse"));
    assert!(!verify_password(&a, "correct horse "));
    assert!(!verify_password("not a hash", "correct horse"));
    assert!(Users::parse(&format!("anna:operator:{a}\n")).is_ok());
    assert_eq!(hash_password(""), Err(UsersError::BadPassword));
}

#[tokio::test(start_paused = true)]
async fn log_ins_are_limited_per_address_and_per_user_name() {
    let mut l = Limiter::default();
    let a: IpAddr = [127, 0, 0, 1].into();
    let b: IpAddr = [127, 0, 0, 2].into();
    let t0 = Instant::now();
    for _ in 0..USER_BURST {
        l.attempt(a, "anna", t0).unwrap();
    }
    // The user's burst is spent: from any address.
    let wait = l.attempt(b, "anna", t0).unwrap_err();
    assert_eq!(wait, USER_EVERY);
    // Another name from the same address still goes, until the address's burst is spent.
    for i in USER_BURST..ADDR_BURST {
        l.attempt(a, &format!("guess{i}"), t0).unwrap();
    }
    assert_eq!(l.attempt(a, "carl", t0).unwrap_err(), ADDR_EVERY);
    // A refused attempt takes nothing; time gives one back.
    tokio::time::advance(USER_EVERY - Duration::from_secs(1)).await;
    let now = Instant::now();
    assert_eq!(
        l.attempt(b, "anna", now).unwrap_err(),
        Duration::from_secs(1)
    );
    tokio::time::advance(Duration::from_secs(1)).await;
    let now = Instant::now();
    l.attempt(b, "anna", now).unwrap();
    assert!(l.attempt(b, "anna", now).is_err());
    // A log-in fills the user's bucket again.
    l.succeeded("anna");
    l.attempt(b, "anna", now).unwrap();
}

#[tokio::test(start_paused = true)]
async fn the_rate_limit_keeps_a_bounded_number_of_keys() {
    let mut l = Limiter::default();
    let now = Instant::now();
    for i in 0..(LIMIT_KEYS + 100) {
        let ip = IpAddr::V6(std::net::Ipv6Addr::from(u128::try_from(i).unwrap()));
        l.attempt(ip, &format!("u{i}"), now).unwrap();
    }
    assert!(l.by_addr.map.len() <= LIMIT_KEYS && l.by_user.map.len() <= LIMIT_KEYS);
}

/// A router with the log-in routes and a test-only POST route (and a GET one), each behind the
/// guard; the routes echo the [`Who`].
fn app(auth: Arc<Auth>) -> Router {
    let echo = |Extension(w): Extension<Who>| async move {
        answer(StatusCode::OK, &json!({"user": w.user, "role": w.role}))
    };
    Router::new()
        .route("/api/test", post(echo).get(echo))
        .route("/", get(|| async { "the page" }))
        .merge(routes(auth.clone()))
        .layer(axum::middleware::from_fn_with_state(auth, guard))
}

struct Answer {
    status: StatusCode,
    headers: axum::http::HeaderMap,
    body: Value,
}

async fn call(
    app: &Router,
    method: &str,
    path: &str,
    headers: &[(&str, &str)],
    body: Option<Value>,
) -> Answer {
    let mut r = axum::http::Request::builder().method(method).uri(path);
    for (k, v) in headers {
        r = r.header(*k, *v);
    }
    let mut req = r
        .body(body.map_or(Body::empty(), |b| Body::from(b.to_string())))
        .unwrap();
    req.extensions_mut()
        .insert(ConnectInfo(SocketAddr::from(([127, 0, 0, 9], 40000))));
    let resp = app.clone().oneshot(req).await.unwrap();
    let status = resp.status();
    let headers = resp.headers().clone();
    let bytes = axum::body::to_bytes(resp.into_body(), 1 << 20)
        .await
        .unwrap();
    let body = serde_json::from_slice(&bytes).unwrap_or(Value::Null);
    Answer {
        status,
        headers,
        body,
    }
}

const HOST: (&str, &str) = ("host", "127.0.0.1:8080");
const JSON: (&str, &str) = ("content-type", "application/json");

#[tokio::test]
async fn without_users_a_post_needs_the_pages_csrf_token_and_the_host_is_checked() {
    let auth = Auth::local().unwrap();
    let app = app(auth);
    let s = call(&app, "GET", "/api/session", &[HOST], None).await;
    assert_eq!(s.status, StatusCode::OK);
    assert_eq!(s.body["login_required"], false);
    assert_eq!(
        (&s.body["user"], &s.body["role"]),
        (&json!("local"), &json!("operator"))
    );
    let token = s.body["csrf"].as_str().unwrap().to_owned();
    assert_eq!(token.len(), 64, "256 bits");

    // A form another site posts has no token.
    let r = call(&app, "POST", "/api/test", &[HOST, JSON], Some(json!({}))).await;
    assert_eq!(r.status, StatusCode::FORBIDDEN);
    assert_eq!(r.body["error"], "csrf");
    let wrong = "0".repeat(64);
    let r = call(
        &app,
        "POST",
        "/api/test",
        &[HOST, ("x-csrf-token", &wrong)],
        None,
    )
    .await;
    assert_eq!(
        (r.status, &r.body["error"]),
        (StatusCode::FORBIDDEN, &json!("csrf"))
    );
    let r = call(
        &app,
        "POST",
        "/api/test",
        &[HOST, ("x-csrf-token", &token)],
        None,
    )
    .await;
    assert_eq!(r.status, StatusCode::OK);
    assert_eq!(r.body, json!({"user": "local", "role": "operator"}));
    // A GET needs no token; a rebinding name is refused before anything.
    assert_eq!(
        call(&app, "GET", "/api/test", &[HOST], None).await.status,
        StatusCode::OK
    );
    let r = call(&app, "GET", "/api/test", &[("host", "evil.example")], None).await;
    assert_eq!(r.status, StatusCode::MISDIRECTED_REQUEST);
    let r = call(
        &app,
        "POST",
        "/api/test",
        &[("host", "evil.example"), ("x-csrf-token", &token)],
        None,
    )
    .await;
    assert_eq!(r.status, StatusCode::MISDIRECTED_REQUEST);
    // No users: nothing to log in to.
    let r = call(
        &app,
        "POST",
        "/api/login",
        &[HOST, JSON],
        Some(json!({"user": "a", "password": "b"})),
    )
    .await;
    assert_eq!(r.status, StatusCode::NOT_FOUND);
}

fn users(pairs: &[(&str, Role, &str)]) -> Users {
    let mut text = String::new();
    for (name, role, password) in pairs {
        text = set_user(&text, name, *role, &hash_password(password).unwrap()).unwrap();
    }
    Users::parse(&text).unwrap()
}

/// Log in; the session cookie (`name=value`) and the CSRF token.
async fn log_in(app: &Router, user: &str, password: &str) -> (String, String) {
    let r = call(
        app,
        "POST",
        "/api/login",
        &[JSON],
        Some(json!({"user": user, "password": password})),
    )
    .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.body);
    let cookie = r.headers[header::SET_COOKIE].to_str().unwrap();
    let pair = cookie.split(';').next().unwrap().to_owned();
    (pair, r.body["csrf"].as_str().unwrap().to_owned())
}

#[tokio::test]
async fn a_log_in_sets_a_strict_secure_http_only_cookie_and_a_session_says_who() {
    let auth = Auth::new(Some(users(&[("anna", Role::Operator, "pw-anna")]))).unwrap();
    let app = app(auth.clone());
    // No session: the page's files and the session's state only.
    assert_eq!(
        call(&app, "GET", "/", &[], None).await.status,
        StatusCode::OK
    );
    let r = call(&app, "GET", "/api/test", &[], None).await;
    assert_eq!(
        (r.status, &r.body["error"]),
        (StatusCode::UNAUTHORIZED, &json!("login"))
    );
    let s = call(&app, "GET", "/api/session", &[], None).await;
    assert_eq!(
        s.body,
        json!({"login_required": true, "user": null, "role": null, "csrf": null})
    );
    // A path spelled otherwise reaches no route past the guard.
    for odd in ["//api/test", "/%61pi/test", "/api//test", "/x/../api/test"] {
        let r = call(&app, "GET", odd, &[], None).await;
        assert!(
            r.status == StatusCode::NOT_FOUND || r.status == StatusCode::UNAUTHORIZED,
            "{odd}: {}",
            r.status
        );
    }
    // Without users the host is checked; with users the session does that job.
    assert_eq!(
        call(&app, "GET", "/", &[("host", "gw.plant.example")], None)
            .await
            .status,
        StatusCode::OK
    );

    let r = call(
        &app,
        "POST",
        "/api/login",
        &[JSON],
        Some(json!({"user": "anna", "password": "pw-anna"})),
    )
    .await;
    assert_eq!(r.status, StatusCode::OK);
    let cookie = r.headers[header::SET_COOKIE].to_str().unwrap().to_owned();
    let attrs: Vec<&str> = cookie.split("; ").collect();
    let id = attrs[0].strip_prefix("drivebus_session=").unwrap();
    assert_eq!(id.len(), 64, "256 random bits: {cookie}");
    assert!(id.bytes().all(|b| b.is_ascii_hexdigit()));
    assert_eq!(
        &attrs[1..],
        ["HttpOnly", "Secure", "SameSite=Strict", "Path=/"]
    );
    assert_eq!(
        (&r.body["user"], &r.body["role"]),
        (&json!("anna"), &json!("operator"))
    );
    let csrf = r.body["csrf"].as_str().unwrap().to_owned();
    assert_ne!(csrf, id);

    let c = format!("drivebus_session={id}");
    let s = call(&app, "GET", "/api/session", &[("cookie", &c)], None).await;
    assert_eq!(s.body["user"], "anna");
    assert_eq!(s.body["csrf"], csrf);
    // Among other cookies.
    let many = format!("theme=dark; {c}; other=1");
    assert_eq!(
        call(&app, "GET", "/api/test", &[("cookie", &many)], None)
            .await
            .status,
        StatusCode::OK
    );
    // The session's token, not another's.
    let r = call(&app, "POST", "/api/test", &[("cookie", &c)], None).await;
    assert_eq!(r.body["error"], "csrf");
    let r = call(
        &app,
        "POST",
        "/api/test",
        &[("cookie", &c), ("x-csrf-token", &csrf)],
        None,
    )
    .await;
    assert_eq!(r.status, StatusCode::OK);
    assert_eq!(r.body, json!({"user": "anna", "role": "operator"}));
    // Another session's cookie is not this one's.
    let r = call(
        &app,
        "GET",
        "/api/test",
        &[("cookie", &format!("drivebus_session={}", "a".repeat(64)))],
        None,
    )
    .await;
    assert_eq!(r.status, StatusCode::UNAUTHORIZED);

    // The log-out ends it, on the server and in the browser.
    let r = call(&app, "POST", "/api/logout", &[("cookie", &c)], None).await;
    assert_eq!(r.body["error"], "csrf", "a log-out needs the token too");
    let r = call(
        &app,
        "POST",
        "/api/logout",
        &[("cookie", &c), ("x-csrf-token", &csrf)],
        None,
    )
    .await;
    assert_eq!(r.status, StatusCode::OK);
    assert!(
        r.headers[header::SET_COOKIE]
            .to_str()
            .unwrap()
            .contains("Max-Age=0")
    );
    let r = call(&app, "GET", "/api/test", &[("cookie", &c)], None).await;
    assert_eq!(r.status, StatusCode::UNAUTHORIZED);
}

#[tokio::test]
async fn a_viewer_reads_but_a_post_is_refused_for_its_role() {
    let auth = Auth::new(Some(users(&[
        ("anna", Role::Operator, "pw-anna"),
        ("bert", Role::Viewer, "pw-bert"),
    ])))
    .unwrap();
    let app = app(auth);
    let (c, csrf) = log_in(&app, "bert", "pw-bert").await;
    let r = call(&app, "GET", "/api/test", &[("cookie", &c)], None).await;
    assert_eq!(r.body, json!({"user": "bert", "role": "viewer"}));
    let r = call(
        &app,
        "POST",
        "/api/test",
        &[("cookie", &c), ("x-csrf-token", &csrf)],
        None,
    )
    .await;
    assert_eq!(
        (r.status, &r.body["error"]),
        (StatusCode::FORBIDDEN, &json!("role"))
    );
    // A viewer still logs out.
    let r = call(
        &app,
        "POST",
        "/api/logout",
        &[("cookie", &c), ("x-csrf-token", &csrf)],
        None,
    )
    .await;
    assert_eq!(r.status, StatusCode::OK);
    let (c, csrf) = log_in(&app, "anna", "pw-anna").await;
    let r = call(
        &app,
        "POST",
        "/api/test",
        &[("cookie", &c), ("x-csrf-token", &csrf)],
        None,
    )
    .await;
    assert_eq!(r.body, json!({"user": "anna", "role": "operator"}));
}

#[tokio::test]
async fn an_unknown_user_and_a_wrong_password_get_the_same_answer_then_a_429() {
    let auth = Auth::new(Some(users(&[("anna", Role::Operator, "pw-anna")]))).unwrap();
    let app = app(auth);
    let wrong = call(
        &app,
        "POST",
        "/api/login",
        &[JSON],
        Some(json!({"user": "anna", "password": "nope"})),
    )
    .await;
    let unknown = call(
        &app,
        "POST",
        "/api/login",
        &[JSON],
        Some(json!({"user": "zoe", "password": "nope"})),
    )
    .await;
    assert_eq!(wrong.status, StatusCode::UNAUTHORIZED);
    assert_eq!((wrong.status, &wrong.body), (unknown.status, &unknown.body));
    assert!(!wrong.headers.contains_key(header::SET_COOKIE));
    // Not JSON: refused before the password is looked at (a cross-site form cannot send JSON).
    let form = call(
        &app,
        "POST",
        "/api/login",
        &[("content-type", "application/x-www-form-urlencoded")],
        None,
    )
    .await;
    assert_eq!(form.status, StatusCode::UNSUPPORTED_MEDIA_TYPE);
    for _ in 1..USER_BURST {
        call(
            &app,
            "POST",
            "/api/login",
            &[JSON],
            Some(json!({"user": "anna", "password": "nope"})),
        )
        .await;
    }
    let limited = call(
        &app,
        "POST",
        "/api/login",
        &[JSON],
        Some(json!({"user": "anna", "password": "pw-anna"})),
    )
    .await;
    assert_eq!(limited.status, StatusCode::TOO_MANY_REQUESTS);
    assert_eq!(limited.body["error"], "rate");
    let after: u64 = limited.headers[header::RETRY_AFTER]
        .to_str()
        .unwrap()
        .parse()
        .unwrap();
    assert!((1..=USER_EVERY.as_secs()).contains(&after), "{after}");
    assert_eq!(limited.body["retry_after"], after);
}

#[tokio::test(start_paused = true)]
async fn a_session_ends_when_idle_and_at_its_maximum_age() {
    let auth = Auth::new(Some(Users::default())).unwrap();
    let who = Who {
        user: "anna".to_owned(),
        role: Role::Viewer,
    };
    let (id, _) = auth.open(who.clone(), Instant::now()).unwrap();
    tokio::time::advance(IDLE - Duration::from_secs(1)).await;
    assert!(auth.session(&id, Instant::now()).is_some(), "touched");
    tokio::time::advance(IDLE - Duration::from_secs(1)).await;
    assert!(auth.session(&id, Instant::now()).is_some());
    tokio::time::advance(IDLE).await;
    assert!(auth.session(&id, Instant::now()).is_none(), "idle");
    let (id, _) = auth.open(who, Instant::now()).unwrap();
    let mut elapsed = Duration::ZERO;
    while elapsed + IDLE / 2 < MAX_AGE {
        tokio::time::advance(IDLE / 2).await;
        elapsed += IDLE / 2;
        assert!(auth.session(&id, Instant::now()).is_some(), "{elapsed:?}");
    }
    tokio::time::advance(IDLE / 2).await;
    assert!(
        auth.session(&id, Instant::now()).is_none(),
        "past its maximum age"
    );
}

#[tokio::test]
async fn actions_are_logged_with_the_user_and_listed_newest_first() {
    let who = Who {
        user: "anna-actions".to_owned(),
        role: Role::Operator,
    };
    action(&who, "write b/d/P130 = 2.5", "ok");
    action(&who, "enable b/d", "refused: not controlled by the page");
    let app = app(Auth::local().unwrap());
    let r = call(&app, "GET", "/api/actions", &[HOST], None).await;
    let mine: Vec<&Value> = r
        .body
        .as_array()
        .unwrap()
        .iter()
        .filter(|a| a["user"] == "anna-actions")
        .collect();
    assert_eq!(mine.len(), 2);
    assert_eq!(mine[0]["action"], "enable b/d");
    assert_eq!(mine[0]["outcome"], "refused: not controlled by the page");
    assert_eq!(mine[1]["action"], "write b/d/P130 = 2.5");
    assert_eq!(mine[1]["role"], "operator");
    assert!(actions().len() <= ACTIONS);
}

fn ui(extra: &str) -> std::result::Result<Ui, String> {
    let file: crate::config::UiFile = toml::from_str(extra).unwrap();
    crate::config::check_ui_file(file)
}

#[test]
fn a_listener_other_than_loopback_needs_tls_and_users() {
    for listen in ["0.0.0.0:8443", "192.168.1.20:443", "[::]:8443"] {
        let e = ui(&format!("listen = \"{listen}\"")).unwrap_err();
        assert!(
            e.contains("tls_cert")
                && e.contains("tls_key")
                && e.contains("users")
                && e.contains("drivectl ui passwd"),
            "{e}"
        );
        let e = ui(&format!("listen = \"{listen}\"\nusers = \"u\"")).unwrap_err();
        assert!(e.contains("tls_cert") && !e.contains("users = "), "{e}");
        let e = ui(&format!(
            "listen = \"{listen}\"\ntls_cert = \"c\"\ntls_key = \"k\""
        ))
        .unwrap_err();
        assert!(e.contains("users = ") && !e.contains("tls_cert = "), "{e}");
        let u = ui(&format!(
            "listen = \"{listen}\"\ntls_cert = \"c\"\ntls_key = \"k\"\nusers = \"u\""
        ))
        .unwrap();
        assert_eq!(u.users.as_deref(), Some("u"));
    }
    // Loopback: TLS and users are allowed, each alone.
    assert!(ui("listen = \"127.0.0.1:8080\"\nusers = \"u\"").is_ok());
    assert!(ui("listen = \"127.0.0.1:8080\"\ntls_cert = \"c\"\ntls_key = \"k\"").is_ok());
    assert!(ui("listen = \"[::1]:8080\"").is_ok());
    assert!(ui("listen = \"[::ffff:127.0.0.1]:8080\"").is_ok());
    assert!(ui("listen = \"[::ffff:10.0.0.1]:8080\"").is_err());
    let e = ui("listen = \"127.0.0.1:8080\"\ntls_cert = \"c\"").unwrap_err();
    assert!(e.contains("tls_key"), "{e}");
    // In a config: the line of [ui].
    let e = Plant::parse(
        "[gateway]\nname = \"gw\"\nbroker = \"off\"\n\
         [[bus]]\nname = \"b\"\nprotocol = \"movilink\"\nsimulate = true\n\
         [[bus.drive]]\nname = \"d\"\naddress = 1\n\
         [[bus.drive.param]]\nparam = \"P130\"\nperiod = \"1s\"\n\
         [ui]\nlisten = \"0.0.0.0:8443\"\n",
        "plant.toml",
    )
    .unwrap_err()
    .to_string();
    assert!(e.starts_with("plant.toml:14: [ui] listen"), "{e}");
}

use crate::config::Plant;

/// A scratch directory removed at the end.
struct Dir(std::path::PathBuf);

impl Dir {
    fn new(name: &str) -> Dir {
        let p = std::env::temp_dir().join(format!("drivebus-auth-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        Dir(p)
    }
    fn file(&self, name: &str, text: &str) -> String {
        let p = self.0.join(name);
        std::fs::write(&p, text).unwrap();
        p.to_string_lossy().into_owned()
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn page(cert: Option<(&str, &str)>, users: Option<&str>) -> Ui {
    Ui {
        listen: "127.0.0.1:0".parse().unwrap(),
        tls: cert.map(|(c, k)| crate::config::UiTls {
            cert: c.to_owned(),
            key: k.to_owned(),
        }),
        users: users.map(str::to_owned),
    }
}

#[test]
fn a_bad_users_file_is_an_error_at_the_start_naming_the_file_and_line() {
    let d = Dir::new("users");
    let missing = d.0.join("missing").to_string_lossy().into_owned();
    let e = Security::load(&page(None, Some(&missing)))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("[ui] users") && e.contains(&missing) && e.contains("cannot read"),
        "{e}"
    );
    let bad = d.file(
        "bad",
        &format!("# users\nanna:operator:{PHC}\nbert:root:{PHC}\n"),
    );
    let e = Security::load(&page(None, Some(&bad)))
        .unwrap_err()
        .to_string();
    assert!(e.starts_with(&format!("{bad}:3: role \"root\"")), "{e}");
    let empty = d.file("empty", "# nobody yet\n");
    let e = Security::load(&page(None, Some(&empty)))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no user") && e.contains("drivectl ui passwd"),
        "{e}"
    );
    let dir = d.0.to_string_lossy().into_owned();
    let e = Security::load(&page(None, Some(&dir)))
        .unwrap_err()
        .to_string();
    assert!(e.contains("a directory"), "{e}");
    let good = d.file("good", &format!("anna:operator:{PHC}\n"));
    assert!(
        Security::load(&page(None, Some(&good)))
            .unwrap()
            .auth
            .login_required()
    );
}

/// A self-signed certificate and its key made with `openssl` (`None`, and a failure under CI,
/// where it is missing).
fn openssl_cert(d: &Dir, name: &str) -> Option<(String, String)> {
    let cert = d.0.join(format!("{name}.crt"));
    let key = d.0.join(format!("{name}.key"));
    let out = std::process::Command::new("openssl")
        .args([
            "req",
            "-x509",
            "-newkey",
            "ec",
            "-pkeyopt",
            "ec_paramgen_curve:prime256v1",
        ])
        .args(["-nodes", "-days", "1", "-subj", "/CN=localhost", "-keyout"])
        .arg(&key)
        .arg("-out")
        .arg(&cert)
        .output();
    match out {
        Ok(o) if o.status.success() => Some((
            cert.to_string_lossy().into_owned(),
            key.to_string_lossy().into_owned(),
        )),
        other => {
            assert!(
                std::env::var_os("CI").is_none_or(|v| v.is_empty()),
                "openssl is needed to make a test certificate: {other:?}"
            );
            eprintln!("SKIPPED: openssl is not installed");
            None
        }
    }
}

#[test]
fn a_bad_certificate_or_key_is_an_error_at_the_start_naming_the_file() {
    let d = Dir::new("tls");
    let not_pem = d.file("not.pem", "hello\n");
    let missing = d.0.join("none.pem").to_string_lossy().into_owned();
    let e = Security::load(&page(Some((&missing, &not_pem)), None))
        .unwrap_err()
        .to_string();
    assert!(e.contains("[ui] tls_cert") && e.contains(&missing), "{e}");
    let e = Security::load(&page(Some((&not_pem, &not_pem)), None))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("[ui] tls_cert") && e.contains("no certificate"),
        "{e}"
    );
    let Some((cert, key)) = openssl_cert(&d, "a") else {
        return;
    };
    let Some((_, other_key)) = openssl_cert(&d, "b") else {
        return;
    };
    assert!(
        Security::load(&page(Some((&cert, &key)), None))
            .unwrap()
            .tls
            .is_some()
    );
    let e = Security::load(&page(Some((&cert, &not_pem)), None))
        .unwrap_err()
        .to_string();
    assert!(e.contains("[ui] tls_key") && e.contains(&not_pem), "{e}");
    let e = Security::load(&page(Some((&cert, &other_key)), None))
        .unwrap_err()
        .to_string();
    assert!(e.contains("do not go together"), "{e}");
    // The key given as the certificate.
    let e = Security::load(&page(Some((&key, &key)), None))
        .unwrap_err()
        .to_string();
    assert!(e.contains("[ui] tls_cert"), "{e}");
}
