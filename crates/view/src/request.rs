//! One request → one reply, with no socket: [`answer`] is a pure function of the request head and
//! a body reader (the server and the fuzz target call it through [`crate::wire::exchange`]).
//!
//! In order: `Host` must name this server ([`Access::host_allowed`], else 403); the body is framed
//! by one `Content-Length` of at most [`MAX_BODY_BYTES`] ([`MAX_EDITS_BODY_BYTES`] for the
//! edit endpoints; 413 without reading a byte, whatever
//! the header claims; `Transfer-Encoding` gets 411); a request that is not `GET` / `HEAD` changes
//! something and needs the page's token and `Origin` (403 before the body is read), a search
//! (`/api/find`) the token; then the body
//! is read, never more than it said, and [`Site::respond`] answers. `/` and `/index.html` are the
//! page with this server's token.

use crate::access::{Access, Refusal, TOKEN_HEADER};
use crate::routes::{body_limit, Reply, Site};
#[cfg(doc)]
use crate::routes::{MAX_BODY_BYTES, MAX_EDITS_BODY_BYTES};
use crate::search::FIND_PATH;
use crate::wire::{unreadable, Head};
use std::borrow::Cow;
use std::io::Read;

/// The reply to `head` (its body still unread in `body`).
pub fn answer<'a>(site: &'a Site, access: &'a Access, head: &Head, body: &mut dyn Read) -> Reply<'a> {
    if head.values("host").count() > 1 {
        return Reply::error(400, "more than one Host header");
    }
    let Some(host) = head.value("host").filter(|h| access.host_allowed(Some(h))) else {
        return refused(Refusal::Host);
    };
    let path = head.target.split(['?', '#']).next().unwrap_or("");
    let length = match body_length(head, body_limit(path)) {
        Ok(n) => n,
        Err(reply) => return reply,
    };
    let reading = matches!(head.method.as_str(), "GET" | "HEAD");
    if !reading {
        if let Err(why) = access.may_change(host, head.value("origin"), head.value(TOKEN_HEADER)) {
            return refused(why);
        }
    } else if path == FIND_PATH && !access.token_ok(head.value(TOKEN_HEADER)) {
        // a search runs a model: only the page (which holds the token) may ask
        return refused(Refusal::Token);
    }
    let mut bytes = Vec::with_capacity(length);
    match body.take(length as u64).read_to_end(&mut bytes) {
        Ok(n) if n == length => {}
        Err(e) => return unreadable(&e),
        Ok(_) => return Reply::error(400, "the body is shorter than its Content-Length"),
    }
    if reading && (path == "/" || path == "/index.html") {
        return Reply::page(Cow::Borrowed(access.page()));
    }
    site.respond(&head.method, &head.target, &bytes)
}

/// The body's length from `Content-Length` (none: 0), or the reply refusing it (over `limit`: 413).
fn body_length(head: &Head, limit: usize) -> Result<usize, Reply<'static>> {
    if head.values("transfer-encoding").next().is_some() {
        return Err(Reply::error(411, "send the body with a Content-Length, not Transfer-Encoding"));
    }
    let mut length = None;
    for value in head.values("content-length") {
        if value.is_empty() || !value.bytes().all(|b| b.is_ascii_digit()) {
            return Err(Reply::error(400, "Content-Length is not a number"));
        }
        // digits only: a parse failure is an overflow, i.e. far over the limit
        let n = value.parse::<u64>().unwrap_or(u64::MAX);
        if length.is_some_and(|l| l != n) {
            return Err(Reply::error(400, "Content-Length headers disagree"));
        }
        length = Some(n);
    }
    match length {
        Some(n) if n > limit as u64 => Err(Reply::too_large(limit)),
        Some(n) => Ok(n as usize),
        None => Ok(0),
    }
}

fn refused(why: Refusal) -> Reply<'static> {
    let message = match why {
        Refusal::Host => {
            "the Host header must be the address this viewer listens on (as printed when it started); \
             other names are refused (DNS rebinding)"
        }
        Refusal::Token => {
            "changes and searches are accepted only from the viewer's own page (missing or wrong X-Splatseg-Token)"
        }
        Refusal::Origin => "changes are accepted only from the viewer's own page (its Origin)",
    };
    Reply::error(403, message)
}
