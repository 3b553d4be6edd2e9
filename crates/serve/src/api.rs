//! The routes: the page, its assets, the JSON API the page itself uses, and the WebSocket.
//!
//! | method and path | takes | gives |
//! |---|---|---|
//! | `GET /` | | the page |
//! | `GET /api/state` | | the state (below) |
//! | `GET /api/library` | | `{"files": [NAME…]}`: the library's songs |
//! | `POST /api/library` | `{"name": NAME}` | the song, read and analysed |
//! | `POST /api/songs?name=FILE` | the file's bytes (`application/octet-stream` or `audio/midi`, at most 16 MiB: 413 past it) | the song, read and analysed |
//! | `GET /api/songs` | | `{"songs": [{"id", "name"}…]}` |
//! | `GET /api/songs/ID` | | the song |
//! | `GET /api/songs/ID/roll.svg` | | its piano roll |
//! | `POST /api/command` | a command, JSON ([`Command`]) | `{"state": STATE}` once the performance shows it |
//! | `GET /api/ended` | | the last performance's report, with its note-by-note account and clock |
//! | `GET /api/ws` | a WebSocket upgrade | the state at once, then each change (at most 30 a second) |
//! | `GET`, `POST /api/session` | | a shared session's state, and its start, stop and tempo ([`crate::session`]) |
//!
//! A song is `{"id", "name", "bars", "seconds", "analysis", "text", "roll"}`: `analysis` is
//! what `orch analyze --json` prints, `text` what `orch analyze` prints. A request refused
//! gets `{"error": WHY}` with 400 (bad input: the message `orch play` gives for a file it
//! cannot play), 404, 409 (nothing playing, or a song already playing), 413 or 415, and
//! changes nothing.

use std::sync::Arc;
use std::time::{Duration, Instant};

use axum::body::Bytes;
use axum::extract::rejection::JsonRejection;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{DefaultBodyLimit, Path, Query, State};
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::Deserialize;
use tokio::sync::broadcast::error::RecvError;

use crate::guard::refuse;
use crate::player::{Command, Player, Reject};
use crate::MAX_UPLOAD;

const INDEX: &str = include_str!("../assets/index.html");
const SCRIPT: &str = include_str!("../assets/app.js");
const STYLE: &str = include_str!("../assets/style.css");

/// The least time between two states sent to a viewer: at most 30 a second.
pub const VIEWER_EVERY: Duration = Duration::from_millis(33);

/// Every route, behind the [`guard`](crate::guard).
pub fn router(player: Arc<Player>) -> Router {
    let access = player.access().clone();
    Router::new()
        .route(
            "/",
            get(|| async { asset(INDEX, "text/html; charset=utf-8") }),
        )
        .route(
            "/assets/app.js",
            get(|| async { asset(SCRIPT, "text/javascript; charset=utf-8") }),
        )
        .route(
            "/assets/style.css",
            get(|| async { asset(STYLE, "text/css; charset=utf-8") }),
        )
        .route("/api/state", get(state))
        .route("/api/library", get(library).post(open_library))
        .route("/api/songs", get(songs).post(upload))
        .route("/api/songs/{id}", get(song))
        .route("/api/songs/{id}/roll.svg", get(roll))
        .route("/api/command", post(command))
        .route("/api/ended", get(ended))
        .route("/api/ws", get(ws))
        .route("/api/session", get(session).post(steer_session))
        .layer(DefaultBodyLimit::max(MAX_UPLOAD))
        .layer(axum::middleware::from_fn_with_state(
            access,
            crate::guard::check,
        ))
        .with_state(player)
}

/// A built-in file, not to be framed by another page.
fn asset(body: &'static str, kind: &'static str) -> Response {
    (
        [
            (header::CONTENT_TYPE, kind),
            (header::CACHE_CONTROL, "no-store"),
            (
                header::CONTENT_SECURITY_POLICY,
                "default-src 'self'; img-src 'self' data:; style-src 'self' 'unsafe-inline'; \
                 frame-ancestors 'none'",
            ),
            (header::X_FRAME_OPTIONS, "DENY"),
        ],
        body,
    )
        .into_response()
}

/// A refusal's status and words.
type Refusal = (StatusCode, String);

fn status_of(r: Reject) -> Refusal {
    let status = match r {
        Reject::Bad(_) => StatusCode::BAD_REQUEST,
        Reject::NotFound(_) => StatusCode::NOT_FOUND,
        Reject::Conflict(_) => StatusCode::CONFLICT,
    };
    (status, r.to_string())
}

fn rejected(r: Reject) -> Response {
    let (status, why) = status_of(r);
    refuse(status, why)
}

/// Runs `f` off the async runtime (reading, analysing, waiting for the performance).
async fn blocking<T: Send + 'static>(
    f: impl FnOnce() -> Result<T, Reject> + Send + 'static,
) -> Result<T, Refusal> {
    match tokio::task::spawn_blocking(f).await {
        Ok(r) => r.map_err(status_of),
        Err(e) => Err((
            StatusCode::INTERNAL_SERVER_ERROR,
            format!("the request failed: {e}"),
        )),
    }
}

async fn state(State(p): State<Arc<Player>>) -> Response {
    Json(p.state()).into_response()
}

