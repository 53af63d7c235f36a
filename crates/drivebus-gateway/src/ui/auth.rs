//! Who may use the page, and how (`docs/ui.md`, "Security"): the password file and its users
//! ([`Users`], two [`Role`]s), log-in sessions in cookies, CSRF tokens, the per-request check
//! ([`guard`]) that puts a [`Who`] into every request, the log of write and control actions
//! ([`action`]), and HTTPS ([`tls`]).
//!
//! Without `[ui] users` the page is this machine's alone (a loopback listener, the `Host`
//! check): every request is the user `local`, an operator. A state-changing request still needs
//! the CSRF token the gateway makes at the start and `GET /api/session` gives the page, so that
//! a form another web site posts to the loopback page is refused.
//!
//! With users every request but the page's files, `GET /api/session` and `POST /api/login`
//! needs a session: a random id in the `drivebus_session` cookie (`HttpOnly; Secure;
//! SameSite=Strict`), ended by `POST /api/logout`, by [`IDLE`] without a request, or by
//! [`MAX_AGE`] after the log-in. Passwords are checked with argon2 on tokio's blocking pool:
//! the buses run on the one thread of the gateway and a hash takes tens of milliseconds.

use std::collections::{HashMap, VecDeque};
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use argon2::password_hash::{PasswordHash, PasswordHasher as _, PasswordVerifier as _, SaltString};
use axum::Router;
use axum::extract::{ConnectInfo, Request, State};
use axum::http::{HeaderValue, Method, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use serde_json::{Value, json};
use tokio::time::Instant;

use crate::config::Ui;
use crate::error::{Error, Result};

pub mod tls;

/// A session ends after this long without a request (30 minutes).
pub const IDLE: Duration = Duration::from_secs(30 * 60);
/// A session ends this long after its log-in, however busy (12 hours: a shift).
pub const MAX_AGE: Duration = Duration::from_secs(12 * 60 * 60);
/// The most sessions kept; a log-in beyond them ends the one idle longest.
pub const MAX_SESSIONS: usize = 1000;
/// The cookie that carries the session id.
pub const COOKIE: &str = "drivebus_session";
/// The header that carries the CSRF token on every state-changing request.
pub const CSRF_HEADER: &str = "x-csrf-token";
/// How many write and control actions `GET /api/actions` keeps.
pub const ACTIONS: usize = 200;
/// Log-in attempts per client address: a burst of this many…
pub const ADDR_BURST: u32 = 10;
/// …then one more every this long.
pub const ADDR_EVERY: Duration = Duration::from_secs(6);
/// Log-in attempts per user name (known or not): a burst of this many…
pub const USER_BURST: u32 = 5;
/// …then one more every this long.
pub const USER_EVERY: Duration = Duration::from_secs(15);
/// Addresses and user names the rate limit keeps track of at most (each).
const LIMIT_KEYS: usize = 4096;
/// Password checks at once (each takes ~19 MiB and tens of milliseconds); more wait.
const HASHING: usize = 2;
/// The longest user name.
pub const MAX_NAME: usize = 64;
/// The longest password taken.
pub const MAX_PASSWORD: usize = 1024;
/// The largest password file read.
const USERS_LIMIT: u64 = 1 << 20;
/// The largest log-in request body.
const LOGIN_BODY: usize = 4096;

/// What a user may do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
#[non_exhaustive]
pub enum Role {
    /// Reads everything, changes nothing.
    Viewer,
    /// Also writes parameters, restores backups and controls drives.
    Operator,
}

impl Role {
    /// `viewer` or `operator`.
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Viewer => "viewer",
            Role::Operator => "operator",
        }
    }

    /// `viewer` or `operator`; `None` for anything else.
    pub fn parse(text: &str) -> Option<Role> {
        match text {
            "viewer" => Some(Role::Viewer),
            "operator" => Some(Role::Operator),
            _ => None,
        }
    }
}

impl std::fmt::Display for Role {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Who sent a request: in every request's extensions once [`guard`] let it through
/// (`axum::Extension<Who>`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Who {
    /// The user's name (`local` on a loopback page without users).
    pub user: String,
    /// The user's role (an operator on a loopback page without users).
    pub role: Role,
}

