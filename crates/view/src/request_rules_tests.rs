//! The server's rules on the pure request → reply path (`wire::exchange` on bytes, as the fuzz
//! target runs it): `Host`, bounded bodies, the page's token and `Origin` for exports; and every
//! committed `fuzz/corpus/view_request` input replayed.

use crate::fuzzing::{request_bytes, site, ADDR, TOKEN};
use std::io::Read;
use std::path::Path;

fn status(reply: &[u8]) -> u16 {
    std::str::from_utf8(&reply[9..12]).ok().and_then(|s| s.parse().ok()).unwrap_or(0)
}

fn body(reply: &[u8]) -> String {
    let end = reply.windows(4).position(|w| w == b"\r\n\r\n").expect("head") + 4;
    String::from_utf8_lossy(&reply[end..]).into_owned()
}

fn export(host: &str, origin: Option<&str>, token: Option<&str>) -> String {
    let json = r#"{"ids":[1],"mode":"extract"}"#;
    let mut head = format!("POST /api/export HTTP/1.1\r\nHost: {host}\r\nContent-Length: {}\r\n", json.len());
    if let Some(origin) = origin {
        head.push_str(&format!("Origin: {origin}\r\n"));
    }
    if let Some(token) = token {
        head.push_str(&format!("X-Splatseg-Token: {token}\r\n"));
    }
    format!("{head}\r\n{json}")
}

fn files(dir: &Path) -> usize {
    std::fs::read_dir(dir).map(|d| d.count()).unwrap_or(0)
}

#[test]
fn only_the_bound_host_is_answered() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let (site, access) = site(tmp.path().to_path_buf());
    let get = |host: &str| {
        status(&request_bytes(
            &site,
            &access,
            format!("GET /api/scene.json HTTP/1.1\r\n{host}\r\n").as_bytes(),
        ))
    };
    assert_eq!(get(&format!("Host: {ADDR}\r\n")), 200);
    assert_eq!(get("Host: localhost:8080\r\n"), 200);
    for foreign in
        ["Host: rebind.evil.example:8080\r\n", "Host: 127.0.0.1:9999\r\n", "Host: 127.0.0.1\r\n", ""]
    {
        assert_eq!(get(foreign), 403, "{foreign:?}");
    }
    assert_eq!(get(&format!("Host: {ADDR}\r\nHost: evil.example:8080\r\n")), 400);
}

#[test]
fn the_page_carries_the_token_the_exports_need() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let (site, access) = site(tmp.path().to_path_buf());
    for path in ["/", "/index.html", "/?canvas=native"] {
        let reply =
            request_bytes(&site, &access, format!("GET {path} HTTP/1.1\r\nHost: {ADDR}\r\n\r\n").as_bytes());
        assert_eq!(status(&reply), 200, "{path}");
        assert!(
            body(&reply).contains(&format!(r#"<meta name="splatseg-token" content="{TOKEN}">"#)),
            "{path}"
        );
    }
}

#[test]
fn exports_need_the_token_and_the_pages_origin_and_write_nothing_otherwise() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let out = tmp.path().join("exports");
    let (site, access) = site(out.clone());
    let page = format!("http://{ADDR}");
    for (request, why) in [
        (export(ADDR, Some(&page), None), "no token"),
        (export(ADDR, Some(&page), Some("00112233445566778899aabbccddeefe")), "wrong token"),
        (export(ADDR, None, Some(TOKEN)), "no Origin"),
        (export(ADDR, Some("http://evil.example"), Some(TOKEN)), "foreign Origin"),
        (export(ADDR, Some("null"), Some(TOKEN)), "opaque Origin"),
        (export("evil.example:8080", Some("http://evil.example:8080"), Some(TOKEN)), "foreign Host"),
    ] {
        let reply = request_bytes(&site, &access, request.as_bytes());
        assert_eq!(status(&reply), 403, "{why}: {}", body(&reply));
        assert_eq!(files(&out), 0, "{why}: a file was written");
    }
    let reply = request_bytes(&site, &access, export(ADDR, Some(&page), Some(TOKEN)).as_bytes());
    assert_eq!(status(&reply), 200, "{}", body(&reply));
    assert!(out.join("extract_1.ply").is_file());
    let reply = request_bytes(
        &site,
        &access,
        export("localhost:8080", Some("http://localhost:8080"), Some(TOKEN)).as_bytes(),
    );
    assert_eq!(status(&reply), 200, "{}", body(&reply));
}

