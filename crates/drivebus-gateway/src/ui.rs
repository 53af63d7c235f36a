//! The browser page (`[ui] listen`): every bus and drive of the plant with its live values,
//! served on a loopback address (`docs/ui.md`).
//!
//! The bus tasks' [`Update`]s pass through the [`Hub`] on their way to the MQTT task (or
//! instead of it, with `broker = "off"`): the hub keeps the latest of each (value, status,
//! figures) for a page that has just loaded (`GET /api/plant`) and hands every one to the pages
//! that watch (`GET /api/events`, server-sent events, one JSON object per event). The page
//! never polls. A page that falls behind by more than [`EVENTS`] events is told to load the
//! plant again (`{"type":"resync"}`) instead of being sent old values.
//!
//! Who may use the page, and how, is [`auth`]'s: on a page without users every request must
//! name a loopback host in its `Host` header, so that a web site a browser on this machine
//! visits cannot reach the page through a name that resolves to 127.0.0.1 (DNS rebinding);
//! with users, a session. The page loads nothing from elsewhere: its files are in the binary.

use std::convert::Infallible;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError, RwLock};

use axum::Router;
use axum::extract::{Request, State};
use axum::http::{HeaderValue, StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use serde_json::{Value, json};
use tokio::sync::{broadcast, mpsc};

use crate::config::Plant;
use crate::error::{Error, Result};
use crate::model::{Ask, BusIx, Reconfig, Update};
use crate::mqtt::payload;

pub mod auth;
pub mod control;
pub mod history;

/// How many events a watching page may fall behind before it is told to load the plant again.
pub const EVENTS: usize = 1024;

const INDEX_HTML: &str = include_str!("ui/index.html");
const APP_JS: &str = include_str!("ui/app.js");
const DRIVE_JS: &str = include_str!("ui/drive.js");
const TREND_JS: &str = include_str!("ui/trend.js");
const EVENTS_JS: &str = include_str!("ui/events.js");
const STYLE_CSS: &str = include_str!("ui/style.css");

/// The latest of everything the buses reported, and the pages that watch.
#[derive(Debug)]
pub struct Hub {
    plant: RwLock<Arc<Plant>>,
    latest: Mutex<Latest>,
    /// The last 10 minutes of every point (the trend's history).
    history: Mutex<history::History>,
    events: broadcast::Sender<Arc<str>>,
    /// Each bus task's way in for the page's requests (`[bus]`); empty: the page only watches.
    asks: RwLock<Arc<[mpsc::Sender<Ask>]>>,
    /// Where the page's jobs run (on the gateway's thread).
    jobs: Option<drive::Jobs>,
    /// The config's generation the plant is of (a page sends the one it shows).
    generation: AtomicU64,
    /// For the last few generations before this one: where each of its buses is now (`None`:
    /// removed or restarted with other settings), so that a page that has not yet loaded the
    /// reloaded plant still reaches the drives it shows, and never another one.
    earlier: Mutex<std::collections::VecDeque<(u64, Vec<Option<BusIx>>)>>,
}

/// How many earlier generations a page may still name.
const EARLIER_GENERATIONS: usize = 8;

/// A page named a bus of an earlier config that the reloaded one removed or runs with other
/// settings (or a generation too old to know).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reloaded;

/// The latest payload of each value, status and bus figures, as published on MQTT.
#[derive(Debug)]
struct Latest {
    /// `[bus][drive][point]`.
    values: Vec<Vec<Vec<Option<Value>>>>,
    /// `[bus][drive]`.
    status: Vec<Vec<Option<Value>>>,
    /// `[bus][drive]`: process input words.
    process_data: Vec<Vec<Option<Value>>>,
    /// `[bus]`.
    figures: Vec<Option<Value>>,
}

impl Latest {
    /// Nothing known yet of `plant`.
    fn of(plant: &Plant) -> Latest {
        Latest {
            values: plant
                .buses
                .iter()
                .map(|b| {
                    b.drives
                        .iter()
                        .map(|d| vec![None; d.points.len()])
                        .collect()
                })
                .collect(),
            status: plant
                .buses
                .iter()
                .map(|b| vec![None; b.drives.len()])
                .collect(),
            process_data: plant
                .buses
                .iter()
                .map(|b| vec![None; b.drives.len()])
                .collect(),
            figures: vec![None; plant.buses.len()],
        }
    }
}

/// Move `from[a]` into `to[b]` (a kept bus's latest), where both are.
fn move_at<T: Default>(from: &mut [T], a: usize, to: &mut [T], b: usize) {
    if let (Some(x), Some(y)) = (from.get_mut(a), to.get_mut(b)) {
        *y = std::mem::take(x);
    }
}

impl Hub {
    /// A hub for `plant` that only watches (no requests reach the buses), nothing reported yet.
    pub fn new(plant: Arc<Plant>) -> Arc<Hub> {
        Hub::serving(plant, Vec::new(), None)
    }

    /// A hub for `plant` whose page also reads and writes: `asks` reach each bus task, `jobs`
    /// run the page's work on the gateway's thread.
    pub fn serving(
        plant: Arc<Plant>,
        asks: Vec<mpsc::Sender<Ask>>,
        jobs: Option<drive::Jobs>,
    ) -> Arc<Hub> {
        let (events, _) = broadcast::channel(EVENTS);
        Arc::new(Hub {
            history: Mutex::new(history::History::new(&plant)),
            latest: Mutex::new(Latest::of(&plant)),
            plant: RwLock::new(plant),
            events,
            asks: RwLock::new(asks.into()),
            jobs,
            generation: AtomicU64::new(1),
            earlier: Mutex::new(std::collections::VecDeque::new()),
        })
    }

    /// The plant the page shows now.
    pub fn plant(&self) -> Arc<Plant> {
        self.plant
            .read()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }

    /// Each bus task's way in for the page's requests.
    pub fn asks(&self) -> Arc<[mpsc::Sender<Ask>]> {
        self.asks
            .read()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }

    /// A hub started by a reload: its plant is of `generation`.
    pub fn begin_at(&self, generation: u64) {
        self.generation.store(generation, Ordering::Relaxed);
    }

    /// The config's generation the plant is of.
    pub fn generation(&self) -> u64 {
        self.generation.load(Ordering::Relaxed)
    }

    /// Bus `bus` of the plant of generation `seen` (what a page shows; `None`: the page did not
    /// say, the current plant's) in the current plant.
    pub fn resolve(&self, seen: Option<u64>, bus: usize) -> std::result::Result<usize, Reloaded> {
        let now = self.generation();
        match seen {
            None => Ok(bus),
            Some(g) if g == now => Ok(bus),
            Some(g) => self
                .earlier
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .iter()
                .find(|(e, _)| *e == g)
                .and_then(|(_, map)| map.get(bus).copied().flatten())
                .ok_or(Reloaded),
        }
    }

    /// A reloaded config takes effect: the new plant, with the latest of the buses that keep
    /// running; every watching page is told (`{"type":"reload","generation":N}`) and loads the
    /// plant again.
    pub fn reconfigure(&self, r: &Reconfig) {
        {
            let mut latest = self.latest.lock().unwrap_or_else(PoisonError::into_inner);
            let mut new = Latest::of(&r.plant);
            for (from, to) in r.kept.iter().enumerate() {
                let Some(to) = *to else { continue };
                move_at(&mut latest.values, from, &mut new.values, to);
                move_at(&mut latest.status, from, &mut new.status, to);
                move_at(&mut latest.process_data, from, &mut new.process_data, to);
                move_at(&mut latest.figures, from, &mut new.figures, to);
            }
            *latest = new;
        }
        self.history_mut().reconfigure(&r.plant, &r.kept);
        {
            let mut earlier = self.earlier.lock().unwrap_or_else(PoisonError::into_inner);
            // Maps of older generations go through this reload too.
            for (_, map) in earlier.iter_mut() {
                for to in map.iter_mut() {
                    *to = to.and_then(|b| r.kept(b));
                }
            }
            earlier.push_front((self.generation(), r.kept.clone()));
            earlier.truncate(EARLIER_GENERATIONS);
        }
        *self.asks.write().unwrap_or_else(PoisonError::into_inner) = r.asks.clone().into();
        *self.plant.write().unwrap_or_else(PoisonError::into_inner) = r.plant.clone();
        self.generation.store(r.generation, Ordering::Relaxed);
        let _ = self.events.send(Arc::from(
            json!({"type": "reload", "generation": r.generation}).to_string(),
        ));
    }

    /// Keep `u` as the latest of its kind and send it to every watching page. An update for a
    /// bus, drive or point the plant does not have is dropped.
    pub fn apply(&self, u: &Update) {
        let Some(event) = self.keep(u) else { return };
        // Written out only for pages that watch.
        if self.events.receiver_count() > 0 {
            let _ = self.events.send(Arc::from(event.to_string()));
        }
    }

    fn keep(&self, u: &Update) -> Option<Value> {
        let mut latest = self.latest.lock().unwrap_or_else(PoisonError::into_inner);
        match u {
            Update::Value {
                bus,
                drive,
                point,
                raw,
                at,
            } => {
                let plant = self.plant();
                let d = plant.buses.get(*bus)?.drives.get(*drive)?;
                let p = d.points.get(*point)?;
                let ts = payload::millis(*at);
                let v = payload::value_json(&p.target, *raw, ts, &d.device);
                self.history_mut().push(*bus, *drive, *point, ts, *raw);
                let s = latest
                    .values
                    .get_mut(*bus)?
                    .get_mut(*drive)?
                    .get_mut(*point)?;
                *s = Some(v.clone());
                Some(
                    json!({"type": "value", "bus": bus, "drive": drive, "point": point, "payload": v}),
                )
            }
            Update::Status {
                bus,
                drive,
                status,
                at,
            } => {
                let v = payload::status_json(status, payload::millis(*at));
                *latest.status.get_mut(*bus)?.get_mut(*drive)? = Some(v.clone());
                Some(json!({"type": "status", "bus": bus, "drive": drive, "payload": v}))
            }
            Update::ProcessData {
                bus,
                drive,
                words,
                at,
            } => {
                let v = json!({"in": words, "ts": payload::millis(*at)});
                *latest.process_data.get_mut(*bus)?.get_mut(*drive)? = Some(v.clone());
                Some(json!({"type": "process_data", "bus": bus, "drive": drive, "payload": v}))
            }
            Update::Figures { bus, figures } => {
                let ts = payload::millis(std::time::SystemTime::now());
                let v = payload::figures_json(figures, ts);
                *latest.figures.get_mut(*bus)? = Some(v.clone());
                Some(json!({"type": "figures", "bus": bus, "payload": v}))
            }
            // The relay hands a reload to [`Hub::reconfigure`].
            Update::Reconfigured(_) => None,
        }
    }

    /// The plant with the latest of everything: what `GET /api/plant` answers.
    pub fn plant_json(&self) -> Value {
        let latest = self.latest.lock().unwrap_or_else(PoisonError::into_inner);
        let get = |v: Option<&Option<Value>>| v.and_then(Clone::clone).unwrap_or(Value::Null);
        let plant = self.plant();
        let buses: Vec<Value> = plant
            .buses
            .iter()
            .enumerate()
            .map(|(b, bus)| {
                let drives: Vec<Value> = bus
                    .drives
                    .iter()
                    .enumerate()
                    .map(|(d, drive)| {
                        let points: Vec<Value> = drive
                            .points
                            .iter()
                            .enumerate()
                            .map(|(p, point)| {
                                let t = &point.target;
                                json!({
                                    "name": point.name,
                                    "label": t.label(),
                                    "name_en": t.param.map(|q| q.name_en()),
                                    "name_de": t.param.map(|q| q.name_de()),
                                    "writable": point.writable,
                                    // Milliseconds; `null`: read only after a write.
                                    "period_ms": point.period.map(|d| u64::try_from(d.as_millis()).unwrap_or(u64::MAX)),
                                    "latest": get(latest.values.get(b).and_then(|x| x.get(d)).and_then(|x| x.get(p))),
                                })
                            })
                            .collect();
                        json!({
                            "name": drive.name,
                            "address": drive.address,
                            "status": get(latest.status.get(b).and_then(|x| x.get(d))),
                            "process_data": get(latest.process_data.get(b).and_then(|x| x.get(d))),
                            "points": points,
                            "control": control::drive_json(bus, drive),
                        })
                    })
                    .collect();
                json!({
                    "name": bus.name,
                    "protocol": bus.protocol.name(),
                    "figures": get(latest.figures.get(b)),
                    "drives": drives,
                })
            })
            .collect();
        json!({"gateway": plant.gateway.name, "generation": self.generation(), "buses": buses})
    }

    fn history_mut(&self) -> std::sync::MutexGuard<'_, history::History> {
        self.history.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// What `GET /api/history/{bus}/{drive}/{point}` answers at `now` (ms since the epoch);
    /// `None` for a point the plant does not have.
    pub fn history_json(&self, at: (usize, usize, usize), now: u64) -> Option<Value> {
        let (samples, size) = {
            let h = self.history_mut();
            (h.samples(at.0, at.1, at.2, now)?, h.size(at.0, at.1, at.2)?)
        };
        history::history_value(&self.plant(), at, &samples, size, now)
    }

    /// A new watcher of every event from now on.
    pub fn subscribe(&self) -> broadcast::Receiver<Arc<str>> {
        self.events.subscribe()
    }
}

/// Pass every update of the bus tasks to the hub and on to `onward` (the MQTT task), until the
/// bus tasks are gone. A full `onward` holds the buses back as it would without the page.
pub async fn relay(
    hub: Arc<Hub>,
    mut updates: mpsc::Receiver<Update>,
    onward: Option<mpsc::Sender<Update>>,
) {
    while let Some(u) = updates.recv().await {
        hub.apply(&u);
        if let Some(tx) = &onward
            && tx.send(u).await.is_err()
        {
            // The MQTT task ended; the page goes on.
        }
    }
}

/// Bind the page's listener (before any bus opens, so a taken port is an error at the start).
pub async fn bind(addr: SocketAddr) -> Result<tokio::net::TcpListener> {
    tokio::net::TcpListener::bind(addr)
        .await
        .map_err(|e| Error::failed(format!("[ui] listen = \"{addr}\": cannot listen: {e}")))
}

/// Serve the page on `listener` until `shutdown` resolves: a loopback page without TLS or users.
pub async fn serve(
    listener: tokio::net::TcpListener,
    hub: Arc<Hub>,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> Result<()> {
    serve_with(listener, hub, auth::Security::local()?, shutdown).await
}

/// Serve the page on `listener` with `security` (TLS, users) until `shutdown` resolves.
pub async fn serve_with(
    listener: tokio::net::TcpListener,
    hub: Arc<Hub>,
    security: auth::Security,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> Result<()> {
    let app = router_with(hub, security.auth);
    auth::tls::serve(listener, app, security.tls, shutdown).await
}

/// The page's routes, on a loopback page without users.
pub fn router(hub: Arc<Hub>) -> Result<Router> {
    Ok(router_with(hub, auth::Auth::local()?))
}

/// The page's routes, each behind [`auth::guard`].
pub fn router_with(hub: Arc<Hub>, auth: Arc<auth::Auth>) -> Router {
    Router::new()
        .route(
            "/",
            get(|| async { file(INDEX_HTML, "text/html; charset=utf-8") }),
        )
        .route(
            "/app.js",
            get(|| async { file(APP_JS, "text/javascript; charset=utf-8") }),
        )
        .route(
            "/drive.js",
            get(|| async { file(DRIVE_JS, "text/javascript; charset=utf-8") }),
        )
        .route(
            "/events.js",
            get(|| async { file(EVENTS_JS, "text/javascript; charset=utf-8") }),
        )
        .route(
            "/trend.js",
            get(|| async { file(TREND_JS, "text/javascript; charset=utf-8") }),
        )
        .route(
            "/style.css",
            get(|| async { file(STYLE_CSS, "text/css; charset=utf-8") }),
        )
        .route("/api/plant", get(plant))
        .route("/api/events", get(events))
        .route("/api/drive/{bus}/{drive}/params", get(params))
        .route("/api/drive/{bus}/{drive}/read", get(read))
        .route("/api/drive/{bus}/{drive}/faults", get(faults))
        .route("/api/drive/{bus}/{drive}/check", get(check))
        .route("/api/drive/{bus}/{drive}/write", post(write))
        .route("/api/drive/{bus}/{drive}/backup", get(backup))
        .route(
            "/api/drive/{bus}/{drive}/restore",
            post(restore).layer(axum::extract::DefaultBodyLimit::max(
                usize::try_from(drive_client::backup::MAX_LEN).unwrap_or(usize::MAX),
            )),
        )
        .route("/api/history/{bus}/{drive}/{point}", get(history))
        .merge(control::routes())
        .merge(auth::routes(auth.clone()))
        .layer(middleware::from_fn_with_state(auth, auth::guard))
        .layer(middleware::from_fn(guard))
        .with_state(hub)
}

fn file(body: &'static str, kind: &'static str) -> Response {
    ([(header::CONTENT_TYPE, kind)], body).into_response()
}

async fn plant(State(hub): State<Arc<Hub>>) -> Response {
    (
        [(header::CONTENT_TYPE, "application/json")],
        hub.plant_json().to_string(),
    )
        .into_response()
}

async fn events(
    State(hub): State<Arc<Hub>>,
) -> Sse<impl futures_util::Stream<Item = std::result::Result<Event, Infallible>>> {
    let rx = hub.subscribe();
    let stream = futures_util::stream::unfold(rx, |mut rx| async move {
        let data = event_data(rx.recv().await)?;
        Some((Ok(Event::default().data(&*data)), rx))
    });
    Sse::new(stream).keep_alive(KeepAlive::default())
}

/// `?search=TERM` of the parameter list.
#[derive(Debug, serde::Deserialize)]
pub struct Search {
    /// Part of a German or English name (case and umlauts folded: `ueberwachung` finds
    /// `Überwachung`); none lists every parameter.
    pub search: Option<String>,
}

/// The most parameters one answer lists (the MOVIDRIVE table has more: search narrows it).
pub const MAX_PARAMS: usize = 2000;

/// The parameter table of a drive's family, as the page lists it: the manual's number and
/// group, both names, unit, access, range, default and value list of each parameter that
/// matches `search`. `None` for a bus or drive the plant does not have.
pub fn params_json(plant: &Plant, bus: usize, drive: usize, search: Option<&str>) -> Option<Value> {
    let b = plant.buses.get(bus)?;
    let d = b.drives.get(drive)?;
    let family = b.protocol.family();
    let term = search.map(str::trim).filter(|t| !t.is_empty());
    let rows: Vec<Value> = drive_profile::family::params(family)
        .filter(|p| term.is_none_or(|t| drive_profile::ParamMeta::name_matches(*p, t)))
        .take(MAX_PARAMS)
        .map(|p| {
            let full = drive_client::meaning::param_json(p);
            let key = |k: &str| full.get(k).cloned().unwrap_or(Value::Null);
            json!({
                "key": drive::key_of(&drive_client::target::Target {
                    sub: drive::page_sub(p),
                    ..drive_client::target::Target::of(p)
                }),
                "number": key("number"), "index": key("index"),
                "name_de": key("name_de"), "name_en": key("name_en"),
                "group_de": key("group_de"), "group_en": key("group_en"),
                "unit": key("unit"), "access": key("access"),
                "min": full.pointer("/range/min_value").cloned().unwrap_or(Value::Null),
                "max": full.pointer("/range/max_value").cloned().unwrap_or(Value::Null),
                "default": key("default_value"), "values": key("values"),
            })
        })
        .collect();
    Some(json!({
        "bus": b.name, "drive": d.name, "address": d.address,
        "family": family.to_string(), "search": term, "params": rows,
    }))
}

async fn params(
    State(hub): State<Arc<Hub>>,
    DriveAt(bus, drive): DriveAt,
    axum::extract::Query(q): axum::extract::Query<Search>,
) -> Response {
    match params_json(&hub.plant(), bus, drive, q.search.as_deref()) {
        Some(v) => ([(header::CONTENT_TYPE, "application/json")], v.to_string()).into_response(),
        None => (StatusCode::NOT_FOUND, "no such bus or drive\n").into_response(),
    }
}

/// The header in which a page names the config generation of the plant it shows.
pub const GENERATION_HEADER: &str = "x-drivebus-generation";

/// The generation a request names ([`GENERATION_HEADER`]; `None` without one: the current
/// plant), or the answer to a header that is no number.
fn generation_of(
    parts: &axum::http::request::Parts,
) -> std::result::Result<Option<u64>, Box<Response>> {
    let Some(v) = parts.headers.get(GENERATION_HEADER) else {
        return Ok(None);
    };
    match v.to_str().ok().and_then(|t| t.trim().parse().ok()) {
        Some(g) => Ok(Some(g)),
        None => Err(Box::new(json_response(
            StatusCode::BAD_REQUEST,
            &json!({"error": "bad_request", "message": format!("{GENERATION_HEADER} is no number")}),
        ))),
    }
}

/// The answer to a page that names a bus the reloaded config removed or restarted.
fn reloaded() -> Response {
    json_response(
        StatusCode::CONFLICT,
        &json!({"error": "reloaded", "ok": false, "message": "the gateway's config was reloaded and this drive's bus changed or is gone: go back to the plant, which shows the reloaded config"}),
    )
}

/// Bus `bus` of the plant the request's generation names, as the current plant's (refused with
/// 409 where a reload removed or restarted it, 400 for a generation that is no number).
fn now_bus(
    parts: &axum::http::request::Parts,
    hub: &Hub,
    bus: usize,
) -> std::result::Result<usize, Box<Response>> {
    let seen = generation_of(parts)?;
    hub.resolve(seen, bus).map_err(|_| Box::new(reloaded()))
}

/// A drive a page names by `{bus}/{drive}` of the plant it shows, as indices of the current
/// plant (a reload may have moved its bus; a bus it removed or restarted is refused with 409).
#[derive(Debug, Clone, Copy)]
pub struct DriveAt(pub usize, pub usize);

impl axum::extract::FromRequestParts<Arc<Hub>> for DriveAt {
    type Rejection = Response;

    async fn from_request_parts(
        parts: &mut axum::http::request::Parts,
        hub: &Arc<Hub>,
    ) -> std::result::Result<Self, Response> {
        let axum::extract::Path((bus, drive)) =
            axum::extract::Path::<(usize, usize)>::from_request_parts(parts, hub)
                .await
                .map_err(IntoResponse::into_response)?;
        Ok(DriveAt(now_bus(parts, hub, bus).map_err(|r| *r)?, drive))
    }
}

/// A point a page names by `{bus}/{drive}/{point}`, as [`DriveAt`].
#[derive(Debug, Clone, Copy)]
pub struct PointAt(pub usize, pub usize, pub usize);

impl axum::extract::FromRequestParts<Arc<Hub>> for PointAt {
    type Rejection = Response;

    async fn from_request_parts(
        parts: &mut axum::http::request::Parts,
        hub: &Arc<Hub>,
    ) -> std::result::Result<Self, Response> {
        let axum::extract::Path((bus, drive, point)) =
            axum::extract::Path::<(usize, usize, usize)>::from_request_parts(parts, hub)
                .await
                .map_err(IntoResponse::into_response)?;
        Ok(PointAt(
            now_bus(parts, hub, bus).map_err(|r| *r)?,
            drive,
            point,
        ))
    }
}

fn json_response(status: StatusCode, v: &Value) -> Response {
    (
        status,
        [(header::CONTENT_TYPE, "application/json")],
        v.to_string(),
    )
        .into_response()
}

fn not_found() -> Response {
    json_response(
        StatusCode::NOT_FOUND,
        &json!({"error": "not_found", "message": "no such bus or drive"}),
    )
}

fn unavailable(message: &str) -> Response {
    json_response(
        StatusCode::SERVICE_UNAVAILABLE,
        &json!({"error": "unavailable", "message": message}),
    )
}

/// Run `work` on drive `drive` of bus `bus` as a job whose JSON lines are the answer's body
/// (`application/x-ndjson`); a drive the bus task cannot be asked about is one error line.
fn streamed<F, Fut>(hub: &Hub, bus: usize, drive: usize, work: F) -> Response
where
    F: FnOnce(drive::Remote, drive::Lines) -> Fut + Send + 'static,
    Fut: std::future::Future<Output = ()> + 'static,
{
    let Some(asks) = drive::asks_for(&hub.asks(), bus, drive, &hub.plant()) else {
        return not_found();
    };
    let Some(jobs) = &hub.jobs else {
        return unavailable("this page only watches: it cannot reach the buses");
    };
    let max_age = hub.plant().gateway.max_set_age;
    let (lines, rx) = drive::Lines::new();
    let job: drive::Job = Box::new(move || {
        Box::pin(async move {
            match drive::Remote::connect(asks, drive, max_age).await {
                Ok(remote) => work(remote, lines).await,
                Err(e) => {
                    let mut o = drive::error_json(&e);
                    if let Some(m) = o.as_object_mut() {
                        m.insert("type".into(), "error".into());
                    }
                    lines.send(&o);
                }
            }
        })
    });
    if !jobs.run(job) {
        return unavailable("the gateway is stopping");
    }
    let body = futures_util::stream::unfold(rx, |mut rx| async move {
        let line = rx.recv().await?;
        Some((Ok::<_, Infallible>(line), rx))
    });
    (
        [(header::CONTENT_TYPE, "application/x-ndjson")],
        axum::body::Body::from_stream(body),
    )
        .into_response()
}

/// Run `work` on a drive as a job and answer its one JSON value.
async fn answered<F, Fut>(hub: &Hub, bus: usize, drive: usize, work: F) -> Response
where
    F: FnOnce(drive::Remote) -> Fut + Send + 'static,
    Fut: std::future::Future<Output = Value> + 'static,
{
    let Some(asks) = drive::asks_for(&hub.asks(), bus, drive, &hub.plant()) else {
        return not_found();
    };
    let Some(jobs) = &hub.jobs else {
        return unavailable("this page only watches: it cannot reach the buses");
    };
    let max_age = hub.plant().gateway.max_set_age;
    let (tx, rx) = tokio::sync::oneshot::channel();
    let job: drive::Job = Box::new(move || {
        Box::pin(async move {
            let v = match drive::Remote::connect(asks, drive, max_age).await {
                Ok(remote) => work(remote).await,
                Err(e) => {
                    let mut o = drive::error_json(&e);
                    if let Some(m) = o.as_object_mut() {
                        m.insert("outcome".into(), "refused".into());
                        m.insert("ok".into(), false.into());
                    }
                    o
                }
            };
            let _ = tx.send(v);
        })
    });
    if !jobs.run(job) {
        return unavailable("the gateway is stopping");
    }
    match rx.await {
        Ok(v) => json_response(StatusCode::OK, &v),
        Err(_) => unavailable("the gateway is stopping"),
    }
}

/// `?keys=8470.0,8471.0` of a read on demand.
#[derive(Debug, serde::Deserialize)]
pub struct Keys {
    /// The parameters, by the `key` of the parameter list, comma-separated.
    pub keys: String,
}

async fn read(
    State(hub): State<Arc<Hub>>,
    DriveAt(bus, d): DriveAt,
    axum::extract::Query(q): axum::extract::Query<Keys>,
) -> Response {
    let Some(family) = hub.plant().buses.get(bus).map(|b| b.protocol.family()) else {
        return not_found();
    };
    let mut targets = Vec::new();
    for k in q.keys.split(',').map(str::trim).filter(|k| !k.is_empty()) {
        match drive::target_of(family, k) {
            Some(t) if targets.len() < MAX_PARAMS => targets.push(t),
            Some(_) => {
                return json_response(
                    StatusCode::BAD_REQUEST,
                    &json!({"error": "bad_request", "message": format!("at most {MAX_PARAMS} parameters per read")}),
                );
            }
            None => {
                return json_response(
                    StatusCode::BAD_REQUEST,
                    &json!({"error": "bad_request", "message": format!("the {family} table has no parameter {k}")}),
                );
            }
        }
    }
    streamed(&hub, bus, d, move |mut remote, lines| async move {
        drive::read_all(&mut remote, targets, lines).await;
    })
}

async fn faults(State(hub): State<Arc<Hub>>, DriveAt(bus, d): DriveAt) -> Response {
    let Some(family) = hub.plant().buses.get(bus).map(|b| b.protocol.family()) else {
        return not_found();
    };
    let targets = drive::fault_targets(family);
    streamed(&hub, bus, d, move |mut remote, lines| async move {
        drive::read_all(&mut remote, targets, lines).await;
    })
}

/// `?key=&value=&eeprom=` of a write's check.
#[derive(Debug, serde::Deserialize)]
pub struct CheckQuery {
    /// The parameter.
    pub key: String,
    /// The value as typed.
    pub value: String,
    /// To EEPROM too.
    #[serde(default)]
    pub eeprom: bool,
}

async fn check(
    State(hub): State<Arc<Hub>>,
    DriveAt(bus, d): DriveAt,
    axum::extract::Query(q): axum::extract::Query<CheckQuery>,
) -> Response {
    let ask = drive::WriteAsk {
        key: q.key,
        value: q.value,
        eeprom: q.eeprom,
        confirm: false,
    };
    answered(&hub, bus, d, move |mut remote| async move {
        drive::check(&mut remote, &ask).await.json
    })
    .await
}

async fn write(
    State(hub): State<Arc<Hub>>,
    DriveAt(bus, d): DriveAt,
    who: Option<axum::Extension<auth::Who>>,
    axum::Json(ask): axum::Json<drive::WriteAsk>,
) -> Response {
    let Some(what) = drive_words(&hub, bus, d) else {
        return not_found();
    };
    let who = who.map(|w| w.0);
    answered(&hub, bus, d, move |mut remote| async move {
        let v = drive::write(&mut remote, &ask).await;
        let outcome = v
            .get("outcome")
            .and_then(serde_json::Value::as_str)
            .unwrap_or("?");
        let reason = v.get("reason").and_then(serde_json::Value::as_str);
        if let Some(who) = &who {
            auth::action(
                who,
                &format!(
                    "write {} = {} ({}) to {what}",
                    ask.key,
                    ask.value,
                    if ask.eeprom { "EEPROM" } else { "RAM" }
                ),
                &reason.map_or_else(|| outcome.to_owned(), |r| format!("{outcome}: {r}")),
            );
        }
        v
    })
    .await
}

/// `drive NAME on bus NAME`, for the action log; `None` for a drive the plant does not have.
fn drive_words(hub: &Hub, bus: usize, drive: usize) -> Option<String> {
    let plant = hub.plant();
    let b = plant.buses.get(bus)?;
    let d = b.drives.get(drive)?;
    Some(format!("drive {} on bus {}", d.name, b.name))
}

async fn backup(State(hub): State<Arc<Hub>>, DriveAt(bus, d): DriveAt) -> Response {
    streamed(&hub, bus, d, move |mut remote, lines| async move {
        drive::backup(&mut remote, lines).await;
    })
}

/// `?apply=true&name=FILE` of a restore.
#[derive(Debug, serde::Deserialize)]
pub struct RestoreQuery {
    /// Write the changes (else only the plan).
    #[serde(default)]
    pub apply: bool,
    /// The file's name, for the report.
    #[serde(default)]
    pub name: Option<String>,
}

async fn restore(
    State(hub): State<Arc<Hub>>,
    DriveAt(bus, d): DriveAt,
    axum::extract::Query(q): axum::extract::Query<RestoreQuery>,
    who: Option<axum::Extension<auth::Who>>,
    body: axum::body::Bytes,
) -> Response {
    let name = q.name.filter(|n| !n.is_empty()).map_or_else(
        || "the uploaded file".to_owned(),
        |n| n.chars().take(200).collect(),
    );
    let Some(what) = drive_words(&hub, bus, d) else {
        return not_found();
    };
    let apply = q.apply;
    let who = who.map(|w| w.0);
    streamed(&hub, bus, d, move |mut remote, lines| async move {
        let outcome = drive::restore(&mut remote, body.to_vec(), name.clone(), apply, lines).await;
        if let (true, Some(who)) = (apply, &who) {
            auth::action(who, &format!("restore {name} to {what}"), outcome);
        }
    })
}

async fn history(State(hub): State<Arc<Hub>>, PointAt(b, d, p): PointAt) -> Response {
    match hub.history_json((b, d, p), payload::millis(std::time::SystemTime::now())) {
        Some(v) => ([(header::CONTENT_TYPE, "application/json")], v.to_string()).into_response(),
        None => (StatusCode::NOT_FOUND, "no such bus, drive or point\n").into_response(),
    }
}

/// What a watching page is sent for what its receiver got: the event; `{"type":"resync"}`
/// when it fell behind (it loads the plant again rather than being sent old values); nothing
/// more once the hub is gone.
fn event_data(got: std::result::Result<Arc<str>, broadcast::error::RecvError>) -> Option<Arc<str>> {
    match got {
        Ok(e) => Some(e),
        Err(broadcast::error::RecvError::Lagged(_)) => Some(Arc::from(r#"{"type":"resync"}"#)),
        Err(broadcast::error::RecvError::Closed) => None,
    }
}

/// Whether a `Host` header names this machine: `localhost`, `127.0.0.1` or `[::1]`, with or
/// without a port.
pub fn loopback_host(host: &str) -> bool {
    let name = if let Some(rest) = host.strip_prefix('[') {
        rest.split_once(']').map_or("", |(n, _)| n)
    } else {
        host.rsplit_once(':').map_or(host, |(n, _)| n)
    };
    matches!(name, "localhost" | "::1")
        || name
            .parse::<std::net::Ipv4Addr>()
            .is_ok_and(|ip| ip.is_loopback())
}

/// Give every answer (refusals too) the headers that keep a browser from caching it, sniffing
/// it or loading anything from elsewhere.
async fn guard(request: Request, next: Next) -> Response {
    let mut response = next.run(request).await;
    let h = response.headers_mut();
    h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    h.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    h.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
    h.insert(
        header::CONTENT_SECURITY_POLICY,
        // `blob:` images: the trend's PNG export draws its SVG onto a canvas.
        HeaderValue::from_static(
            "default-src 'self'; img-src 'self' blob:; frame-ancestors 'none'",
        ),
    );
    response
}

/// A plant of one bus made from a command line (`drivectl ui movilink --port …`): the drives
/// at `addresses`, each with its family's usual points, the page on `listen`, no broker.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OneBus {
    /// The gateway's protocol name (`movilink`, `sbus`, `uss`, `ctt2`, `modbus-rtu`,
    /// `modbus-ascii`).
    pub protocol: String,
    /// The serial port (not SBus).
    pub port: Option<String>,
    /// The CAN interface (SBus).
    pub iface: Option<String>,
    /// The baud rate; `None`: the protocol's factory setting.
    pub baud: Option<u32>,
    /// `even`, `odd` or `none`; `None`: the protocol's factory setting.
    pub parity: Option<String>,
    /// The drives' addresses.
    pub addresses: Vec<u8>,
    /// Run on simulated drives.
    pub simulate: bool,
    /// Where the page is served.
    pub listen: SocketAddr,
    /// The response timeout of one attempt, in ms; `None`: the protocol's.
    pub timeout_ms: Option<u64>,
    /// Attempts after a failed one; `None`: the gateway's default.
    pub retries: Option<u8>,
    /// The serial adapter echoes what it sends (`echo = true`).
    pub echo: bool,
    /// Kernel RS-485 mode (`rs485 = true` and its settings).
    pub rs485: Option<drive_transport::serial::Rs485Config>,
}

/// The points every drive of a [`OneBus`] plant shows, per family: (name, parameter, selector
/// key and value, poll period).
fn usual_points(
    protocol: &str,
) -> &'static [(&'static str, &'static str, &'static str, &'static str)] {
    match protocol {
        "movilink" | "sbus" => &[
            ("speed", "P000", "", "500ms"),
            ("current", "P004", "", "500ms"),
            ("drive_status", "P010", "", "1s"),
            ("fault", "P012", "", "1s"),
        ],
        "uss" => &[
            ("fault", "P700", "array = 1", "1s"),
            ("warning", "P700", "array = 2", "1s"),
            ("max_frequency", "P105", "", "5s"),
        ],
        // The same points slower: a read takes about 0.7 s on the AS-i link of two drives
        // (the CTT2 byte time, BU 0255 4.4), so that two drives fit the wire.
        "ctt2" => &[
            ("fault", "P700", "array = 1", "5s"),
            ("warning", "P700", "array = 2", "10s"),
            ("max_frequency", "P105", "", "30s"),
        ],
        _ => &[
            ("frequency", "241", "", "500ms"),
            ("status_word", "411", "", "1s"),
            ("fault", "260", "", "1s"),
            ("warnings", "270", "", "1s"),
        ],
    }
}

/// The addresses a `--scan` probes by default, per protocol (as `drivectl … scan` does): the
/// protocol's whole range of single drives.
pub fn scan_range(protocol: &str) -> (u8, u8) {
    match protocol {
        "movilink" => (0, 99),
        "sbus" => (0, 63),
        "uss" => (0, 31),
        // The double slaves' numbers (1A…31A).
        "ctt2" => (1, 31),
        _ => (1, 247),
    }
}

impl OneBus {
    /// Probe every address from `from` to `to` on this bus (one read of the drive's fault
    /// status each, no retries): the addresses that answer, in order. `each` hears every
    /// address probed and whether it answered (a refusal answers too). A bus that cannot be
    /// opened answers nowhere.
    pub fn scan(&self, from: u8, to: u8, each: &mut dyn FnMut(u8, bool)) -> Result<Vec<u8>> {
        let probe = OneBus {
            addresses: vec![from],
            ..self.clone()
        };
        let mut plant = Plant::parse(&probe.config(), "the command line")?;
        let Some(mut bus) = plant.buses.pop() else {
            return Ok(Vec::new());
        };
        bus.retries = 0;
        // The simulated bus holds the drives the command line names.
        bus.drives = self
            .addresses
            .iter()
            .filter_map(|a| {
                let mut d = bus.drives.first()?.clone();
                d.address = *a;
                Some(d)
            })
            .collect();
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .map_err(|e| Error::failed(format!("cannot start the runtime: {e}")))?;
        let local = tokio::task::LocalSet::new();
        local.block_on(&rt, async {
            use crate::bus::BusAccess as _;
            let mut access = crate::families::open_bus(&bus);
            let mut found = Vec::new();
            for a in from..=to {
                let answered = match access.fault(a).await {
                    Ok(_) | Err(drive_client::ClientError::Device(_)) => true,
                    Err(_) => false,
                };
                each(a, answered);
                if answered {
                    found.push(a);
                }
            }
            Ok(found)
        })
    }

    /// The plant's config text: checked by [`Plant::parse`] as any config is.
    pub fn config(&self) -> String {
        use std::fmt::Write as _;
        let quoted = |s: &str| serde_json::Value::from(s).to_string();
        // The bus is named after its port or interface (a topic level: no `/`).
        let bus = match (&self.port, &self.iface, self.simulate) {
            (_, _, true) => "simulated".to_owned(),
            // `/dev/ttyUSB0` → `ttyUSB0`, a pseudo-terminal `/dev/pts/3` → `pts-3`.
            (Some(p), _, _) | (None, Some(p), _) => {
                let mut parts = p.rsplit('/');
                let last = parts.next().unwrap_or("bus");
                match parts.next() {
                    Some("pts") => format!("pts-{last}"),
                    _ => last.to_owned(),
                }
            }
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || "._-".contains(c) {
                    c
                } else {
                    '-'
                }
            })
            .take(64)
            .collect(),
            (None, None, false) => "bus".to_owned(),
        };
        let bus = if bus.is_empty() {
            "bus".to_owned()
        } else {
            bus
        };
        let mut t = format!(
            "[gateway]\nname = \"laptop\"\nbroker = \"off\"\nmetrics = \"off\"\n\n\
             [ui]\nlisten = {}\n\n[[bus]]\nname = {}\nprotocol = {}\n",
            quoted(&self.listen.to_string()),
            quoted(&bus),
            quoted(&self.protocol)
        );
        if let Some(p) = &self.port {
            let _ = writeln!(t, "port = {}", quoted(p));
        }
        if let Some(i) = &self.iface {
            let _ = writeln!(t, "iface = {}", quoted(i));
        }
        if let Some(b) = self.baud {
            let _ = writeln!(t, "baud = {b}");
        }
        if let Some(p) = &self.parity {
            let _ = writeln!(t, "parity = {}", quoted(p));
        }
        if self.simulate {
            let _ = writeln!(t, "simulate = true");
        }
        if let Some(ms) = self.timeout_ms {
            let _ = writeln!(t, "timeout = \"{ms}ms\"");
        }
        if let Some(r) = self.retries {
            let _ = writeln!(t, "retries = {r}");
        }
        if self.echo {
            let _ = writeln!(t, "echo = true");
        }
        if let Some(r) = &self.rs485 {
            let rts = if r.rts_on_send { "high" } else { "low" };
            let _ = writeln!(
                t,
                "rs485 = true\nrs485_rts = \"{rts}\"\nrs485_delay_before = \"{}ms\"\n\
                 rs485_delay_after = \"{}ms\"",
                r.delay_rts_before_send_ms, r.delay_rts_after_send_ms
            );
        }
        for a in &self.addresses {
            let _ = write!(t, "\n[[bus.drive]]\nname = \"drive-{a}\"\naddress = {a}\n");
            for (name, param, selector, period) in usual_points(&self.protocol) {
                let _ = write!(
                    t,
                    "\n[[bus.drive.param]]\nparam = \"{param}\"\nname = \"{name}\"\nperiod = \"{period}\"\n"
                );
                if !selector.is_empty() {
                    let _ = writeln!(t, "{selector}");
                }
            }
        }
        t
    }
}

pub mod drive;

#[cfg(test)]
#[path = "ui/tests.rs"]
mod tests;