/// One user of the password file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct User {
    /// The name typed at the log-in.
    pub name: String,
    /// What the user may do.
    pub role: Role,
    /// The argon2id hash of the password, as a PHC string (`$argon2id$v=19$m=…`).
    pub phc: String,
}

/// Why a password file, a user name or a password is refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum UsersError {
    /// The file is not UTF-8 text.
    #[error("not UTF-8 text")]
    NotText,
    /// A line that is not `name:role:hash` (1-based).
    #[error("line {line}: {problem}")]
    Line {
        /// The line, from 1.
        line: usize,
        /// What is wrong with it.
        problem: String,
    },
    /// A user name that cannot be used.
    #[error(
        "user name {0:?}: give 1–64 characters without ':', control characters or spaces at either end, not starting with '#'"
    )]
    BadName(String),
    /// An empty or too long password.
    #[error("the password is empty or longer than 1024 bytes")]
    BadPassword,
    /// The OS's random generator failed.
    #[error("no random salt: {0}")]
    Random(String),
    /// Hashing failed (argon2's own error).
    #[error("cannot hash the password: {0}")]
    Hash(String),
}

/// Whether `name` can be a user's name: 1–[`MAX_NAME`] characters, no `:` (the file's
/// separator), no control characters, no spaces at either end, not starting with `#` (a
/// comment).
pub fn check_user_name(name: &str) -> std::result::Result<(), UsersError> {
    let ok = !name.is_empty()
        && name.chars().count() <= MAX_NAME
        && !name.contains(':')
        && !name.chars().any(char::is_control)
        && name.trim() == name
        && !name.starts_with('#')
        && !name.starts_with('\u{feff}');
    if ok {
        Ok(())
    } else {
        Err(UsersError::BadName(name.chars().take(80).collect()))
    }
}

/// The argon2 hasher every hash is made with: argon2id, version 19, 19 MiB, 2 passes, 1 lane
/// (argon2's defaults, OWASP's first choice).
fn argon2() -> argon2::Argon2<'static> {
    argon2::Argon2::default()
}

/// The argon2id hash of `password` with a random 16-byte salt from the OS, as a PHC string.
pub fn hash_password(password: &str) -> std::result::Result<String, UsersError> {
    if password.is_empty() || password.len() > MAX_PASSWORD {
        return Err(UsersError::BadPassword);
    }
    let mut salt = [0u8; 16];
    getrandom::getrandom(&mut salt).map_err(|e| UsersError::Random(e.to_string()))?;
    let salt = SaltString::encode_b64(&salt).map_err(|e| UsersError::Hash(e.to_string()))?;
    argon2()
        .hash_password(password.as_bytes(), &salt)
        .map(|h| h.to_string())
        .map_err(|e| UsersError::Hash(e.to_string()))
}

/// Whether `password` is the one `phc` was made from (a PHC string that does not parse never
/// matches). Takes as long as the hash's parameters say, whatever the answer.
pub fn verify_password(phc: &str, password: &str) -> bool {
    match PasswordHash::new(phc) {
        Ok(h) => argon2().verify_password(password.as_bytes(), &h).is_ok(),
        Err(_) => false,
    }
}

/// The largest argon2 memory cost (KiB) a password file may ask for: a hash that asks for more
/// would let one log-in take the machine's memory.
const MAX_M_COST: u32 = 256 * 1024;
/// The most passes and lanes a password file may ask for.
const MAX_T_COST: u32 = 16;
const MAX_P_COST: u32 = 16;

/// Check a PHC string: argon2id, with costs a log-in can afford.
fn check_phc(phc: &str) -> std::result::Result<(), String> {
    let h = PasswordHash::new(phc).map_err(|e| {
        format!("the hash is not a PHC string ({e}); make the line with `drivectl ui passwd`")
    })?;
    if h.algorithm.as_str() != "argon2id" {
        return Err(format!(
            "the hash is {}, not argon2id; make the line with `drivectl ui passwd`",
            h.algorithm
        ));
    }
    let params = argon2::Params::try_from(&h).map_err(|e| format!("the hash's parameters: {e}"))?;
    if params.m_cost() > MAX_M_COST || params.t_cost() > MAX_T_COST || params.p_cost() > MAX_P_COST
    {
        return Err(format!(
            "the hash asks for m={} KiB, t={}, p={}: at most m={MAX_M_COST}, t={MAX_T_COST}, \
             p={MAX_P_COST}",
            params.m_cost(),
            params.t_cost(),
            params.p_cost()
        ));
    }
    if h.hash.is_none() || h.salt.is_none() {
        return Err("the hash has no salt or no output".to_owned());
    }
    Ok(())
}

