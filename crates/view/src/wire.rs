//! HTTP/1.1 on the wire, as little of it as the viewer needs: the request head read within
//! [`MAX_HEAD_BYTES`] and [`MAX_HEADERS`] (and, on a socket, [`HEAD_SECS`]), one request per connection (every reply says
//! `Connection: close`), bodies only with `Content-Length` (framing and limits in
//! [`crate::request`]). [`exchange`] is the whole server-side conversation on any reader and
//! writer: the server runs it on a socket, the fuzz target on bytes.

use crate::access::Access;
use crate::request::answer;
use crate::routes::{Reply, Site};
use crate::server::{CONNECTION_SECS, HEAD_SECS};
use std::io::{BufRead, ErrorKind, Read, Write};

/// Largest request line plus headers, bytes.
pub const MAX_HEAD_BYTES: usize = 16 * 1024;

/// Most header lines in one request.
pub const MAX_HEADERS: usize = 64;

/// A request's first line and headers (names lower-cased, values trimmed).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Head {
    /// `GET`, `POST`, … as sent.
    pub method: String,
    /// The request target, `/path?query`.
    pub target: String,
    /// `(name, value)` in order.
    pub headers: Vec<(String, String)>,
}

impl Head {
    /// Every value of header `name` (lower case).
    pub fn values<'h>(&'h self, name: &'h str) -> impl Iterator<Item = &'h str> + 'h {
        self.headers.iter().filter(move |(n, _)| n == name).map(|(_, v)| v.as_str())
    }

    /// The value of header `name` when it is sent exactly once (twice or more: `None`).
    pub fn value<'h>(&'h self, name: &'h str) -> Option<&'h str> {
        let mut values = self.values(name);
        match (values.next(), values.next()) {
            (Some(one), None) => Some(one),
            _ => None,
        }
    }
}

/// Reads one request head. `Ok(None)`: nothing came (the connection closed, failed or ran out
/// of time before a byte); `Err`: the reply to send (400 malformed, 431 too large, and for a
/// read that failed, [`unreadable`]'s).
pub fn read_head(reader: &mut impl BufRead) -> Result<Option<Head>, Reply<'static>> {
    let mut budget = MAX_HEAD_BYTES;
    let mut lines = Vec::new();
    loop {
        let mut line = Vec::new();
        let n = match reader.by_ref().take(budget as u64).read_until(b'\n', &mut line) {
            Ok(n) => n,
            // read_until keeps what it read before the error
            Err(_) if lines.is_empty() && line.is_empty() => return Ok(None),
            Err(e) => return Err(unreadable(&e)),
        };
        if n == 0 && lines.is_empty() {
            return Ok(None);
        }
        if !line.ends_with(b"\n") {
            return Err(if n == budget {
                Reply::error(431, &format!("request head over {MAX_HEAD_BYTES} bytes"))
            } else {
                Reply::error(400, "the request head ended early")
            });
        }
        budget -= n;
        line.pop();
        if line.last() == Some(&b'\r') {
            line.pop();
        }
        if line.is_empty() {
            break;
        }
        if lines.len() > MAX_HEADERS {
            return Err(Reply::error(431, &format!("more than {MAX_HEADERS} headers")));
        }
        lines.push(String::from_utf8(line).map_err(|_| Reply::error(400, "request head is not UTF-8"))?);
    }
    parse_head(&lines).map(Some)
}

/// The reply to a request whose reading failed: 408 when it did not come in time, 503 when the
/// server closed the connection to make room for others ([`crate::connections`]), else 400.
pub fn unreadable(e: &std::io::Error) -> Reply<'static> {
    match e.kind() {
        ErrorKind::TimedOut => Reply::error(
            408,
            &format!(
                "the request did not come in time: the request line and headers are awaited {HEAD_SECS} s, \
                 the whole request {CONNECTION_SECS} s"
            ),
        ),
        ErrorKind::ConnectionAborted => Reply::error(
            503,
            "too many connections were waiting for their requests: this one, waiting longest, was \
             closed to make room; send the request again",
        ),
        _ => Reply::error(400, "the request could not be read"),
    }
}