async fn library(State(p): State<Arc<Player>>) -> Response {
    match p.library() {
        Ok(files) => Json(serde_json::json!({ "files": files })).into_response(),
        Err(r) => rejected(r),
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LibrarySong {
    name: String,
}

/// A JSON body, or the refusal in JSON.
fn json_body<T>(body: Result<Json<T>, JsonRejection>) -> Result<T, Refusal> {
    body.map(|Json(t)| t)
        .map_err(|e| (e.status(), e.body_text()))
}

async fn open_library(
    State(p): State<Arc<Player>>,
    body: Result<Json<LibrarySong>, JsonRejection>,
) -> Response {
    let name = match json_body(body) {
        Ok(b) => b.name,
        Err((status, why)) => return refuse(status, why),
    };
    match blocking(move || p.load_from_library(&name)).await {
        Ok(song) => Json(song.json()).into_response(),
        Err((status, why)) => refuse(status, why),
    }
}

#[derive(Deserialize)]
struct UploadQuery {
    #[serde(default)]
    name: Option<String>,
}

async fn upload(
    State(p): State<Arc<Player>>,
    Query(q): Query<UploadQuery>,
    headers: HeaderMap,
    body: Result<Bytes, axum::extract::rejection::BytesRejection>,
) -> Response {
    let kind = headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("");
    let kind = kind.split(';').next().unwrap_or("").trim();
    if !matches!(
        kind,
        "application/octet-stream" | "audio/midi" | "audio/mid" | "audio/x-midi"
    ) {
        return refuse(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            "upload the file's bytes as application/octet-stream or audio/midi",
        );
    }
    let bytes = match body {
        Ok(b) => b,
        Err(e) => {
            let status = e.status();
            let why = if status == StatusCode::PAYLOAD_TOO_LARGE {
                format!(
                    "the file is larger than the {} MiB an upload may be",
                    MAX_UPLOAD >> 20
                )
            } else {
                e.body_text()
            };
            return refuse(status, why);
        }
    };
    let name = q.name.unwrap_or_default();
    match blocking(move || p.load(&name, &bytes)).await {
        Ok(song) => Json(song.json()).into_response(),
        Err((status, why)) => refuse(status, why),
    }
}

async fn ended(State(p): State<Arc<Player>>) -> Response {
    match p.ended() {
        Ok(e) => ([(header::CONTENT_TYPE, "application/json")], e).into_response(),
        Err(r) => rejected(r),
    }
}

async fn songs(State(p): State<Arc<Player>>) -> Response {
    let state = p.state();
    Json(serde_json::json!({ "songs": state["songs"] })).into_response()
}

async fn song(State(p): State<Arc<Player>>, Path(id): Path<u64>) -> Response {
    match p.song(id) {
        Ok(s) => Json(s.json()).into_response(),
        Err(r) => rejected(r),
    }
}

async fn roll(State(p): State<Arc<Player>>, Path(id): Path<u64>) -> Response {
    match p.song(id) {
        Ok(s) => (
            [(
                header::CONTENT_TYPE,
                HeaderValue::from_static("image/svg+xml"),
            )],
            s.analysis.svg.clone(),
        )
            .into_response(),
        Err(r) => rejected(r),
    }
}

async fn command(
    State(p): State<Arc<Player>>,
    body: Result<Json<Command>, JsonRejection>,
) -> Response {
    let command = match json_body(body) {
        Ok(c) => c,
        Err((status, why)) => return refuse(status, why),
    };
    match blocking(move || p.command(command)).await {
        Ok(state) => Json(serde_json::json!({ "state": state })).into_response(),
        Err((status, why)) => refuse(status, why),
    }
}

/// What a session request gets from a server without one.
const NO_SESSION: &str = "no shared session: the server was not started with --link";

async fn session(State(p): State<Arc<Player>>) -> Response {
    match p.session() {
        Some(s) => Json(s.status()).into_response(),
        None => refuse(StatusCode::NOT_FOUND, NO_SESSION),
    }
}

async fn steer_session(
    State(p): State<Arc<Player>>,
    body: Result<Json<crate::SessionCommand>, JsonRejection>,
) -> Response {
    let command = match json_body(body) {
        Ok(c) => c,
        Err((status, why)) => return refuse(status, why),
    };
    let Some(session) = p.session() else {
        return refuse(StatusCode::NOT_FOUND, NO_SESSION);
    };
    match command.apply(session) {
        Ok(status) => Json(status).into_response(),
        Err(why) => refuse(StatusCode::BAD_REQUEST, why),
    }
}

async fn ws(State(p): State<Arc<Player>>, upgrade: WebSocketUpgrade) -> Response {
    upgrade.on_upgrade(move |socket| viewer(p, socket))
}

/// One viewer: the state at once, then each change, at most 30 a second (changes that come
/// faster are folded into the latest).
async fn viewer(p: Arc<Player>, mut socket: WebSocket) {
    let mut states = p.subscribe();
    let mut closing = p.closing();
    let first = p.state().to_string();
    if socket.send(Message::Text(first.into())).await.is_err() {
        return;
    }
    let mut sent_at = Instant::now();
    loop {
        let text: Arc<str> = tokio::select! {
            r = states.recv() => match r {
                Ok(t) => t,
                Err(RecvError::Lagged(_)) => p.state().to_string().into(),
                Err(RecvError::Closed) => break,
            },
            m = socket.recv() => match m {
                None | Some(Err(_)) | Some(Ok(Message::Close(_))) => break,
                Some(Ok(_)) => continue,
            },
            _ = closing.changed() => break,
        };
        let since = sent_at.elapsed();
        let mut text = text;
        if since < VIEWER_EVERY {
            tokio::time::sleep(VIEWER_EVERY - since).await;
            // The latest state told meanwhile.
            loop {
                match states.try_recv() {
                    Ok(t) => text = t,
                    Err(tokio::sync::broadcast::error::TryRecvError::Lagged(_)) => continue,
                    Err(_) => break,
                }
            }
        }
        if socket
            .send(Message::Text(text.to_string().into()))
            .await
            .is_err()
        {
            break;
        }
        sent_at = Instant::now();
    }
    let _ = socket.send(Message::Close(None)).await;
}