/// The lines of a password file's text without a byte-order mark, each without its CR.
fn lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    text.split('\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
}

/// The users of a password file: one `name:role:hash` per line (`role` is `viewer` or
/// `operator`, `hash` an argon2id PHC string); `#` comments and blank lines are skipped; a
/// byte-order mark and CR LF line ends (a file saved by Notepad) are fine. A user named twice
/// is an error.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Users {
    list: Vec<User>,
}

impl Users {
    /// Parse a password file's text.
    pub fn parse(text: &str) -> std::result::Result<Users, UsersError> {
        let mut list: Vec<User> = Vec::new();
        for (line, l) in lines(text) {
            let t = l.trim();
            if t.is_empty() || t.starts_with('#') {
                continue;
            }
            let bad = |problem: String| UsersError::Line { line, problem };
            let mut parts = t.splitn(3, ':');
            let (Some(name), Some(role), Some(phc)) = (parts.next(), parts.next(), parts.next())
            else {
                return Err(bad(
                    "give name:role:hash (role viewer or operator); make the line with \
                     `drivectl ui passwd`"
                        .to_owned(),
                ));
            };
            check_user_name(name).map_err(|e| bad(e.to_string()))?;
            let role = Role::parse(role).ok_or_else(|| {
                bad(format!(
                    "role {:?}: give viewer or operator",
                    role.chars().take(40).collect::<String>()
                ))
            })?;
            check_phc(phc).map_err(bad)?;
            if list.iter().any(|u| u.name == name) {
                return Err(bad(format!("user {name:?} is named twice")));
            }
            list.push(User {
                name: name.to_owned(),
                role,
                phc: phc.to_owned(),
            });
        }
        Ok(Users { list })
    }

    /// Parse a password file's bytes (UTF-8).
    pub fn parse_bytes(bytes: &[u8]) -> std::result::Result<Users, UsersError> {
        Users::parse(std::str::from_utf8(bytes).map_err(|_| UsersError::NotText)?)
    }

    /// The user called `name`.
    pub fn get(&self, name: &str) -> Option<&User> {
        self.list.iter().find(|u| u.name == name)
    }

    /// Every user, in the file's order.
    pub fn list(&self) -> &[User] {
        &self.list
    }
}

/// A password file's text with `name` added as `role` with the hash `phc`, or its line
/// replaced where it has one; every other line (comments too) is kept as it is. The text must
/// be a good password file (a bad one is refused, changed nothing). A new file starts with a
/// comment that says what it is.
pub fn set_user(
    text: &str,
    name: &str,
    role: Role,
    phc: &str,
) -> std::result::Result<String, UsersError> {
    check_user_name(name)?;
    check_phc(phc).map_err(|problem| UsersError::Line { line: 0, problem })?;
    Users::parse(text)?;
    let line = format!("{name}:{role}:{phc}");
    let bom = if text.starts_with('\u{feff}') {
        "\u{feff}"
    } else {
        ""
    };
    let crlf = text.contains("\r\n");
    let eol = if crlf { "\r\n" } else { "\n" };
    let mut out: Vec<String> = Vec::new();
    let mut replaced = false;
    for (_, l) in lines(text) {
        let is_user = l
            .trim()
            .split_once(':')
            .is_some_and(|(n, _)| n == name && !l.trim().starts_with('#'));
        if is_user {
            out.push(line.clone());
            replaced = true;
        } else {
            out.push(l.to_owned());
        }
    }
    // The split leaves one empty piece after the last line end.
    if out.last().is_some_and(String::is_empty) {
        out.pop();
    }
    if out.is_empty() {
        out.push(
            "# drivebus page users: name:role:argon2id-hash, role viewer or operator \
             (drivectl ui passwd)"
                .to_owned(),
        );
    }
    if !replaced {
        out.push(line);
    }
    let mut s = String::from(bom);
    for l in out {
        s.push_str(&l);
        s.push_str(eol);
    }
    Ok(s)
}

