//! Entity tags for the answers that are not tiles: the JSON descriptions (tagged by a hash
//! of their bytes) and views (tagged by what decides their mesh, before any work), so a
//! client polling them gets a body-less 304 instead of the same body again; and the
//! preconditions on them, `If-Match` before `If-None-Match` (RFC 9110 §13.2.2).

use std::hash::{DefaultHasher, Hash, Hasher};

use axum::body::Body;
use axum::http::header::{CACHE_CONTROL, CONTENT_TYPE, ETAG, VARY};
use axum::http::{HeaderMap, HeaderValue, StatusCode};
use axum::response::Response;
use serde::Serialize;

use crate::serve::codings::{self, Coding};
use crate::serve::error::{ApiError, ApiResult};
use crate::serve::negotiate;

/// What a description, view or mesh LOD carries: keep it, but ask each time. An upload
/// changes `/v1/meshes` and a mesh's LODs at once (a freshness lifetime, the tiles' hour,
/// would hide that from every client holding a copy), and a restart on re-ingested data
/// changes the dataset ones; the revalidation is cheap, its tag computed before any work.
pub const REVALIDATE: &str = "public, no-cache";

/// Part of every tag of a rendered answer (tiles, views): an upgrade may mesh the same
/// request differently, so a client's copy from the old server must not revalidate. The
/// crate's version alone did not move when the bytes did (0.1.0 all along), so the revision
/// after it counts changes to what a tile or view encodes: bump it with any. 2: GLB turned
/// to +Y up, a 65,536-vertex quantized-mesh tile padded to 65,537. 3: quantized-mesh and
/// ENU heights of EGM96 datasets raised to the ellipsoid (a dataset ingested now, served by
/// an older build, which ignores the field, would otherwise share their tags).
pub const RENDERER: &str = concat!("zerotile ", env!("CARGO_PKG_VERSION"), " r3");

/// A weak tag from a hash, naming the coding the body goes out in: each coding has its own
/// tag, as RFC 9110 §8.8.3 asks of strong ones, so a cache holding several never takes one
/// coding's 304 for another's copy. Weak, since the compression layer makes those bytes and
/// a change of its library may make others.
pub fn weak_tag(prefix: char, key: u64, coding: Coding) -> String {
    format!("W/\"{prefix}{key:016x}{}\"", coding.tag_suffix())
}

/// The validator headers a tagged answer carries, on its 200 and its 304 alike. `Vary:
/// accept-encoding` among them: the tag names the coding, picked from `Accept-Encoding`, and
/// the compression layer adds `Vary` only to the bodies it compresses, so an answer under its
/// 32 bytes (an empty LOD, an empty mesh list) went out with a `-br` tag and no `Vary`.
pub fn validators(h: &mut HeaderMap, etag: &str, cache_control: &str) -> ApiResult<()> {
    h.insert(
        ETAG,
        HeaderValue::from_str(etag).map_err(ApiError::internal)?,
    );
    h.insert(
        CACHE_CONTROL,
        HeaderValue::from_str(cache_control).map_err(ApiError::internal)?,
    );
    h.insert(VARY, HeaderValue::from_static("accept-encoding"));
    Ok(())
}

/// The 412 for an `If-Match` that `etag`, the current representation's tag (`None`: there
/// is none), does not pass.
pub fn if_match(headers: &HeaderMap, etag: Option<&str>) -> ApiResult<()> {
    if negotiate::if_match(headers, etag) {
        return Ok(());
    }
    let why = match etag {
        None => "there is no current representation to match".to_string(),
        Some(t) if t.starts_with("W/") => format!(
            "its tag {t} is weak, and If-Match compares strongly (RFC 9110 §13.1.1): only * \
             passes"
        ),
        Some(t) => format!("its tag is {t}"),
    };
    Err(ApiError::new(
        StatusCode::PRECONDITION_FAILED,
        "precondition_failed",
        format!("If-Match names no current representation of this resource: {why}"),
    ))
}

/// The request's preconditions on a representation tagged `etag`: the 412 error for a failed
/// `If-Match`, else the 304 when `If-None-Match` lists the tag. For answers whose every 4xx
/// is known before this; see [`Held`] for those that learn one from their work.
pub fn preconditions(
    headers: &HeaderMap,
    etag: &str,
    cache_control: &str,
) -> ApiResult<Option<Response>> {
    if_match(headers, Some(etag))?;
    not_modified(headers, etag, cache_control)
}

/// The 304 when `If-None-Match` lists `etag`.
fn not_modified(
    headers: &HeaderMap,
    etag: &str,
    cache_control: &str,
) -> ApiResult<Option<Response>> {
    if !negotiate::not_modified(headers, etag) {
        return Ok(None);
    }
    not_modified_response(etag, cache_control).map(Some)
}

fn not_modified_response(etag: &str, cache_control: &str) -> ApiResult<Response> {
    let mut res = Response::new(Body::empty());
    *res.status_mut() = StatusCode::NOT_MODIFIED;
    // With the 200's Vary, as a 304 repeats it (RFC 9110 §15.4.5).
    validators(res.headers_mut(), etag, cache_control)?;
    Ok(res)
}