/// Counts the bytes taken from an endless body.
struct Endless(usize);

impl Read for Endless {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        buf.fill(b' ');
        self.0 += buf.len();
        Ok(buf.len())
    }
}

#[test]
fn bodies_are_read_up_to_their_length_and_never_over_the_limit() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let (site, access) = site(tmp.path().to_path_buf());
    let answer = |claim: &str, endless: &mut Endless| {
        let head = format!(
            "POST /api/export HTTP/1.1\r\nHost: {ADDR}\r\nOrigin: http://{ADDR}\r\nX-Splatseg-Token: {TOKEN}\r\nContent-Length: {claim}\r\n\r\n"
        );
        let mut input = std::io::BufReader::new(std::io::Cursor::new(head.into_bytes()).chain(endless));
        let mut out = Vec::new();
        crate::wire::exchange(&site, &access, &mut input, &mut out).expect("exchange");
        status(&out)
    };
    let limit = crate::routes::MAX_BODY_BYTES;
    for claim in
        ["1000000000000", "18446744073709551615", "99999999999999999999999", &(limit + 1).to_string()]
    {
        let mut endless = Endless(0);
        assert_eq!(answer(claim, &mut endless), 413, "{claim}");
        assert!(endless.0 <= 64 * 1024, "{claim}: read {} body bytes", endless.0);
    }
    for claim in ["-1", "1e3", "0x10", " ", "+5"] {
        assert_eq!(answer(claim, &mut Endless(0)), 400, "{claim:?}");
    }
    let mut endless = Endless(0);
    assert_eq!(answer("100", &mut endless), 400, "100 spaces are not an export request");
    assert!(endless.0 <= 100 + 8192, "read {} body bytes", endless.0);
    let chunked = format!("POST /api/export HTTP/1.1\r\nHost: {ADDR}\r\nTransfer-Encoding: chunked\r\n\r\n5\r\nhello\r\n0\r\n\r\n");
    assert_eq!(status(&request_bytes(&site, &access, chunked.as_bytes())), 411);
    let short = format!("POST /api/export HTTP/1.1\r\nHost: {ADDR}\r\nOrigin: http://{ADDR}\r\nX-Splatseg-Token: {TOKEN}\r\nContent-Length: 50\r\n\r\n{{}}");
    assert_eq!(status(&request_bytes(&site, &access, short.as_bytes())), 400);
}

#[test]
fn the_committed_fuzz_corpus_replays() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let (site, access) = site(tmp.path().to_path_buf());
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus/view_request");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).expect("fuzz/corpus/view_request") {
        let data = std::fs::read(entry.expect("entry").path()).expect("read");
        request_bytes(&site, &access, &data);
        n += 1;
    }
    assert!(n >= 5, "only {n} inputs in {}", dir.display());
}