/// `n` random bytes from the OS, as lowercase hex.
fn random_hex(n: usize) -> Option<String> {
    use std::fmt::Write as _;
    let mut b = vec![0u8; n];
    getrandom::getrandom(&mut b).ok()?;
    Some(b.iter().fold(String::with_capacity(2 * n), |mut s, x| {
        let _ = write!(s, "{x:02x}");
        s
    }))
}

/// Whether `a` and `b` are equal, in a time that depends only on their lengths.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// A token bucket: up to `burst` attempts, one more every `every`.
#[derive(Debug, Clone, Copy)]
struct Bucket {
    tokens: u32,
    at: Instant,
}

impl Bucket {
    /// The bucket as of `now`: refilled for the time since `at`.
    fn refill(self, now: Instant, burst: u32, every: Duration) -> Bucket {
        let elapsed = now.saturating_duration_since(self.at);
        let add = u32::try_from(elapsed.as_nanos() / every.as_nanos().max(1)).unwrap_or(u32::MAX);
        let tokens = self.tokens.saturating_add(add).min(burst);
        let at = if tokens >= burst {
            now
        } else {
            self.at + every * add
        };
        Bucket { tokens, at }
    }

    /// How long until it has a token (zero when it has one).
    fn wait(self, now: Instant, every: Duration) -> Duration {
        if self.tokens > 0 {
            Duration::ZERO
        } else {
            (self.at + every).saturating_duration_since(now)
        }
    }
}

/// Token buckets by key, at most [`LIMIT_KEYS`]: when full, the buckets that have refilled are
/// dropped, then the one untouched longest.
#[derive(Debug)]
struct Buckets<K> {
    map: HashMap<K, Bucket>,
    burst: u32,
    every: Duration,
}

impl<K: std::hash::Hash + Eq + Clone> Buckets<K> {
    fn new(burst: u32, every: Duration) -> Self {
        Buckets {
            map: HashMap::new(),
            burst,
            every,
        }
    }

    fn get(&self, k: &K, now: Instant) -> Bucket {
        self.map.get(k).map_or(
            Bucket {
                tokens: self.burst,
                at: now,
            },
            |b| b.refill(now, self.burst, self.every),
        )
    }

    fn take(&mut self, k: &K, now: Instant) {
        let mut b = self.get(k, now);
        b.tokens = b.tokens.saturating_sub(1);
        if !self.map.contains_key(k) && self.map.len() >= LIMIT_KEYS {
            let (burst, every) = (self.burst, self.every);
            self.map
                .retain(|_, b| b.refill(now, burst, every).tokens < burst);
            if self.map.len() >= LIMIT_KEYS
                && let Some(oldest) = self
                    .map
                    .iter()
                    .min_by_key(|(_, b)| b.at)
                    .map(|(k, _)| k.clone())
            {
                self.map.remove(&oldest);
            }
        }
        self.map.insert(k.clone(), b);
    }
}

/// The log-in rate limit: a bucket per client address and one per user name (known or not),
/// both needed for an attempt. A refused attempt takes nothing.
#[derive(Debug)]
pub struct Limiter {
    by_addr: Buckets<IpAddr>,
    by_user: Buckets<String>,
}

impl Default for Limiter {
    fn default() -> Self {
        Limiter {
            by_addr: Buckets::new(ADDR_BURST, ADDR_EVERY),
            by_user: Buckets::new(USER_BURST, USER_EVERY),
        }
    }
}

impl Limiter {
    /// Take an attempt for `addr` and `user` at `now`, or say how long to wait.
    pub fn attempt(
        &mut self,
        addr: IpAddr,
        user: &str,
        now: Instant,
    ) -> std::result::Result<(), Duration> {
        let user = user.chars().take(MAX_NAME).collect::<String>();
        let wait = self
            .by_addr
            .get(&addr, now)
            .wait(now, self.by_addr.every)
            .max(self.by_user.get(&user, now).wait(now, self.by_user.every));
        if wait > Duration::ZERO {
            return Err(wait);
        }
        self.by_addr.take(&addr, now);
        self.by_user.take(&user, now);
        Ok(())
    }

    /// `user` logged in: their name's bucket is full again (the address's is not).
    pub fn succeeded(&mut self, user: &str) {
        self.by_user.map.remove(user);
    }
}