fn parse_head(lines: &[String]) -> Result<Head, Reply<'static>> {
    let bad = |what: &str| Reply::error(400, &format!("malformed request: {what}"));
    let first = lines.first().ok_or_else(|| bad("no request line"))?;
    let mut parts = first.split(' ');
    let (Some(method), Some(target), Some(version), None) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Err(bad("expected `METHOD /path HTTP/1.1`"));
    };
    if method.is_empty() || method.len() > 16 || !method.bytes().all(|b| b.is_ascii_uppercase()) {
        return Err(bad("method"));
    }
    if !target.starts_with('/') || target.bytes().any(|b| b.is_ascii_control()) {
        return Err(bad("the target must be a path"));
    }
    if version != "HTTP/1.1" && version != "HTTP/1.0" {
        return Err(Reply::error(505, "only HTTP/1.0 and HTTP/1.1"));
    }
    let mut headers = Vec::with_capacity(lines.len() - 1);
    for line in &lines[1..] {
        let (name, value) = line.split_once(':').ok_or_else(|| bad("header without `:`"))?;
        let token = |b: u8| b.is_ascii_alphanumeric() || b"!#$%&'*+-.^_`|~".contains(&b);
        if name.is_empty() || !name.bytes().all(token) {
            return Err(bad("header name"));
        }
        headers.push((name.to_ascii_lowercase(), value.trim_matches([' ', '\t']).to_string()));
    }
    Ok(Head { method: method.to_string(), target: target.to_string(), headers })
}

/// Writes `reply` (without its body for `HEAD`) and flushes.
pub fn write_reply(writer: &mut impl Write, reply: &Reply<'_>, head_only: bool) -> std::io::Result<()> {
    let mut head = format!(
        "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nConnection: close\r\n\
         Cache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nX-Frame-Options: DENY\r\n\
         Content-Security-Policy: frame-ancestors 'none'\r\n",
        reply.status,
        reason(reply.status),
        reply.content_type,
        reply.body.len()
    );
    if let Some(name) = &reply.download_name {
        head.push_str(&format!("Content-Disposition: attachment; filename=\"{name}\"\r\n"));
    }
    head.push_str("\r\n");
    writer.write_all(head.as_bytes())?;
    if !head_only {
        writer.write_all(&reply.body)?;
    }
    writer.flush()
}

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        408 => "Request Timeout",
        411 => "Length Required",
        413 => "Content Too Large",
        431 => "Request Header Fields Too Large",
        500 => "Internal Server Error",
        503 => "Service Unavailable",
        505 => "HTTP Version Not Supported",
        _ => "",
    }
}

/// One request and its reply on `reader` / `writer`: the head, [`answer`], the reply. A
/// connection closed before a byte gets no reply.
pub fn exchange(
    site: &Site,
    access: &Access,
    reader: &mut impl BufRead,
    writer: &mut impl Write,
) -> std::io::Result<()> {
    match read_head(reader) {
        Ok(None) => Ok(()),
        Ok(Some(head)) => reply_to(site, access, &head, reader, writer),
        Err(reply) => write_reply(writer, &reply, false),
    }
}

