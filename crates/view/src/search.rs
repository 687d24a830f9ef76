//! The page's search box: `GET /api/find?q=TEXT` ranks the objects against a text query. The ranking
//! is the caller's ([`Search`], given at start with [`crate::Site::with_search`]): `splatseg view`
//! wires the CLIP embeddings `run --clip` wrote (`splatseg_model_cues::clip_objects`), so this crate
//! does not build candle. Without one, the manifest says `search: false` and `/api/find` is 404.
//!
//! The object list's names (`view --names`) are the caller's too ([`ObjectName`], given with
//! [`crate::Site::with_names`]): they go into the manifest's objects.
//!
//! The query is bounded ([`MAX_QUERY_CHARS`]), an empty or blank one refused, and, as it runs a model, the request needs the page's
//! token (`X-Splatseg-Token`, which another site's page cannot send without a preflight this server
//! never grants), besides the `Host` check every request has.

use serde::Serialize;

/// The path of the search endpoint.
pub const FIND_PATH: &str = "/api/find";
/// Longest query, in characters: a bound on what one request may ask for, far above what CLIP reads
/// (75 tokens and its start and end tokens); a query within it that CLIP cannot read whole is the
/// search function's to refuse, in the words `splatseg find` uses.
pub const MAX_QUERY_CHARS: usize = 1000;
/// Matches returned per query.
pub const SEARCH_TOP: usize = 10;

/// One ranked object.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SearchHit {
    /// The object's id.
    pub id: u32,
    /// Relevancy in (0, 1), best first.
    pub relevancy: f32,
}

/// An object's name from the list of `view --names`, as the caller computed it.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectName {
    /// The object's id.
    pub id: u32,
    /// Its best match among the names.
    pub name: String,
    /// The relevancy of that name to the object, in (0, 1).
    pub relevancy: f32,
}

/// Ranks the objects against a query (at most `top`), best first; an error in words, which the
/// page gets as the reply (400: once the text tower is loaded, what fails is the query, e.g. longer
/// than CLIP's context), so that the viewer refuses a query as `splatseg find` does.
pub type Search = Box<dyn Fn(&str, usize) -> Result<Vec<SearchHit>, String> + Send + Sync>;

/// The `q` parameter of a URL's query string, percent-decoded (`+` = space); `None` when absent or
/// not UTF-8 after decoding.
pub fn query_param(url: &str) -> Option<String> {
    let query = url.split('#').next()?.split_once('?')?.1;
    let raw = query.split('&').find_map(|pair| pair.strip_prefix("q="))?;
    let bytes = raw.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        match bytes[i] {
            b'+' => out.push(b' '),
            b'%' => {
                let hex = bytes.get(i + 1..i + 3)?;
                out.push(u8::from_str_radix(std::str::from_utf8(hex).ok()?, 16).ok()?);
                i += 2;
            }
            b => out.push(b),
        }
        i += 1;
    }
    String::from_utf8(out).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_query_is_decoded() {
        assert_eq!(query_param("/api/find?q=a+red%20mug").as_deref(), Some("a red mug"));
        assert_eq!(query_param("/api/find?x=1&q=caf%C3%A9#top").as_deref(), Some("café"));
        assert_eq!(query_param("/api/find?q=").as_deref(), Some(""));
        assert_eq!(query_param("/api/find"), None);
        assert_eq!(query_param("/api/find?q=%zz"), None);
        assert_eq!(query_param("/api/find?q=%FF"), None, "not UTF-8");
        assert_eq!(query_param("/api/find?q=%4"), None, "cut short");
    }
}
