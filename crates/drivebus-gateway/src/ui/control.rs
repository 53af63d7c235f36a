//! The page's control of a drive over process data (`page_control = true`, `docs/ui.md`
//! "Process data"): a page takes a drive with `POST …/control/lease`, whose answer stays open
//! as JSON lines of the drive's state each cycle; while it is open the page sends
//! `POST …/control` (`enable` with a setpoint, `setpoint`, `stop`) with the lease's number.
//! When the answer ends — the page closed, reloaded, navigated away or lost its connection —
//! the bus task sends the family's stop at the next cycle ([`crate::task::control`]).

use std::convert::Infallible;
use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use serde_json::{Value, json};
use tokio::sync::{oneshot, watch};

use super::auth::{self, Who};
use super::{DriveAt, Hub, json_response, not_found, unavailable};
use crate::config::{Bus, Drive};
use crate::model::{Answer, Ask, AskOp, ControlOp, PageCommand};
use crate::task::control::{no_control, setpoint_word, unit};

const CONTROL_JS: &str = include_str!("control.js");

/// How often an open lease hears from the gateway when nothing changed: a page that went away
/// is found by the write that fails.
const ALIVE_EVERY: Duration = Duration::from_secs(1);

/// The routes: `/control.js`, `POST /api/drive/{bus}/{drive}/control/lease` and
/// `POST /api/drive/{bus}/{drive}/control`.
pub fn routes() -> Router<Arc<Hub>> {
    Router::new()
        .route(
            "/control.js",
            get(|| async {
                (
                    [(header::CONTENT_TYPE, "text/javascript; charset=utf-8")],
                    CONTROL_JS,
                )
            }),
        )
        .route("/api/drive/{bus}/{drive}/control/lease", post(lease))
        .route("/api/drive/{bus}/{drive}/control", post(command))
}

/// What the plant's JSON says of a drive's control from the page: `{"unit": …}` when the
/// config lets the page drive it, else `null`.
pub fn drive_json(bus: &Bus, drive: &Drive) -> Value {
    match &drive.process_data {
        Some(pd) if pd.page_control => json!({"unit": unit(bus.protocol.family())}),
        _ => Value::Null,
    }
}

/// Why the page may not drive `drive` (403), or nothing.
fn refusal(bus: &Bus, drive: &Drive) -> Option<Response> {
    if drive
        .process_data
        .as_ref()
        .is_some_and(|pd| pd.page_control)
    {
        return None;
    }
    let family = bus.protocol.family();
    let message = if bus.protocol.has_process_data() {
        format!(
            "drive {} on bus {} is not controlled from the page: its config needs \
             [bus.drive.process_data] with page_control = true",
            drive.name, bus.name
        )
    } else {
        no_control(family)
    };
    Some(json_response(
        StatusCode::FORBIDDEN,
        &json!({"error": "not_page_control", "message": message}),
    ))
}

/// Send `op` to the bus task of `bus`'s drive `drive` and wait for its answer.
async fn ask(
    hub: &Hub,
    bus: usize,
    drive: usize,
    op: ControlOp,
) -> Option<Result<Answer, drive_client::ClientError>> {
    let asks = hub.asks().get(bus)?.clone();
    let (reply, answer) = oneshot::channel();
    let ask = Ask {
        drive,
        op: AskOp::Control(op),
        received: tokio::time::Instant::now(),
        max_age: hub.plant().gateway.max_set_age,
        reply,
    };
    asks.send(ask).await.ok()?;
    answer.await.ok()
}

fn refused(e: &drive_client::ClientError) -> Response {
    let message = match e {
        drive_client::ClientError::Request(m) => m.clone(),
        other => other.to_string(),
    };
    json_response(
        StatusCode::CONFLICT,
        &json!({"error": "refused", "ok": false, "message": message}),
    )
}

