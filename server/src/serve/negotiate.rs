//! Content negotiation: quantized-mesh extensions from `Accept`, gzip from
//! `Accept-Encoding`, conditional requests and byte ranges. Header parsing only.

use axum::http::header::{ACCEPT, ACCEPT_ENCODING, IF_MATCH, IF_NONE_MATCH, IF_RANGE, RANGE, VARY};
use axum::http::{HeaderMap, HeaderValue};

use super::error::ApiError;

/// Media type of quantized-mesh tiles.
pub const QUANTIZED_MESH: &str = "application/vnd.quantized-mesh";

/// The quantized-mesh extensions a client asked for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Extensions {
    pub octvertexnormals: bool,
    pub watermask: bool,
    pub metadata: bool,
}

impl Extensions {
    /// Adds the names in a `-`-separated list (`octvertexnormals-metadata`); unknown names
    /// are ignored, as Cesium's servers do.
    fn add_list(&mut self, list: &str) {
        for name in list.split(['-', ',']) {
            match name.trim() {
                "octvertexnormals" => self.octvertexnormals = true,
                "watermask" => self.watermask = true,
                "metadata" => self.metadata = true,
                _ => {}
            }
        }
    }

    /// The list as it goes in a `Content-Type` parameter.
    pub fn names(&self) -> String {
        let mut v = Vec::new();
        if self.octvertexnormals {
            v.push("octvertexnormals");
        }
        if self.watermask {
            v.push("watermask");
        }
        if self.metadata {
            v.push("metadata");
        }
        v.join("-")
    }
}

/// Extensions from `Accept` and `?extensions=`. The most specific range that names
/// quantized-mesh decides (RFC 9110 §12.5.1): its own entries, else `application/*`, else
/// `*/*`; `application/octet-stream` also does, for clients that ask for any binary body. So
/// `application/vnd.quantized-mesh;q=0, */*` (anything but quantized-mesh) is refused with
/// 406, as is an `Accept` naming none of them. Every `Accept` line counts, as one list
/// (RFC 9110 §5.3: a proxy may split a list over lines, or join lines into one).
pub fn terrain_extensions(
    headers: &HeaderMap,
    query: Option<&str>,
) -> Result<Extensions, ApiError> {
    let mut ext = Extensions::default();
    if let Some(q) = query {
        ext.add_list(q);
    }
    if !headers.contains_key(ACCEPT) {
        return Ok(ext);
    }
    let lines = headers
        .get_all(ACCEPT)
        .iter()
        .map(|v| v.to_str().map_err(|_| not_acceptable()))
        .collect::<Result<Vec<_>, _>>()?;
    // Per range: listed at all, and listed with q > 0 (a weight that is no number is not a
    // refusal).
    let (mut exact, mut octet, mut application, mut any) = (None, None, None, None);
    for (media, params) in lines.into_iter().flat_map(list_items) {
        let ok = weight(&params).is_none_or(|q| q > 0.0);
        match media.as_str() {
            QUANTIZED_MESH => {
                mark(&mut exact, ok);
                if ok {
                    for (k, v) in &params {
                        if k == "extensions" {
                            ext.add_list(v);
                        }
                    }
                }
            }
            "application/octet-stream" => mark(&mut octet, ok),
            "application/*" => mark(&mut application, ok),
            "*/*" => mark(&mut any, ok),
            _ => {}
        }
    }
    let acceptable =
        exact.unwrap_or_else(|| octet == Some(true) || application.or(any).unwrap_or(false));
    if acceptable {
        Ok(ext)
    } else {
        Err(not_acceptable())
    }
}

/// The 406, with the `Vary: Accept` of every `.terrain` answer: `Accept` chose it.
fn not_acceptable() -> ApiError {
    ApiError::new(
        axum::http::StatusCode::NOT_ACCEPTABLE,
        "not_acceptable",
        format!("this route serves {QUANTIZED_MESH} (or */*, application/octet-stream)"),
    )
    .with_header(VARY, HeaderValue::from_static("Accept"))
}