/// A log-in session.
#[derive(Debug, Clone)]
struct Session {
    who: Who,
    csrf: String,
    created: Instant,
    seen: Instant,
}

impl Session {
    fn live(&self, now: Instant) -> bool {
        now.saturating_duration_since(self.seen) < IDLE
            && now.saturating_duration_since(self.created) < MAX_AGE
    }
}

/// The page's sessions and rate limit.
#[derive(Debug, Default)]
struct Book {
    sessions: HashMap<String, Session>,
    limiter: Limiter,
}

/// Who may use the page: the users (or none: a loopback page), the sessions, the CSRF token of
/// a page without users, the log-in rate limit.
#[derive(Debug)]
pub struct Auth {
    users: Option<Users>,
    /// The one CSRF token of a page without users.
    local_csrf: String,
    state: Mutex<Book>,
    hashing: tokio::sync::Semaphore,
}

impl Auth {
    /// The page of this machine only: no users, one CSRF token.
    pub fn local() -> Result<Arc<Auth>> {
        Auth::new(None)
    }

    /// The page with `users` (`None`: no log-in, a loopback page).
    pub fn new(users: Option<Users>) -> Result<Arc<Auth>> {
        let local_csrf = random_hex(32)
            .ok_or_else(|| Error::failed("the OS's random generator failed (the page's token)"))?;
        Ok(Arc::new(Auth {
            users,
            local_csrf,
            state: Mutex::new(Book::default()),
            hashing: tokio::sync::Semaphore::new(HASHING),
        }))
    }

    /// Whether the page asks for a log-in.
    pub fn login_required(&self) -> bool {
        self.users.is_some()
    }

    fn state(&self) -> std::sync::MutexGuard<'_, Book> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The live session of `id` (touched), or none; an expired one is dropped.
    fn session(&self, id: &str, now: Instant) -> Option<Session> {
        let mut st = self.state();
        let s = st.sessions.get_mut(id)?;
        if s.live(now) {
            s.seen = now;
            Some(s.clone())
        } else {
            st.sessions.remove(id);
            None
        }
    }

    /// A new session for `who`: its id and CSRF token.
    fn open(&self, who: Who, now: Instant) -> Option<(String, String)> {
        let id = random_hex(32)?;
        let csrf = random_hex(32)?;
        let mut st = self.state();
        if st.sessions.len() >= MAX_SESSIONS {
            st.sessions.retain(|_, s| s.live(now));
            if st.sessions.len() >= MAX_SESSIONS
                && let Some(idle) = st
                    .sessions
                    .iter()
                    .min_by_key(|(_, s)| s.seen)
                    .map(|(k, _)| k.clone())
            {
                st.sessions.remove(&idle);
            }
        }
        st.sessions.insert(
            id.clone(),
            Session {
                who,
                csrf: csrf.clone(),
                created: now,
                seen: now,
            },
        );
        Some((id, csrf))
    }
}

/// What the page is served with: who may use it and, with TLS, the server's certificate.
#[derive(Debug, Clone)]
pub struct Security {
    /// Users, sessions, tokens.
    pub auth: Arc<Auth>,
    /// The TLS configuration (`None`: plain HTTP, a loopback page).
    pub tls: Option<Arc<rustls::ServerConfig>>,
}

impl Security {
    /// A loopback page without TLS or users.
    pub fn local() -> Result<Security> {
        Ok(Security {
            auth: Auth::local()?,
            tls: None,
        })
    }

    /// Read and check the files `[ui]` names (before any bus opens): the certificate chain,
    /// its key, the password file. An error names the config key, the file and (in the
    /// password file) the line.
    pub fn load(ui: &Ui) -> Result<Security> {
        let tls = match &ui.tls {
            Some(t) => Some(Arc::new(tls::server_config(&t.cert, &t.key)?)),
            None => None,
        };
        let users = match &ui.users {
            Some(path) => Some(load_users(path)?),
            None => None,
        };
        Ok(Security {
            auth: Auth::new(users)?,
            tls,
        })
    }
}

/// A small regular file read whole; `key` names the `[ui]` key in errors.
pub(crate) fn read_small(path: &str, key: &str, limit: u64) -> Result<Vec<u8>> {
    crate::config::read_small_file(path, &format!("[ui] {key}"), limit)
}