async fn lease(
    State(hub): State<Arc<Hub>>,
    DriveAt(b, d): DriveAt,
    who: Option<axum::Extension<Who>>,
) -> Response {
    let plant = hub.plant();
    let Some((bus, drive)) = plant
        .buses
        .get(b)
        .and_then(|bus| Some((bus, bus.drives.get(d)?)))
    else {
        return not_found();
    };
    if let Some(r) = refusal(bus, drive) {
        return r;
    }
    let Some(axum::Extension(who)) = who else {
        return unavailable("no user");
    };
    let what = format!("drive {} on bus {}", drive.name, bus.name);
    let (tx, rx) = watch::channel(Value::Null);
    let op = ControlOp::Take {
        who: who.clone(),
        lease: Arc::new(tx),
    };
    let n = match ask(&hub, b, d, op).await {
        Some(Ok(Answer::Lease(n))) => n,
        Some(Ok(_)) | None => return unavailable("the bus task is not running"),
        Some(Err(e)) => return refused(&e),
    };
    auth::action(
        &who,
        &format!("take control of {what}"),
        &format!("lease {n}"),
    );
    let first = json!({
        "type": "lease",
        "lease": n,
        "unit": unit(bus.protocol.family()),
        "note": "closing or reloading this page, leaving this view or losing the connection stops the drive",
    });
    let body = futures_util::stream::unfold((rx, Some(first)), |(mut rx, first)| async move {
        if let Some(f) = first {
            return Some((Ok::<_, Infallible>(format!("{f}\n")), (rx, None)));
        }
        let line = match tokio::time::timeout(ALIVE_EVERY, rx.changed()).await {
            Ok(Ok(())) => rx.borrow_and_update().to_string(),
            // The bus task let the drive go (the gateway stops).
            Ok(Err(_)) => return None,
            Err(_) => json!({"type": "alive"}).to_string(),
        };
        Some((Ok(format!("{line}\n")), (rx, None)))
    });
    (
        [
            (header::CONTENT_TYPE, "application/x-ndjson"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        axum::body::Body::from_stream(body),
    )
        .into_response()
}

/// The body of `POST …/control`.
#[derive(Debug, serde::Deserialize)]
pub struct CommandBody {
    /// The lease's number (the first line of the lease).
    pub lease: u64,
    /// `enable`, `setpoint` (a new setpoint while enabled), `stop`, or `alive` (the page is
    /// still there: every second while it holds the lease).
    pub action: String,
    /// The setpoint as typed, in the unit of the lease (`enable`, `setpoint`; 0 if absent).
    #[serde(default)]
    pub setpoint: Option<String>,
}

async fn command(
    State(hub): State<Arc<Hub>>,
    DriveAt(b, d): DriveAt,
    who: Option<axum::Extension<Who>>,
    axum::Json(body): axum::Json<CommandBody>,
) -> Response {
    let plant = hub.plant();
    let Some((bus, drive)) = plant
        .buses
        .get(b)
        .and_then(|bus| Some((bus, bus.drives.get(d)?)))
    else {
        return not_found();
    };
    if let Some(r) = refusal(bus, drive) {
        return r;
    }
    let Some(axum::Extension(who)) = who else {
        return unavailable("no user");
    };
    let family = bus.protocol.family();
    let what = format!("drive {} on bus {}", drive.name, bus.name);
    if body.action == "alive" {
        return match ask(&hub, b, d, ControlOp::Alive { lease: body.lease }).await {
            Some(Ok(_)) => json_response(StatusCode::OK, &json!({"ok": true})),
            Some(Err(e)) => refused(&e),
            None => unavailable("the bus task is not running"),
        };
    }
    let (command, words) = match body.action.as_str() {
        "enable" | "setpoint" => {
            let text = body.setpoint.as_deref().unwrap_or("0");
            match setpoint_word(family, text) {
                Ok(word) => (
                    PageCommand::Enable { word },
                    format!("{} {what} at {text} {}", body.action, unit(family)),
                ),
                Err(message) => {
                    return json_response(
                        StatusCode::BAD_REQUEST,
                        &json!({"error": "setpoint", "ok": false, "message": format!("{message}; nothing was sent")}),
                    );
                }
            }
        }
        "stop" => (PageCommand::Stop, format!("stop {what}")),
        other => {
            return json_response(
                StatusCode::BAD_REQUEST,
                &json!({"error": "bad_request", "ok": false, "message": format!("action `{}`: give enable, setpoint, stop or alive", other.chars().take(40).collect::<String>())}),
            );
        }
    };
    let op = ControlOp::Command {
        lease: body.lease,
        command,
    };
    match ask(&hub, b, d, op).await {
        Some(Ok(Answer::Text(message))) => {
            auth::action(&who, &words, "sent");
            json_response(StatusCode::OK, &json!({"ok": true, "message": message}))
        }
        Some(Ok(_)) | None => unavailable("the bus task is not running"),
        Some(Err(e)) => {
            auth::action(&who, &words, &format!("refused: {e}"));
            refused(&e)
        }
    }
}
