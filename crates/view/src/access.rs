//! Who may drive the server: the `Host` names it answers to (against DNS rebinding) and the
//! per-server token that requests changing anything must carry, with the page's `Origin`.
//!
//! Rules (one server, bound to one address):
//! - `Host` must be `NAME:PORT` with PORT the bound port and NAME the name given to `--listen`,
//!   the bound IP (IPv6 in brackets), or `localhost` when bound to a loopback address. Bound to an
//!   unspecified address (`0.0.0.0`, `::`), any IP literal is accepted as NAME, never another
//!   name: a rebinding attack needs its own domain name in `Host`.
//! - A request that changes anything (`POST /api/export`) needs `X-Splatseg-Token` equal to the
//!   token the page was served with, and `Origin` equal to `http://` + the request's `Host`.

use crate::error::{ViewError, ViewResult};
use std::net::{IpAddr, SocketAddr};

/// The request header carrying the page's token.
pub const TOKEN_HEADER: &str = "x-splatseg-token";

/// The placeholder in `index.html` replaced by the token.
const TOKEN_PLACEHOLDER: &[u8] = b"SPLATSEG_TOKEN";

/// The rules of one running server (see the module doc).
#[derive(Clone, Debug)]
pub struct Access {
    names: Vec<String>,
    any_ip: bool,
    port: u16,
    token: String,
    page: Vec<u8>,
}

/// Why a request was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// `Host` missing or not one the server answers to.
    Host,
    /// A change without the page's token.
    Token,
    /// A change whose `Origin` is missing or not the page's.
    Origin,
}

impl Access {
    /// The rules for a server bound to `bound`, started as `--listen NAME:…`, issuing `token`.
    pub fn new(bound: SocketAddr, name: &str, token: String) -> Access {
        let ip = bound.ip();
        let mut names =
            vec![host_name(ip), name.trim_start_matches('[').trim_end_matches(']').to_ascii_lowercase()];
        if ip.is_loopback() || ip.is_unspecified() {
            names.push("localhost".to_string());
        }
        names.sort();
        names.dedup();
        let page = render_page(&token);
        Access { names, any_ip: ip.is_unspecified(), port: bound.port(), token, page }
    }

    /// `index.html` with this server's token in its `<meta name="splatseg-token">`.
    pub fn page(&self) -> &[u8] {
        &self.page
    }

    /// Whether `host` (a `Host` header) names this server.
    pub fn host_allowed(&self, host: Option<&str>) -> bool {
        let Some((name, port)) = host.and_then(|h| h.trim().rsplit_once(':')) else {
            return false;
        };
        if port.parse::<u16>().ok() != Some(self.port) {
            return false;
        }
        let name = name.to_ascii_lowercase();
        let bare = name.trim_start_matches('[').trim_end_matches(']');
        let ip_literal = bare.parse::<IpAddr>().is_ok();
        let bracketed = name.starts_with('[') && name.ends_with(']');
        // an IPv6 literal only in brackets, everything else never in brackets
        if ip_literal && bare.contains(':') != bracketed {
            return false;
        }
        self.names.iter().any(|n| n == bare) || (self.any_ip && ip_literal)
    }

    /// Whether `token` (an `X-Splatseg-Token` header) is this server's.
    pub fn token_ok(&self, token: Option<&str>) -> bool {
        token.is_some_and(|t| constant_time_eq(t.trim().as_bytes(), self.token.as_bytes()))
    }

    /// Whether a request changing something may go ahead: the token, then an `Origin` equal to
    /// `http://` + `host` (already checked by [`Access::host_allowed`]).
    pub fn may_change(&self, host: &str, origin: Option<&str>, token: Option<&str>) -> Result<(), Refusal> {
        if !self.token_ok(token) {
            return Err(Refusal::Token);
        }
        let page_origin = format!("http://{}", host.trim());
        match origin {
            Some(o) if o.trim().eq_ignore_ascii_case(&page_origin) => Ok(()),
            _ => Err(Refusal::Origin),
        }
    }
}