/// Read the password file `path` (`[ui] users`): at least one user.
pub fn load_users(path: &str) -> Result<Users> {
    let bytes = read_small(path, "users", USERS_LIMIT)?;
    let users = Users::parse_bytes(&bytes).map_err(|e| match e {
        UsersError::Line { line, problem } => {
            Error::config(format!("{path}:{line}: {problem} ([ui] users)"))
        }
        other => Error::config(format!("[ui] users = {path:?}: {other}")),
    })?;
    if users.list().is_empty() {
        return Err(Error::config(format!(
            "[ui] users = {path:?}: no user in it; add one with `drivectl ui passwd --file \
             {path} --user NAME --role operator`"
        )));
    }
    Ok(users)
}

/// One write or control action of the page.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Action {
    /// When, milliseconds since 1970.
    pub ts: u64,
    /// Who.
    pub user: String,
    /// With which role.
    pub role: Role,
    /// What (`write line-1/pump/ramp = 2.5`, `restore …`, `enable …`).
    pub action: String,
    /// How it ended (`ok`, or the refusal or failure).
    pub outcome: String,
}

/// The last [`ACTIONS`] actions, oldest first (one log for the process).
static LOG: Mutex<VecDeque<Action>> = Mutex::new(VecDeque::new());

/// Log a write or control action that `who` asked the page for and its outcome: on the
/// gateway's log (info) and in the last [`ACTIONS`] that `GET /api/actions` lists.
pub fn action(who: &Who, action: &str, outcome: &str) {
    tracing::info!(
        user = %who.user,
        role = %who.role,
        action,
        outcome,
        "page action"
    );
    let ts = u64::try_from(
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap_or_default()
            .as_millis(),
    )
    .unwrap_or(u64::MAX);
    let mut log = LOG.lock().unwrap_or_else(PoisonError::into_inner);
    if log.len() >= ACTIONS {
        log.pop_front();
    }
    log.push_back(Action {
        ts,
        user: who.user.clone(),
        role: who.role,
        action: action.to_owned(),
        outcome: outcome.to_owned(),
    });
}

/// The kept actions, newest first.
pub fn actions() -> Vec<Action> {
    LOG.lock()
        .unwrap_or_else(PoisonError::into_inner)
        .iter()
        .rev()
        .cloned()
        .collect()
}

/// A JSON answer.
fn answer(status: StatusCode, v: &Value) -> Response {
    (
        status,
        [(header::CONTENT_TYPE, "application/json")],
        v.to_string(),
    )
        .into_response()
}

fn refuse(status: StatusCode, error: &str, message: &str) -> Response {
    answer(status, &json!({"error": error, "message": message}))
}

/// The session id in a request's `Cookie` headers.
fn session_cookie(h: &axum::http::HeaderMap) -> Option<&str> {
    h.get_all(header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .find_map(|c| c.trim().strip_prefix(COOKIE)?.strip_prefix('='))
}

/// The `Set-Cookie` value of a new session.
pub fn session_set_cookie(id: &str) -> String {
    format!("{COOKIE}={id}; HttpOnly; Secure; SameSite=Strict; Path=/")
}

/// The `Set-Cookie` value that ends the session in the browser.
fn cleared_cookie() -> &'static str {
    "drivebus_session=; HttpOnly; Secure; SameSite=Strict; Path=/; Max-Age=0"
}

/// The request's session id and its session, where it has a live one.
#[derive(Debug, Clone)]
struct SessionId(Option<String>, Option<String>);

/// Whether a path is open without a session: the page's own files, `/api/session`,
/// `/api/login`.
fn public(path: &str) -> bool {
    !path.starts_with("/api/") || path == "/api/session" || path == "/api/login"
}