/// The second half of [`exchange`], once the head is read: [`answer`] (which reads the body
/// from `body`) and the reply.
pub fn reply_to(
    site: &Site,
    access: &Access,
    head: &Head,
    body: &mut impl Read,
    writer: &mut impl Write,
) -> std::io::Result<()> {
    let reply = answer(site, access, head, body);
    write_reply(writer, &reply, head.method == "HEAD")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    fn head(bytes: &[u8]) -> Result<Option<Head>, u16> {
        read_head(&mut Cursor::new(bytes.to_vec())).map_err(|r| r.status)
    }

    #[test]
    fn reads_a_head_and_leaves_the_body() {
        let mut input =
            Cursor::new(b"POST /api/export?x=1 HTTP/1.1\r\nHost: a:1\r\nX-A:  b \r\n\r\nBODY".to_vec());
        let h = read_head(&mut input).expect("head").expect("some");
        assert_eq!((h.method.as_str(), h.target.as_str()), ("POST", "/api/export?x=1"));
        assert_eq!(h.headers, vec![("host".into(), "a:1".into()), ("x-a".into(), "b".into())]);
        let mut rest = String::new();
        input.read_to_string(&mut rest).expect("rest");
        assert_eq!(rest, "BODY");
        assert_eq!(head(b"GET / HTTP/1.0\n\n").expect("bare LF").expect("some").method, "GET");
    }

    #[test]
    fn refuses_malformed_and_oversized_heads() {
        assert_eq!(head(b""), Ok(None));
        for bad in [
            &b"GET / HTTP/1.1\r\nHost: a"[..],
            b"GET /\r\n\r\n",
            b"GET  / HTTP/1.1\r\n\r\n",
            b"get / HTTP/1.1\r\n\r\n",
            b"GET http://x/ HTTP/1.1\r\n\r\n",
            b"GET / HTTP/1.1\r\nno colon\r\n\r\n",
            b"GET / HTTP/1.1\r\n folded: x\r\n\r\n",
            b"GET / HTTP/1.1\r\nX: \xff\r\n\r\n",
        ] {
            assert_eq!(head(bad), Err(400), "{}", String::from_utf8_lossy(bad));
        }
        assert_eq!(head(b"GET / HTTP/2.0\r\n\r\n"), Err(505));
        let long = [b"GET /".as_slice(), &vec![b'a'; MAX_HEAD_BYTES], b" HTTP/1.1\r\n\r\n"].concat();
        assert_eq!(head(&long), Err(431));
        let many = format!("GET / HTTP/1.1\r\n{}\r\n", "X: y\r\n".repeat(MAX_HEADERS + 1));
        assert_eq!(head(many.as_bytes()), Err(431));
    }

    /// `bytes`, then the error `kind` (as a socket past its deadline, or closed for room).
    struct FailsAfter(Cursor<Vec<u8>>, ErrorKind);

    impl Read for FailsAfter {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            match self.0.read(buf)? {
                0 => Err(std::io::Error::new(self.1, "failed")),
                n => Ok(n),
            }
        }
    }

    #[test]
    fn a_head_cut_by_a_failed_read_gets_408_503_or_nothing() {
        let status = |bytes: &[u8], kind| {
            let mut reader = std::io::BufReader::new(FailsAfter(Cursor::new(bytes.to_vec()), kind));
            read_head(&mut reader).map(|h| h.is_some()).map_err(|r| r.status)
        };
        // nothing sent: no reply at all
        assert_eq!(status(b"", ErrorKind::TimedOut), Ok(false));
        assert_eq!(status(b"", ErrorKind::ConnectionAborted), Ok(false));
        assert_eq!(status(b"GET / HTTP/1.1\r\nHost: a", ErrorKind::TimedOut), Err(408));
        assert_eq!(status(b"GET / HT", ErrorKind::ConnectionAborted), Err(503));
        assert_eq!(status(b"GET / HTTP/1.1\r\n", ErrorKind::Other), Err(400));
        assert_eq!(status(b"GET / HTTP/1.1\r\n\r\n", ErrorKind::TimedOut), Ok(true));
    }

    #[test]
    fn replies_close_the_connection_and_head_has_no_body() {
        let reply = Reply::error(404, "not found");
        let mut out = Vec::new();
        write_reply(&mut out, &reply, true).expect("write");
        let text = String::from_utf8(out).expect("utf-8");
        assert!(
            text.starts_with("HTTP/1.1 404 Not Found\r\n") && text.contains("Connection: close\r\n"),
            "{text}"
        );
        assert!(
            text.ends_with("\r\n\r\n") && text.contains(&format!("Content-Length: {}", reply.body.len()))
        );
    }
}