/// Whether `Accept-Encoding` allows gzip: its own entry (`gzip`, `x-gzip`) decides when
/// listed, else `*`, which stands only for codings not listed (RFC 9110 §12.5.3), each with
/// q > 0. So `gzip;q=0, *` is no gzip: the tile is sent as the other layers would send it.
/// Every `Accept-Encoding` line counts, as one list.
pub fn accepts_gzip(headers: &HeaderMap) -> bool {
    let (mut named, mut any) = (None, None);
    let lines = headers.get_all(ACCEPT_ENCODING).iter();
    for (coding, params) in lines.filter_map(|v| v.to_str().ok()).flat_map(list_items) {
        // Here a weight that is no number does not allow the coding.
        let ok = weight(&params).is_some_and(|q| q > 0.0);
        match coding.as_str() {
            "gzip" | "x-gzip" => mark(&mut named, ok),
            "*" => mark(&mut any, ok),
            _ => {}
        }
    }
    named.or(any).unwrap_or(false)
}

/// The items of a comma-separated header list (`Accept`, `Accept-Encoding`): each token,
/// lowercased, with its parameters (keys lowercased, values unquoted).
fn list_items(value: &str) -> impl Iterator<Item = (String, Vec<(String, String)>)> + '_ {
    value.split(',').map(|item| {
        let mut parts = item.split(';');
        let token = parts.next().unwrap_or("").trim().to_ascii_lowercase();
        let params = parts
            .filter_map(|p| {
                let (k, v) = p.split_once('=')?;
                Some((
                    k.trim().to_ascii_lowercase(),
                    v.trim().trim_matches('"').to_string(),
                ))
            })
            .collect();
        (token, params)
    })
}

/// An item's weight: 1 without `q`, `None` when `q` is no number.
fn weight(params: &[(String, String)]) -> Option<f64> {
    params
        .iter()
        .find(|(k, _)| k == "q")
        .map_or(Some(1.0), |(_, v)| v.parse().ok())
}

/// Notes that a range (or coding) was listed, and whether with q > 0; listed twice, any
/// positive entry counts.
fn mark(slot: &mut Option<bool>, ok: bool) {
    *slot = Some(slot.unwrap_or(false) || ok);
}

/// Whether `If-Match` lets a request go on (RFC 9110 §13.1.1) against the resource's current
/// representation, tagged `current` (`None`: there is none): without `If-Match`; with `*`
/// when there is one; with a tag equal to `current` by the strong comparison, which a weak
/// tag on either side never passes (so only `*` passes where every tag is weak).
pub fn if_match(headers: &HeaderMap, current: Option<&str>) -> bool {
    if !headers.contains_key(IF_MATCH) {
        return true;
    }
    let Some(current) = current else {
        return false;
    };
    let strong = |t: &str| !t.starts_with("W/");
    headers
        .get_all(IF_MATCH)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(','))
        .map(str::trim)
        .any(|t| t == "*" || (strong(t) && strong(current) && t == current))
}

/// Whether `If-None-Match` lists `etag` (weak comparison, as RFC 9110 asks for GET) or `*`.
pub fn not_modified(headers: &HeaderMap, etag: &str) -> bool {
    none_match_lists_star(headers) || none_match_lists_tag(headers, etag)
}

/// Whether `If-None-Match` lists `etag` itself (weak comparison): only a client that had the
/// representation can send it.
pub fn none_match_lists_tag(headers: &HeaderMap, etag: &str) -> bool {
    let bare = |t: &str| t.trim().trim_start_matches("W/").to_string();
    none_match_entries(headers).any(|t| t != "*" && bare(t) == bare(etag))
}

/// Whether `If-None-Match` lists `*`: "any current representation".
pub fn none_match_lists_star(headers: &HeaderMap) -> bool {
    none_match_entries(headers).any(|t| t == "*")
}