/// The check every request passes before its route: on a page without users, a loopback `Host`
/// (else 421); with users, a live session except for the public paths (the page's files, the session, the log-in) (else 401); on every
/// request but GET and HEAD, the `X-CSRF-Token` of the session or the page (else 403 `csrf`);
/// on a POST under `/api/` but log-in and log-out, an operator (else 403 `role`). The request
/// then carries a [`Who`].
pub async fn guard(State(auth): State<Arc<Auth>>, mut request: Request, next: Next) -> Response {
    let path = request.uri().path().to_owned();
    let method = request.method().clone();
    let changes = method != Method::GET && method != Method::HEAD;
    let now = Instant::now();
    let (who, csrf, id) = if auth.login_required() {
        // No `Host` check here: a page of another site that a rebinding name points at this
        // gateway is another origin to the browser, which sends it no session cookie (and the
        // cookie is `SameSite=Strict`); without a session it reaches only the page's files
        // and the log-in, which needs the password.
        let id = session_cookie(request.headers()).map(str::to_owned);
        match id.as_deref().and_then(|i| auth.session(i, now)) {
            Some(s) => (Some(s.who), Some(s.csrf), id),
            None if public(&path) => (None, None, None),
            None => {
                return refuse(
                    StatusCode::UNAUTHORIZED,
                    "login",
                    "log in first (the session ended or there is none)",
                );
            }
        }
    } else {
        let host_ok = request
            .headers()
            .get(header::HOST)
            .and_then(|h| h.to_str().ok())
            .is_some_and(super::loopback_host);
        if !host_ok {
            return (
                StatusCode::MISDIRECTED_REQUEST,
                "this page answers only to localhost, 127.0.0.1 or [::1]\n",
            )
                .into_response();
        }
        let who = Who {
            user: "local".to_owned(),
            role: Role::Operator,
        };
        (Some(who), Some(auth.local_csrf.clone()), None)
    };
    // The log-in has no session yet: its JSON body (a cross-site form cannot send one) and
    // the password stand for the token.
    if changes && path != "/api/login" {
        let sent = request
            .headers()
            .get(CSRF_HEADER)
            .map(HeaderValue::as_bytes)
            .unwrap_or_default();
        if !csrf.as_deref().is_some_and(|t| same(t.as_bytes(), sent)) {
            return refuse(
                StatusCode::FORBIDDEN,
                "csrf",
                "the request has no valid X-CSRF-Token header: load the page again",
            );
        }
    }
    if changes
        && path.starts_with("/api/")
        && path != "/api/login"
        && path != "/api/logout"
        && who.as_ref().is_some_and(|w| w.role != Role::Operator)
    {
        return refuse(
            StatusCode::FORBIDDEN,
            "role",
            "a viewer may look but not write or control: log in as an operator",
        );
    }
    if let Some(w) = who {
        request.extensions_mut().insert(w);
    }
    request.extensions_mut().insert(SessionId(id, csrf));
    next.run(request).await
}

/// The routes of the log-in: `GET /api/session`, `POST /api/login`, `POST /api/logout`,
/// `GET /api/actions`, and `/login.js`.
pub fn routes<S: Clone + Send + Sync + 'static>(auth: Arc<Auth>) -> Router<S> {
    Router::new()
        .route("/api/session", get(session))
        .route("/api/login", post(login))
        .route("/api/logout", post(logout))
        .route(
            "/api/actions",
            get(|| async { answer(StatusCode::OK, &json!(actions())) }),
        )
        .route(
            "/login.js",
            get(|| async {
                (
                    [(header::CONTENT_TYPE, "text/javascript; charset=utf-8")],
                    LOGIN_JS,
                )
            }),
        )
        .with_state(auth)
}

const LOGIN_JS: &str = include_str!("login.js");

fn session_json(auth: &Auth, who: Option<&Who>, csrf: Option<&str>) -> Value {
    json!({
        "login_required": auth.login_required(),
        "user": who.map(|w| w.user.as_str()),
        "role": who.map(|w| w.role),
        "csrf": csrf,
    })
}

async fn session(State(auth): State<Arc<Auth>>, request: Request) -> Response {
    let who = request.extensions().get::<Who>();
    let csrf = request
        .extensions()
        .get::<SessionId>()
        .and_then(|s| s.1.as_deref());
    answer(StatusCode::OK, &session_json(&auth, who, csrf))
}

/// The client's address (unknown: 0.0.0.0, one bucket for all such).
fn client(request: &Request) -> IpAddr {
    request
        .extensions()
        .get::<ConnectInfo<SocketAddr>>()
        .map_or(IpAddr::V4(Ipv4Addr::UNSPECIFIED), |c| c.0.ip())
}

#[derive(serde::Deserialize)]
struct Login {
    user: String,
    password: String,
}

