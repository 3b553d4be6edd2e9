//! Who may come in, because the robot moves.
//!
//! - **Loopback by default**; on any other address a random token is required ([`Access`]):
//!   `Authorization: Bearer TOKEN`, the query `?token=TOKEN` (the URL printed at start
//!   carries it), or the cookie the page is given when it is loaded with it. Without it: 401.
//! - **`Host`** must name the address listened on (its IP and port, or `localhost` on
//!   loopback or all addresses; any IP address of the machine when listening on all of them): a page of
//!   another site whose name was pointed at this machine (DNS rebinding) sends its own name,
//!   and is refused (403).
//! - **`Origin`**: a command (any request but GET and HEAD) or a WebSocket upgrade whose
//!   `Origin` is not this page's (`http://` and the `Host` it was sent to) is refused (403).
//!   Browsers always send `Origin` with both; a script without one (curl) is let through.
//! - **JSON only**: commands take `Content-Type: application/json` (415 otherwise), uploads
//!   `application/octet-stream` or `audio/midi`: neither is a type a form of another site can
//!   send without asking first.

use std::net::{IpAddr, SocketAddr};

use axum::extract::{Request, State};
use axum::http::{header, HeaderMap, HeaderValue, Method, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

/// The cookie that carries the token for the page's own requests.
pub const TOKEN_COOKIE: &str = "orch_token";

/// Who may come in: the address listened on, and the token asked for off loopback.
#[derive(Clone, Debug)]
pub struct Access {
    addr: SocketAddr,
    token: Option<String>,
}

impl Access {
    /// Access to a server listening at `addr` (its real port, once bound): on loopback no
    /// token; on any other address a new random one (128 bits, hex).
    pub fn new(addr: SocketAddr) -> Result<Self, getrandom::Error> {
        let token = if addr.ip().is_loopback() {
            None
        } else {
            let mut bytes = [0u8; 16];
            getrandom::fill(&mut bytes)?;
            Some(bytes.iter().map(|b| format!("{b:02x}")).collect())
        };
        Ok(Self { addr, token })
    }

    /// The address listened on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The token asked for, if any (off loopback).
    pub fn token(&self) -> Option<&str> {
        self.token.as_deref()
    }

    /// The page's URL at `host` (an IP address or name this server answers to), carrying the
    /// token if one is asked for.
    pub fn url(&self, host: IpAddr) -> String {
        let host = SocketAddr::new(host, self.addr.port());
        match &self.token {
            Some(t) => format!("http://{host}/?token={t}"),
            None => format!("http://{host}/"),
        }
    }

    /// The page's URLs, each as [`url`](Self::url) gives it: at the address listened on, or,
    /// listening on all addresses, at loopback first and then at each of the machine's other
    /// addresses of that family (link-local IPv6 left out: it needs a zone in a URL).
    pub fn urls(&self) -> Vec<String> {
        let addr = self.addr;
        let hosts: Vec<IpAddr> = if addr.ip().is_unspecified() {
            let mut hosts = vec![if addr.is_ipv4() {
                IpAddr::from([127, 0, 0, 1])
            } else {
                IpAddr::from(std::net::Ipv6Addr::LOCALHOST)
            }];
            hosts.extend(machine_addresses(addr));
            hosts
        } else {
            vec![addr.ip()]
        };
        hosts.into_iter().map(|h| self.url(h)).collect()
    }

    /// Whether a request's `Host` names this server (see the [module notes](self)).
    pub fn host_ok(&self, host: &str) -> bool {
        let Some((name, port)) = split_host(host) else {
            return false;
        };
        if port != self.addr.port() {
            return false;
        }
        let ip = self.addr.ip();
        match name.parse::<IpAddr>() {
            Ok(asked) => !asked.is_unspecified() && (asked == ip || ip.is_unspecified()),
            Err(_) => {
                name.eq_ignore_ascii_case("localhost") && (ip.is_loopback() || ip.is_unspecified())
            }
        }
    }

    /// Whether `given` is the token (compared in constant time); always when none is asked.
    fn token_ok(&self, given: Option<&str>) -> bool {
        let Some(token) = &self.token else {
            return true;
        };
        let Some(given) = given else { return false };
        given.len() == token.len()
            && given
                .bytes()
                .zip(token.bytes())
                .fold(0u8, |acc, (a, b)| acc | (a ^ b))
                == 0
    }
}

/// `name:port` (`[v6]:port` for IPv6) split; the port is required (the page is never on
/// port 80 by default, and a browser always sends a port other than its scheme's).
fn split_host(host: &str) -> Option<(&str, u16)> {
    let (name, port) = host.rsplit_once(':')?;
    let port = port.parse().ok()?;
    match name.strip_prefix('[').and_then(|n| n.strip_suffix(']')) {
        Some(v6) => Some((v6, port)),
        // An IPv6 address is written in brackets in a Host, always.
        None if name.contains(':') => None,
        None => Some((name, port)),
    }
}

/// The token a request carries: `Authorization: Bearer`, `?token=`, or the page's cookie.
fn carried_token<'a>(headers: &'a HeaderMap, query: Option<&'a str>) -> Option<&'a str> {
    let bearer = headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "));
    let in_query = query.and_then(|q| {
        q.split('&')
            .find_map(|kv| kv.strip_prefix("token="))
            .filter(|t| !t.is_empty())
    });
    let in_cookie = headers
        .get_all(header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .find_map(|c| c.trim().strip_prefix(TOKEN_COOKIE)?.strip_prefix('='));
    bearer.or(in_query).or(in_cookie)
}

/// A refusal: the status and why, as JSON.
pub(crate) fn refuse(status: StatusCode, why: impl Into<String>) -> Response {
    (
        status,
        axum::Json(serde_json::json!({ "error": why.into() })),
    )
        .into_response()
}

/// The middleware in front of every route: `Host`, token, `Origin` (see the [module
/// notes](self)); the page loaded with a good `?token=` gets it as a cookie.
pub async fn check(State(access): State<Access>, request: Request, next: Next) -> Response {
    let headers = request.headers();
    let host = headers
        .get(header::HOST)
        .and_then(|h| h.to_str().ok())
        .unwrap_or("");
    if !access.host_ok(host) {
        return refuse(
            StatusCode::FORBIDDEN,
            format!(
                "refused: Host {host:?} is not the address orch serve listens on ({})",
                access.addr
            ),
        );
    }
    let query = request.uri().query();
    let token = carried_token(headers, query);
    if !access.token_ok(token) {
        return refuse(
            StatusCode::UNAUTHORIZED,
            "this orch serve asks for its token: open the URL it printed at start",
        );
    }
    let upgrade = headers.contains_key(header::UPGRADE);
    let command = !matches!(*request.method(), Method::GET | Method::HEAD);
    if command || upgrade {
        if let Some(origin) = headers.get(header::ORIGIN) {
            let ours = format!("http://{host}");
            if origin.as_bytes() != ours.as_bytes() {
                return refuse(
                    StatusCode::FORBIDDEN,
                    format!(
                        "refused: a command from another page ({:?})",
                        String::from_utf8_lossy(origin.as_bytes())
                    ),
                );
            }
        }
    }
    // The page loaded with the token in its URL: its own requests carry it as a cookie from
    // then on (readable by nothing but this server: HttpOnly, SameSite=Strict).
    let set_cookie = match (access.token(), query.map(|q| q.contains("token="))) {
        (Some(t), Some(true)) if request.uri().path() == "/" => HeaderValue::from_str(&format!(
            "{TOKEN_COOKIE}={t}; Path=/; HttpOnly; SameSite=Strict"
        ))
        .ok(),
        _ => None,
    };
    let mut response = next.run(request).await;
    if let Some(c) = set_cookie {
        response.headers_mut().insert(header::SET_COOKIE, c);
    }
    response
}

/// This machine's addresses other than loopback, of `addr`'s family, sorted.
fn machine_addresses(addr: SocketAddr) -> Vec<IpAddr> {
    let Ok(ifaces) = nix::ifaddrs::getifaddrs() else {
        return Vec::new();
    };
    let mut found: Vec<IpAddr> = ifaces
        .filter_map(|i| i.address)
        .filter_map(|a| {
            if let Some(v4) = a.as_sockaddr_in() {
                Some(IpAddr::V4(v4.ip()))
            } else {
                a.as_sockaddr_in6().map(|v6| IpAddr::V6(v6.ip()))
            }
        })
        .filter(|ip| !ip.is_loopback() && ip.is_ipv4() == addr.is_ipv4())
        .filter(|ip| match ip {
            // Link-local IPv6 needs a zone in a URL: left out.
            IpAddr::V6(v6) => (v6.segments()[0] & 0xffc0) != 0xfe80,
            IpAddr::V4(_) => true,
        })
        .collect();
    found.sort();
    found.dedup();
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(addr: &str) -> Access {
        Access::new(addr.parse().unwrap()).unwrap()
    }

    #[test]
    fn the_urls_are_the_address_listened_on_or_loopback_first_then_the_machines() {
        assert_eq!(at("127.0.0.1:8000").urls(), ["http://127.0.0.1:8000/"]);
        assert_eq!(at("[::1]:8000").urls(), ["http://[::1]:8000/"]);
        let all = at("0.0.0.0:8000");
        let token = all.token().unwrap();
        let urls = all.urls();
        assert_eq!(urls[0], format!("http://127.0.0.1:8000/?token={token}"));
        for url in &urls[1..] {
            assert!(!url.contains("127.0.0.1") && !url.contains('['), "{url}");
            assert!(url.ends_with(&format!(":8000/?token={token}")), "{url}");
        }
        let v6 = at("[::]:8000");
        assert!(v6.urls()[0].starts_with("http://[::1]:8000/?token="));
        assert!(v6.urls().iter().all(|u| !u.contains("[fe80")));
    }

    #[test]
    fn loopback_asks_no_token_and_any_other_address_a_random_one() {
        assert_eq!(at("127.0.0.1:8000").token(), None);
        assert_eq!(at("[::1]:8000").token(), None);
        let a = at("0.0.0.0:8000");
        let b = at("0.0.0.0:8000");
        let (ta, tb) = (a.token().unwrap(), b.token().unwrap());
        assert_eq!(ta.len(), 32);
        assert_ne!(ta, tb, "a new token each start");
        assert!(a.token_ok(Some(ta)));
        assert!(!a.token_ok(Some(tb)));
        assert!(!a.token_ok(None));
        assert!(!a.token_ok(Some(&ta[..31])));
        assert_eq!(
            a.url("192.0.2.7".parse().unwrap()),
            format!("http://192.0.2.7:8000/?token={ta}")
        );
    }

    #[test]
    fn the_host_must_name_the_address_listened_on() {
        let lo = at("127.0.0.1:8000");
        assert!(lo.host_ok("127.0.0.1:8000"));
        assert!(lo.host_ok("localhost:8000"));
        assert!(lo.host_ok("LOCALHOST:8000"));
        assert!(!lo.host_ok("127.0.0.1:8001"));
        assert!(!lo.host_ok("127.0.0.1"));
        assert!(!lo.host_ok("evil.example:8000"), "DNS rebinding");
        assert!(!lo.host_ok("127.0.0.2:8000"));
        assert!(!lo.host_ok(""));
        let v6 = at("[::1]:8000");
        assert!(v6.host_ok("[::1]:8000"));
        assert!(!v6.host_ok("::1:8000"));
        let all = at("0.0.0.0:8000");
        assert!(all.host_ok("192.0.2.7:8000"));
        assert!(all.host_ok("127.0.0.1:8000"));
        assert!(!all.host_ok("0.0.0.0:8000"));
        assert!(!all.host_ok("orch.example:8000"), "DNS rebinding");
        assert!(all.host_ok("localhost:8000"));
        let one = at("192.0.2.7:8000");
        assert!(one.host_ok("192.0.2.7:8000"));
        assert!(!one.host_ok("192.0.2.8:8000"));
    }

    #[test]
    fn the_token_is_found_in_the_header_the_query_or_the_cookie() {
        let mut h = HeaderMap::new();
        assert_eq!(carried_token(&h, Some("a=1&token=abc")), Some("abc"));
        assert_eq!(carried_token(&h, Some("token=")), None);
        h.insert(header::COOKIE, "x=1; orch_token=def".parse().unwrap());
        assert_eq!(carried_token(&h, None), Some("def"));
        h.insert(header::AUTHORIZATION, "Bearer ghi".parse().unwrap());
        assert_eq!(carried_token(&h, Some("token=abc")), Some("ghi"));
    }
}