/// A new random token: 16 bytes from the operating system, as 32 hex digits.
pub fn new_token() -> ViewResult<String> {
    let mut bytes = [0u8; 16];
    getrandom::getrandom(&mut bytes).map_err(|e| ViewError::Random(e.to_string()))?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// How an IP appears as the name part of `Host` (without brackets).
fn host_name(ip: IpAddr) -> String {
    ip.to_string().to_ascii_lowercase()
}

/// The embedded `index.html` with the placeholder replaced by `token` (hex digits only, so no
/// escaping is needed).
fn render_page(token: &str) -> Vec<u8> {
    let template = crate::assets::INDEX_HTML;
    match template.windows(TOKEN_PLACEHOLDER.len()).position(|w| w == TOKEN_PLACEHOLDER) {
        Some(at) => [&template[..at], token.as_bytes(), &template[at + TOKEN_PLACEHOLDER.len()..]].concat(),
        None => template.to_vec(),
    }
}

/// Compares without stopping at the first difference (the token is a secret).
fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn access(bound: &str, name: &str) -> Access {
        Access::new(bound.parse().expect("socket address"), name, "0123456789abcdef0123456789abcdef".into())
    }

    #[test]
    fn host_must_name_the_bound_address_and_port() {
        let a = access("127.0.0.1:8080", "127.0.0.1");
        for ok in ["127.0.0.1:8080", "localhost:8080", "LOCALHOST:8080"] {
            assert!(a.host_allowed(Some(ok)), "{ok}");
        }
        for bad in [
            "evil.example:8080",
            "127.0.0.1:8081",
            "127.0.0.1",
            "localhost",
            "127.0.0.2:8080",
            "[127.0.0.1]:8080",
            "localhost.evil.example:8080",
            "",
            ":8080",
        ] {
            assert!(!a.host_allowed(Some(bad)), "{bad}");
        }
        assert!(!a.host_allowed(None));
        let v6 = access("[::1]:9000", "::1");
        assert!(v6.host_allowed(Some("[::1]:9000")) && v6.host_allowed(Some("localhost:9000")));
        assert!(!v6.host_allowed(Some("::1:9000")));
    }

    #[test]
    fn a_named_or_unspecified_listen_address() {
        let named = access("192.168.1.5:80", "MyBox.lan");
        assert!(named.host_allowed(Some("mybox.lan:80")) && named.host_allowed(Some("192.168.1.5:80")));
        assert!(!named.host_allowed(Some("localhost:80")) && !named.host_allowed(Some("10.0.0.1:80")));
        let all = access("0.0.0.0:80", "0.0.0.0");
        assert!(all.host_allowed(Some("10.0.0.1:80")) && all.host_allowed(Some("localhost:80")));
        assert!(!all.host_allowed(Some("rebind.evil.example:80")));
    }

    #[test]
    fn changes_need_the_token_and_the_pages_origin() {
        let a = access("127.0.0.1:8080", "127.0.0.1");
        let token = Some("0123456789abcdef0123456789abcdef");
        let host = "127.0.0.1:8080";
        assert_eq!(a.may_change(host, Some("http://127.0.0.1:8080"), token), Ok(()));
        assert_eq!(a.may_change(host, Some("http://evil.example"), token), Err(Refusal::Origin));
        assert_eq!(a.may_change(host, Some("null"), token), Err(Refusal::Origin));
        assert_eq!(a.may_change(host, None, token), Err(Refusal::Origin));
        assert_eq!(a.may_change(host, Some("http://127.0.0.1:8080"), None), Err(Refusal::Token));
        assert_eq!(a.may_change(host, Some("http://127.0.0.1:8080"), Some("0123")), Err(Refusal::Token));
    }

    #[test]
    fn the_page_carries_the_token_and_tokens_differ() {
        let a = access("127.0.0.1:8080", "127.0.0.1");
        let page = String::from_utf8_lossy(a.page()).into_owned();
        assert!(
            page.contains(r#"<meta name="splatseg-token" content="0123456789abcdef0123456789abcdef">"#),
            "{page}"
        );
        let (t1, t2) = (new_token().expect("token"), new_token().expect("token"));
        assert_eq!(t1.len(), 32);
        assert!(t1.bytes().all(|b| b.is_ascii_hexdigit()));
        assert_ne!(t1, t2);
    }
}