async fn login(State(auth): State<Arc<Auth>>, request: Request) -> Response {
    let Some(users) = &auth.users else {
        return refuse(
            StatusCode::NOT_FOUND,
            "no_users",
            "this page has no users: there is nothing to log in to",
        );
    };
    let addr = client(&request);
    let json_body = request
        .headers()
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.trim_start().starts_with("application/json"));
    if !json_body {
        return refuse(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            "bad_request",
            "send the log-in as JSON (Content-Type: application/json)",
        );
    }
    let Ok(body) = axum::body::to_bytes(request.into_body(), LOGIN_BODY).await else {
        return refuse(
            StatusCode::BAD_REQUEST,
            "bad_request",
            "the log-in is too long",
        );
    };
    let Ok(form) = serde_json::from_slice::<Login>(&body) else {
        return refuse(
            StatusCode::BAD_REQUEST,
            "bad_request",
            "send {\"user\": NAME, \"password\": PASSWORD}",
        );
    };
    let user: String = form.user.chars().take(MAX_NAME + 1).collect();
    let limited = auth.state().limiter.attempt(addr, &user, Instant::now());
    if let Err(wait) = limited {
        let secs = wait.as_secs() + u64::from(wait.subsec_nanos() > 0);
        tracing::warn!(%addr, user = %user, retry_after = secs, "page log-in refused: too many attempts");
        let mut r = answer(
            StatusCode::TOO_MANY_REQUESTS,
            &json!({
                "error": "rate",
                "message": format!("too many log-in attempts: try again in {secs} s"),
                "retry_after": secs,
            }),
        );
        if let Ok(v) = HeaderValue::from_str(&secs.to_string()) {
            r.headers_mut().insert(header::RETRY_AFTER, v);
        }
        return r;
    }
    let known = users.get(&user).cloned();
    // An unknown user is checked against a real hash too (the first user's, whose password
    // cannot match as the result is not used): the answer takes as long as a wrong password.
    let phc = match (&known, users.list().first()) {
        (Some(u), _) | (None, Some(u)) => u.phc.clone(),
        (None, None) => String::new(),
    };
    let password = form.password;
    let ok = {
        let Ok(_permit) = auth.hashing.acquire().await else {
            return refuse(
                StatusCode::SERVICE_UNAVAILABLE,
                "busy",
                "the gateway is stopping",
            );
        };
        tokio::task::spawn_blocking(move || {
            password.len() <= MAX_PASSWORD && verify_password(&phc, &password)
        })
        .await
        .unwrap_or(false)
    };
    match known {
        Some(u) if ok => {
            let who = Who {
                user: u.name.clone(),
                role: u.role,
            };
            let Some((id, csrf)) = auth.open(who.clone(), Instant::now()) else {
                return refuse(
                    StatusCode::INTERNAL_SERVER_ERROR,
                    "random",
                    "the OS's random generator failed",
                );
            };
            auth.state().limiter.succeeded(&u.name);
            tracing::info!(%addr, user = %u.name, role = %u.role, "page log-in");
            let mut r = answer(
                StatusCode::OK,
                &session_json(&auth, Some(&who), Some(&csrf)),
            );
            if let Ok(v) = HeaderValue::from_str(&session_set_cookie(&id)) {
                r.headers_mut().insert(header::SET_COOKIE, v);
            }
            r
        }
        _ => {
            tracing::warn!(%addr, user = %user, "page log-in failed: wrong user name or password");
            refuse(
                StatusCode::UNAUTHORIZED,
                "login",
                "wrong user name or password",
            )
        }
    }
}

async fn logout(State(auth): State<Arc<Auth>>, request: Request) -> Response {
    let addr = client(&request);
    let id = request
        .extensions()
        .get::<SessionId>()
        .and_then(|s| s.0.clone());
    let who = request.extensions().get::<Who>().cloned();
    if let Some(id) = id {
        auth.state().sessions.remove(&id);
    }
    if let Some(w) = &who {
        tracing::info!(%addr, user = %w.user, "page log-out");
    }
    let mut r = answer(StatusCode::OK, &session_json(&auth, None, None));
    r.headers_mut().insert(
        header::SET_COOKIE,
        HeaderValue::from_static(cleared_cookie()),
    );
    r
}

#[cfg(test)]
#[path = "auth/tests.rs"]
mod tests;