fn none_match_entries(headers: &HeaderMap) -> impl Iterator<Item = &str> {
    headers
        .get_all(IF_NONE_MATCH)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(','))
        .map(str::trim)
}

/// Whether `Range` may be honoured (RFC 9110 §13.1.5): with no `If-Range`, or one naming
/// this body's strong entity tag. A weak tag never matches, nor does a date (tiles carry no
/// `Last-Modified`): the client then gets the whole body, never a part of another build.
pub fn if_range_allows(headers: &HeaderMap, etag: &str) -> bool {
    match headers.get(IF_RANGE) {
        None => true,
        Some(v) => !etag.starts_with("W/") && v.as_bytes() == etag.as_bytes(),
    }
}

/// What a `Range` header asks of a body of `len` bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RangeAsk {
    /// No usable single range: send everything (multiple ranges are answered whole too).
    Full,
    /// Bytes start..=end.
    Part { start: u64, end: u64 },
    /// Outside the body: 416.
    Unsatisfiable,
}

/// Parses `Range: bytes=a-b | a- | -n` against a body of `len` bytes. Two `Range` lines are
/// one list (RFC 9110 §5.3), so several ranges: the whole body, as for a comma.
pub fn range(headers: &HeaderMap, len: u64) -> RangeAsk {
    let mut lines = headers.get_all(RANGE).iter();
    let (Some(v), None) = (lines.next().and_then(|v| v.to_str().ok()), lines.next()) else {
        return RangeAsk::Full;
    };
    let Some(spec) = v.trim().strip_prefix("bytes=") else {
        return RangeAsk::Full;
    };
    if spec.contains(',') {
        return RangeAsk::Full;
    }
    let Some((a, b)) = spec.split_once('-') else {
        return RangeAsk::Full;
    };
    let (a, b) = (a.trim(), b.trim());
    // RFC 9110 positions are digits of any length: one past u64 is past every body.
    let parse = |s: &str| {
        (!s.is_empty() && s.bytes().all(|c| c.is_ascii_digit()))
            .then(|| s.parse::<u64>().unwrap_or(u64::MAX))
    };
    match (a.is_empty(), b.is_empty()) {
        // Suffix: the last n bytes.
        (true, false) => match parse(b) {
            Some(0) => RangeAsk::Unsatisfiable,
            Some(n) if len > 0 => RangeAsk::Part {
                start: len.saturating_sub(n),
                end: len - 1,
            },
            Some(_) => RangeAsk::Unsatisfiable,
            None => RangeAsk::Full,
        },
        (false, _) => {
            let Some(start) = parse(a) else {
                return RangeAsk::Full;
            };
            let end = if b.is_empty() {
                Some(u64::MAX)
            } else {
                parse(b)
            };
            let Some(end) = end else {
                return RangeAsk::Full;
            };
            if end < start {
                return RangeAsk::Full;
            }
            if start >= len {
                return RangeAsk::Unsatisfiable;
            }
            RangeAsk::Part {
                start,
                end: end.min(len - 1),
            }
        }
        (true, true) => RangeAsk::Full,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::http::HeaderValue;

    fn with(name: axum::http::HeaderName, v: &'static str) -> HeaderMap {
        let mut h = HeaderMap::new();
        h.insert(name, HeaderValue::from_static(v));
        h
    }

    #[test]
    fn cesium_accept_header_gives_its_extensions() {
        let h = with(
            ACCEPT,
            "application/vnd.quantized-mesh;extensions=octvertexnormals-watermask-metadata,application/octet-stream;q=0.9,*/*;q=0.01",
        );
        let e = terrain_extensions(&h, None).unwrap();
        assert!(e.octvertexnormals && e.watermask && e.metadata);
        assert!(terrain_extensions(&with(ACCEPT, "image/png"), None).is_err());
        assert_eq!(
            terrain_extensions(&HeaderMap::new(), Some("metadata"))
                .unwrap()
                .names(),
            "metadata"
        );
    }

    /// Two `Accept` lines are one list: a range, its extensions or its refusal on the second
    /// line counts as on the first (only the first was read: 406 for an `image/png` line
    /// before a quantized-mesh one, and no normals after a `*/*` line).
    #[test]
    fn accept_lines_are_one_list() {
        let two = |first: &'static str, second: &'static str| {
            let mut h = with(ACCEPT, first);
            h.append(ACCEPT, HeaderValue::from_static(second));
            terrain_extensions(&h, None)
        };
        assert_eq!(
            two("image/png", QUANTIZED_MESH).unwrap(),
            Extensions::default()
        );
        let e = two(
            "*/*",
            "application/vnd.quantized-mesh;extensions=octvertexnormals",
        )
        .unwrap();
        assert!(e.octvertexnormals && !e.watermask && !e.metadata, "{e:?}");
        assert!(two("*/*", "application/vnd.quantized-mesh;q=0").is_err());
        assert!(two("image/png", "text/html").is_err());
    }

    /// The most specific range decides: refusing quantized-mesh by name is not undone by a
    /// wildcard, and `application/*;q=0` outranks `*/*`.
    #[test]
    fn a_named_refusal_of_quantized_mesh_outranks_wildcards() {
        for refused in [
            "application/vnd.quantized-mesh;q=0, */*",
            "*/*, application/vnd.quantized-mesh;q=0",
            "application/*;q=0, */*",
            "application/vnd.quantized-mesh;q=0, application/octet-stream;q=0, */*",
        ] {
            assert!(
                terrain_extensions(&with(ACCEPT, refused), None).is_err(),
                "{refused}"
            );
        }
        for allowed in [
            "application/vnd.quantized-mesh;q=0.5, */*;q=0",
            "application/octet-stream, */*;q=0",
            "application/octet-stream;q=0, */*",
            "application/*, */*;q=0",
        ] {
            assert!(
                terrain_extensions(&with(ACCEPT, allowed), None).is_ok(),
                "{allowed}"
            );
        }
        // A refused entry's extensions are not taken from it.
        let h = with(
            ACCEPT,
            "application/vnd.quantized-mesh;extensions=metadata;q=0, application/vnd.quantized-mesh",
        );
        assert_eq!(terrain_extensions(&h, None).unwrap(), Extensions::default());
    }

    #[test]
    fn gzip_needs_a_positive_q() {
        assert!(accepts_gzip(&with(ACCEPT_ENCODING, "gzip, deflate, br")));
        assert!(!accepts_gzip(&with(ACCEPT_ENCODING, "gzip;q=0, br")));
        assert!(!accepts_gzip(&with(ACCEPT_ENCODING, "identity")));
        assert!(!accepts_gzip(&HeaderMap::new()));
        // `*` stands only for the codings not listed: a refused gzip stays refused.
        assert!(!accepts_gzip(&with(ACCEPT_ENCODING, "gzip;q=0, *")));
        assert!(!accepts_gzip(&with(ACCEPT_ENCODING, "*, br;q=0, gzip;q=0")));
        assert!(accepts_gzip(&with(ACCEPT_ENCODING, "br;q=0, *")));
        assert!(accepts_gzip(&with(ACCEPT_ENCODING, "gzip;q=0.5, *;q=0")));
        // Two header lines are one list.
        let mut h = with(ACCEPT_ENCODING, "br");
        h.append(ACCEPT_ENCODING, HeaderValue::from_static("gzip"));
        assert!(accepts_gzip(&h));
    }

    #[test]
    fn ranges_follow_rfc_9110() {
        let r = |v: &'static str, len| range(&with(RANGE, v), len);
        assert_eq!(r("bytes=0-9", 100), RangeAsk::Part { start: 0, end: 9 });
        assert_eq!(r("bytes=90-", 100), RangeAsk::Part { start: 90, end: 99 });
        assert_eq!(r("bytes=-10", 100), RangeAsk::Part { start: 90, end: 99 });
        assert_eq!(
            r("bytes=50-500", 100),
            RangeAsk::Part { start: 50, end: 99 }
        );
        assert_eq!(r("bytes=100-", 100), RangeAsk::Unsatisfiable);
        assert_eq!(r("bytes=0-1,5-6", 100), RangeAsk::Full);
        // Two lines are two ranges, as a comma is (only the first was read).
        let mut two = with(RANGE, "bytes=0-1");
        two.append(RANGE, HeaderValue::from_static("bytes=5-6"));
        assert_eq!(range(&two, 100), RangeAsk::Full);
        assert_eq!(r("items=0-1", 100), RangeAsk::Full);
        // Positions too long for u64 are still positions, not garbage.
        assert_eq!(
            r("bytes=99999999999999999999999-", 100),
            RangeAsk::Unsatisfiable
        );
        assert_eq!(
            r("bytes=10-99999999999999999999999", 100),
            RangeAsk::Part { start: 10, end: 99 }
        );
        assert_eq!(
            r("bytes=-99999999999999999999999", 100),
            RangeAsk::Part { start: 0, end: 99 }
        );
        assert_eq!(r("bytes=+5-9", 100), RangeAsk::Full);
        // A last position before the first is not a range (RFC 9110 §14.1.1): ignored.
        assert_eq!(r("bytes=9-0", 100), RangeAsk::Full);
    }

    /// One byte (first and last position equal) is a range; an empty body has no bytes to
    /// give, not even the last n of them.
    #[test]
    fn single_byte_ranges_and_empty_bodies() {
        let r = |v: &'static str, len| range(&with(RANGE, v), len);
        assert_eq!(r("bytes=5-5", 100), RangeAsk::Part { start: 5, end: 5 });
        assert_eq!(r("bytes=99-99", 100), RangeAsk::Part { start: 99, end: 99 });
        assert_eq!(r("bytes=0-0", 1), RangeAsk::Part { start: 0, end: 0 });
        assert_eq!(r("bytes=-5", 1), RangeAsk::Part { start: 0, end: 0 });
        for v in ["bytes=-5", "bytes=-0", "bytes=0-", "bytes=0-0"] {
            assert_eq!(r(v, 0), RangeAsk::Unsatisfiable, "{v}");
        }
        assert_eq!(r("bytes=-0", 100), RangeAsk::Unsatisfiable);
    }

    /// If-Match compares strongly: a stream prefix's own tag passes, its weak form or a weak
    /// current tag never does; `*` passes while there is a representation; any listed tag
    /// will do.
    #[test]
    fn if_match_compares_strongly() {
        let strong = Some("\"abc\"");
        let weak = Some("W/\"abc\"");
        assert!(if_match(&HeaderMap::new(), strong));
        assert!(if_match(&HeaderMap::new(), None));
        for (listed, current, passes) in [
            ("\"abc\"", strong, true),
            ("\"x\", \"abc\"", strong, true),
            ("*", strong, true),
            ("*", weak, true),
            ("*", None, false),
            ("\"abd\"", strong, false),
            ("W/\"abc\"", strong, false),
            ("\"abc\"", weak, false),
            ("W/\"abc\"", weak, false),
            ("\"abc\"", None, false),
        ] {
            let h = with(IF_MATCH, listed);
            assert_eq!(if_match(&h, current), passes, "{listed} on {current:?}");
        }
        // Two lines are one list.
        let mut h = with(IF_MATCH, "\"x\"");
        h.append(IF_MATCH, HeaderValue::from_static("\"abc\""));
        assert!(if_match(&h, strong));
    }

    #[test]
    fn etags_compare_weakly() {
        let h = with(IF_NONE_MATCH, "\"x\", W/\"abc\"");
        assert!(not_modified(&h, "W/\"abc\""));
        assert!(!not_modified(&h, "W/\"abd\""));
        // `*` matches any current representation (RFC 9110 §13.1.2).
        assert!(not_modified(&with(IF_NONE_MATCH, "*"), "W/\"abd\""));
        assert!(!not_modified(&HeaderMap::new(), "W/\"abd\""));
    }
}