/// `GET /api/find?q=`: only with the page's token, a bounded query, 404 without a search function; the
/// query reaches the function decoded.
#[test]
fn searches_need_the_token_and_a_bounded_query() {
    use crate::search::{SearchHit, MAX_QUERY_CHARS};
    let tmp = tempfile::tempdir().expect("temp dir");
    let find = |site: &crate::Site, access, query: &str, token: Option<&str>| {
        let mut head = format!("GET /api/find?q={query} HTTP/1.1\r\nHost: {ADDR}\r\n");
        if let Some(token) = token {
            head.push_str(&format!("X-Splatseg-Token: {token}\r\n"));
        }
        let reply = request_bytes(site, access, format!("{head}\r\n").as_bytes());
        (status(&reply), body(&reply))
    };
    let (plain, access) = site(tmp.path().to_path_buf());
    let (code, text) = find(&plain, &access, "mug", Some(TOKEN));
    assert_eq!(code, 404, "no search function: {text}");
    assert!(text.contains("run --clip"), "{text}");
    assert!(!body(&request_bytes(
        &plain,
        &access,
        format!("GET /api/scene.json HTTP/1.1\r\nHost: {ADDR}\r\n\r\n").as_bytes()
    ))
    .contains("\"search\""));

    let (site, access) = site(tmp.path().to_path_buf());
    // the "ranking": the query's length as the id, to see what arrived; refused past 300
    // characters, as CLIP's tokenizer refuses what does not fit its context
    let site = site.with_search(Box::new(|q: &str, top: usize| match q.chars().count() {
        n if n > 300 => Err(format!("the query is {n} tokens long, more than the 75 CLIP reads")),
        n => Ok(vec![SearchHit { id: n as u32, relevancy: 0.75 }; top.min(2)]),
    }));
    let (code, text) = find(&site, &access, "a+red%20mug", Some(TOKEN));
    assert_eq!(code, 200, "{text}");
    let value: serde_json::Value = serde_json::from_str(&text).expect("json");
    assert_eq!(value["query"], "a red mug");
    assert_eq!(value["matches"][0]["id"], 9);
    assert_eq!(value["matches"].as_array().map(Vec::len), Some(2));
    assert_eq!(find(&site, &access, "mug", None).0, 403, "without the token");
    assert_eq!(find(&site, &access, "mug", Some("0000")).0, 403, "with another token");
    for blank in ["", "+++", "%20%09"] {
        let (code, text) = find(&site, &access, blank, Some(TOKEN));
        assert!(code == 400 && text.contains("is empty or blank"), "{blank:?}: {code} {text}");
    }
    assert_eq!(find(&site, &access, "%zz", Some(TOKEN)).0, 400, "bad encoding");
    // what the search function cannot read whole is refused in its words, 400 (was: 500), and
    // a query is not cut short of what CLIP reads by a lower bound here (was: 200 characters)
    let (code, text) = find(&site, &access, &"a".repeat(301), Some(TOKEN));
    assert!(code == 400 && text.contains("301 tokens long, more than the 75 CLIP reads"), "{code} {text}");
    let (code, text) = find(&site, &access, &"b".repeat(250), Some(TOKEN));
    assert_eq!(code, 200, "{text}");
    let long = "a".repeat(MAX_QUERY_CHARS + 1);
    let (code, text) = find(&site, &access, &long, Some(TOKEN));
    assert!(code == 400 && text.contains("shorten it"), "too long: {code} {text}");
    let manifest = request_bytes(
        &site,
        &access,
        format!("GET /api/scene.json HTTP/1.1\r\nHost: {ADDR}\r\n\r\n").as_bytes(),
    );
    assert!(body(&manifest).contains("\"search\":true"));
}

#[test]
fn the_names_of_view_names_go_into_the_manifest_objects() {
    use crate::search::ObjectName;
    let tmp = tempfile::tempdir().expect("temp dir");
    let (site, access) = site(tmp.path().to_path_buf());
    let manifest = |site: &crate::Site| -> serde_json::Value {
        let reply = request_bytes(
            site,
            &access,
            format!("GET /api/scene.json HTTP/1.1\r\nHost: {ADDR}\r\n\r\n").as_bytes(),
        );
        serde_json::from_str(&body(&reply)).expect("json")
    };
    let plain = manifest(&site);
    assert!(plain["objects"].as_array().expect("objects").iter().all(|o| o.get("name").is_none()));
    let named = ObjectName { id: 2, name: "a red mug".into(), relevancy: 0.625 };
    let unknown = ObjectName { id: 7, name: "lamp".into(), relevancy: 0.5 };
    let site = site.with_names(&[named, unknown]);
    let objects = manifest(&site)["objects"].clone();
    assert_eq!(objects[0]["id"], 1);
    assert!(objects[0].get("name").is_none(), "object 1 was given no name: {objects}");
    assert_eq!(objects[1]["id"], 2);
    assert_eq!(objects[1]["name"], "a red mug");
    assert_eq!(objects[1]["name_relevancy"], 0.625);
    assert_eq!(objects.as_array().map(Vec::len), Some(2), "a name of no object adds nothing");
}