/// The answer a precondition gives, held back until the work shows the request would
/// succeed without it: RFC 9110 §13.2.1 has a request that fails anyway (a view of no
/// terrain, 404; an octree level past the mesh's, 400) answer its own error. Held: a failed
/// `If-Match` (412), and the 304 of an `If-None-Match: *` (there may be no representation
/// to match). The work is done for them, as for the request without the headers; clients
/// send them to views and LODs rarely. An `If-None-Match` naming the tag itself is a 304 at
/// once: only a client that had the representation holds its tag.
#[must_use = "release() it once the request is known to succeed"]
pub struct Held(Option<Result<Response, ApiError>>);

impl Held {
    /// The preconditions on `etag`, in RFC 9110 §13.2.2's order: `Err` is the 304 to send
    /// now, `Ok` what to do once the work succeeds.
    pub fn check(
        headers: &HeaderMap,
        etag: &str,
        cache_control: &str,
    ) -> ApiResult<Result<Self, Response>> {
        if let Err(e) = if_match(headers, Some(etag)) {
            return Ok(Ok(Self(Some(Err(e)))));
        }
        if negotiate::none_match_lists_tag(headers, etag) {
            return Ok(Err(not_modified_response(etag, cache_control)?));
        }
        Ok(Ok(Self(if negotiate::none_match_lists_star(headers) {
            Some(Ok(not_modified_response(etag, cache_control)?))
        } else {
            None
        })))
    }

    /// The 412 or the 304 held, now that the request would have succeeded without them.
    pub fn release(self) -> ApiResult<Option<Response>> {
        self.0.transpose()
    }
}

/// The 412 for an upload's `If-None-Match` that lists one of `current`, the tags of the
/// representation it would replace in each coding (`None`: there is none), or `*` while
/// there is one (RFC 9110 §13.1.2: for a method other than GET and HEAD, a false condition
/// is 412).
pub fn if_none_match_on_write(headers: &HeaderMap, current: Option<&[String]>) -> ApiResult<()> {
    let listed = current
        .into_iter()
        .flatten()
        .find(|tag| negotiate::not_modified(headers, tag));
    match listed {
        Some(tag) => Err(ApiError::new(
            StatusCode::PRECONDITION_FAILED,
            "precondition_failed",
            format!(
                "If-None-Match names the current representation of this resource (tag {tag}, \
                 or *): the upload would replace it"
            ),
        )),
        None => Ok(()),
    }
}

/// `value` as JSON, and its tag: a hash of its bytes, in the coding the layer sends them in.
pub fn tagged(headers: &HeaderMap, value: &impl Serialize) -> ApiResult<(Vec<u8>, String)> {
    let (bytes, key) = json_key(value)?;
    Ok((bytes, weak_tag('j', key, codings::of_layer(headers))))
}

/// [`tagged`]'s tag of `value` in the layer's coding for `headers`, and in every coding: what
/// a client may hold of it, whichever `Accept-Encoding` it read it with.
pub fn tags(headers: &HeaderMap, value: &impl Serialize) -> ApiResult<(String, Vec<String>)> {
    let (_, key) = json_key(value)?;
    let every = Coding::ALL.map(|c| weak_tag('j', key, c)).to_vec();
    Ok((weak_tag('j', key, codings::of_layer(headers)), every))
}

fn json_key(value: &impl Serialize) -> ApiResult<(Vec<u8>, u64)> {
    let bytes = serde_json::to_vec(value).map_err(ApiError::internal)?;
    let mut h = DefaultHasher::new();
    bytes.hash(&mut h);
    Ok((bytes, h.finish()))
}

/// `value` as JSON with its [`tagged`] tag, or a 304 when the client holds those bytes (a 412
/// for an `If-Match` they do not pass).
pub fn json(
    headers: &HeaderMap,
    value: &impl Serialize,
    cache_control: &str,
) -> ApiResult<Response> {
    let (bytes, etag) = tagged(headers, value)?;
    if let Some(res) = preconditions(headers, &etag, cache_control)? {
        return Ok(res);
    }
    let mut res = Response::new(Body::from(bytes));
    res.headers_mut()
        .insert(CONTENT_TYPE, HeaderValue::from_static("application/json"));
    validators(res.headers_mut(), &etag, cache_control)?;
    Ok(res)
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::http::header::IF_NONE_MATCH;
    use serde_json::json;

    fn tag_of(res: &Response) -> String {
        res.headers()[ETAG].to_str().unwrap().to_string()
    }

    #[test]
    fn the_same_json_revalidates_and_other_json_does_not() {
        let v = json!({ "a": 1 });
        let first = json(&HeaderMap::new(), &v, REVALIDATE).unwrap();
        assert_eq!(first.status(), StatusCode::OK);
        assert_eq!(first.headers()[CACHE_CONTROL], REVALIDATE);
        let tag = tag_of(&first);
        assert!(tag.starts_with("W/\"j"), "{tag}");

        let mut h = HeaderMap::new();
        h.insert(IF_NONE_MATCH, HeaderValue::from_str(&tag).unwrap());
        let again = json(&h, &v, REVALIDATE).unwrap();
        assert_eq!(again.status(), StatusCode::NOT_MODIFIED);
        assert_eq!(tag_of(&again), tag);
        assert_eq!(again.headers()[CACHE_CONTROL], REVALIDATE);
        assert_eq!(again.headers()[VARY], "accept-encoding");

        let changed = json(&h, &json!({ "a": 2 }), REVALIDATE).unwrap();
        assert_eq!(changed.status(), StatusCode::OK);
        assert_ne!(tag_of(&changed), tag);
    }
}
