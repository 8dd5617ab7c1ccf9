//! The content codings answers go out in, and the 406 for a client that accepts none.
//!
//! The compression layer answers such a client 406 (RFC 9110 §12.5.3), but only once the
//! handler has made its answer: a tile was decoded and meshed to be dropped. The middleware
//! here gives the 406 first, on the compression layer's own decision (asked on the request's
//! `Accept-Encoding`), so the two cannot disagree on which clients get one.
//!
//! Every coding of an answer has its own ETag (RFC 9110 §8.8.3: a validator names one
//! representation, and a cache that keeps several may update or serve the one a tag names),
//! so a handler names the coding before the layer picks it: [`of_layer`] restates the
//! layer's choice, and a test holds the two together.

use std::convert::Infallible;

use axum::body::Body;
use axum::extract::Request;
use axum::http::header::ACCEPT_ENCODING;
use axum::http::{HeaderMap, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use tower::{Layer, ServiceExt};
use tower_http::compression::predicate::{DefaultPredicate, NotForContentType, Predicate};
use tower_http::compression::CompressionLayer;

use super::error::ApiError;
use super::routes::tiles::EZW_MEDIA;

/// What the 406 says, whichever layer made it.
pub const NOT_ACCEPTABLE_MESSAGE: &str =
    "no content coding the client accepts: this server sends gzip, br or identity";

/// The codings the server compresses with: the app's compression layer and the probe below
/// are both built from it.
pub fn layer() -> CompressionLayer {
    CompressionLayer::new()
}

/// Media types sent as they are, beside the images the layer leaves alone by default: EZW
/// prefixes are arithmetic-coded, GLB is binary already.
const SENT_AS_THEY_ARE: [&str; 2] = [EZW_MEDIA, "model/gltf-binary"];

/// The app's compression layer: [`layer`], leaving compact bodies alone (and tiles a handler
/// compressed: the layer never compresses a body with a `Content-Encoding`).
pub fn app_layer() -> CompressionLayer<impl Predicate> {
    let [ezw, glb] = SENT_AS_THEY_ARE;
    layer().compress_when(
        DefaultPredicate::new()
            .and(NotForContentType::const_new(ezw))
            .and(NotForContentType::const_new(glb)),
    )
}

/// A content coding an answer goes out in, in the layer's order of preference when weights
/// tie (br, then gzip, then none).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Coding {
    Identity,
    Gzip,
    Br,
}

impl Coding {
    /// Every coding a body goes out in.
    pub const ALL: [Self; 3] = [Self::Identity, Self::Gzip, Self::Br];

    /// Its `Content-Encoding` value; identity has none.
    pub fn content_encoding(self) -> Option<&'static str> {
        match self {
            Self::Identity => None,
            Self::Gzip => Some("gzip"),
            Self::Br => Some("br"),
        }
    }

    /// What an ETag of a body in this coding ends with: nothing for identity.
    pub fn tag_suffix(self) -> &'static str {
        match self {
            Self::Identity => "",
            Self::Gzip => "-gzip",
            Self::Br => "-br",
        }
    }
}

/// The coding the compression layer sends an answer of `media` in, for a request with these
/// headers: none for the media it leaves alone, else [`of_layer`]. (A body under the layer's
/// 32 bytes goes out as it is under the coding's tag: a tag too many, never one shared.)
pub fn of_answer(headers: &HeaderMap, media: &str) -> Coding {
    // The layer's default leaves images alone but SVG, which is text.
    let image = media.starts_with("image/") && media != "image/svg+xml";
    let plain = image || SENT_AS_THEY_ARE.contains(&media);
    if plain {
        Coding::Identity
    } else {
        of_layer(headers)
    }
}

/// The coding the compression layer picks for a compressible answer: tower-http's rule,
/// restated (it is not public). The highest weight of gzip (or `x-gzip`), br and identity
/// wins, ties going to br, then gzip; without `*` only the codings listed count (the highest
/// of each one's entries), with it each coding takes its first entry's weight, else `*`'s;
/// an entry whose weight is not `q=` with 0 or 1 and up to three decimals is ignored.
/// Identity when nothing is acceptable (a 406, answered before any handler).
pub fn of_layer(headers: &HeaderMap) -> Coding {
    let mut listed = Vec::new();
    let mut any = None;
    let lines = headers.get_all(ACCEPT_ENCODING).iter();
    for item in lines
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(','))
    {
        let (name, q) = match item.split_once(';') {
            Some((name, q)) => (name.trim(), layer_weight(q.trim())),
            None => (item.trim(), Some(1000)),
        };
        let Some(q) = q else { continue };
        let coding = if name == "*" {
            any.get_or_insert(q);
            continue;
        } else if name.eq_ignore_ascii_case("gzip") || name.eq_ignore_ascii_case("x-gzip") {
            Coding::Gzip
        } else if name.eq_ignore_ascii_case("br") {
            Coding::Br
        } else if name.eq_ignore_ascii_case("identity") {
            Coding::Identity
        } else {
            continue;
        };
        listed.push((coding, q));
    }
    let weight = |c: Coding| {
        let mut entries = listed.iter().filter(|(l, _)| *l == c).map(|&(_, q)| q);
        match any {
            None => entries.max(),
            Some(any) => Some(entries.next().unwrap_or(any)),
        }
    };
    [Coding::Identity, Coding::Gzip, Coding::Br]
        .into_iter()
        .filter_map(|c| weight(c).filter(|&q| q > 0).map(|q| (q, c)))
        .max()
        .map_or(Coding::Identity, |(_, c)| c)
}

/// A weight as the layer reads it, in thousandths: `q=` (or `Q=`), then `0` or `1`, then
/// optionally `.` and up to three digits, at most 1; `None` otherwise.
fn layer_weight(s: &str) -> Option<u16> {
    let v = s.strip_prefix("q=").or_else(|| s.strip_prefix("Q="))?;
    let (whole, fraction) = v.split_once('.').unwrap_or((v, ""));
    let whole = match whole {
        "0" => 0,
        "1" => 1000,
        _ => return None,
    };
    if fraction.len() > 3 || !fraction.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let thousandths = fraction
        .bytes()
        .zip([100, 10, 1])
        .map(|(d, scale)| u16::from(d - b'0') * scale)
        .sum::<u16>();
    Some(whole + thousandths).filter(|&q| q <= 1000)
}

/// Middleware, inside the compression layer: a request accepting no coding the server has
/// is answered 406 without running its handler.
pub async fn refuse_unacceptable(req: Request, next: Next) -> Response {
    if accepts_a_coding(&req).await {
        next.run(req).await
    } else {
        // An upload still sending would get a broken pipe instead of the answer.
        super::routes::meshes::drain(req.into_body());
        ApiError::new(
            StatusCode::NOT_ACCEPTABLE,
            "not_acceptable",
            NOT_ACCEPTABLE_MESSAGE,
        )
        .into_response()
    }
}

/// Asks the compression layer, around an empty answer, what it would do with this request.
/// Only a header with a weight can refuse identity (`identity;q=0`, `*;q=0`): without one,
/// as browsers and curl send it, there is nothing to ask, and tile requests skip the probe.
fn accepts_a_coding(req: &Request) -> impl std::future::Future<Output = bool> + Send {
    let weighted = req.headers().get_all(ACCEPT_ENCODING).iter().any(|v| {
        v.as_bytes()
            .windows(2)
            .any(|w| w.eq_ignore_ascii_case(b"q="))
    });
    // Built before the await: a `&Request` (its body is not `Sync`) cannot be held across it.
    let probe = weighted.then(|| {
        let mut probe = Request::new(Body::empty());
        for v in req.headers().get_all(ACCEPT_ENCODING) {
            probe.headers_mut().append(ACCEPT_ENCODING, v.clone());
        }
        probe
    });
    async move {
        let Some(probe) = probe else {
            return true;
        };
        let empty = tower::service_fn(|_: Request| async {
            Ok::<_, Infallible>(Response::new(Body::empty()))
        });
        layer()
            .layer(empty)
            .oneshot(probe)
            .await
            .map_or(true, |res| res.status() != StatusCode::NOT_ACCEPTABLE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::http::header::CONTENT_TYPE;

    async fn accepts(values: &[&str]) -> bool {
        let mut req = Request::new(Body::empty());
        for v in values {
            req.headers_mut()
                .append(ACCEPT_ENCODING, v.parse().unwrap());
        }
        accepts_a_coding(&req).await
    }

    /// What the layer sends a compressible answer in for these `Accept-Encoding` lines;
    /// `None` for its 406.
    async fn layer_picks(lines: &[&str]) -> Option<Coding> {
        let mut req = Request::new(Body::empty());
        for v in lines {
            req.headers_mut()
                .append(ACCEPT_ENCODING, v.parse().unwrap());
        }
        let answer = tower::service_fn(|_: Request| async {
            let mut res = Response::new(Body::from(vec![b'{'; 64]));
            res.headers_mut()
                .insert(CONTENT_TYPE, "application/json".parse().unwrap());
            Ok::<_, Infallible>(res)
        });
        let res = app_layer().layer(answer).oneshot(req).await.unwrap();
        if res.status() == StatusCode::NOT_ACCEPTABLE {
            return None;
        }
        Some(match res.headers().get("content-encoding") {
            None => Coding::Identity,
            Some(v) if v == "gzip" => Coding::Gzip,
            Some(v) if v == "br" => Coding::Br,
            Some(v) => panic!("{lines:?}: the layer sent {v:?}"),
        })
    }

    /// `of_layer` names the coding the layer then sends, so a tag made before the answer
    /// names its body's coding.
    #[tokio::test]
    async fn of_layer_is_the_layers_choice() {
        for lines in [
            &[][..],
            &[""],
            &["gzip"],
            &["br"],
            &["gzip, br"],
            &["br, gzip"],
            &["gzip, deflate, br, zstd"],
            &["gzip;q=0.5, br;q=0.4"],
            &["gzip;q=0.5, br;q=0.5"],
            &["br;q=0.5, identity"],
            &["identity"],
            &["identity;q=0.5, gzip;q=0.2"],
            &["*"],
            &["*;q=0.3, gzip;q=0.2"],
            &["gzip;q=0, *"],
            &["*, br;q=0"],
            &["*, br;q=0, br"],
            &["br, br;q=0"],
            &["br;q=0"],
            &["x-gzip"],
            &["GZIP"],
            &["Br;Q=1"],
            &["gzip;level=1"],
            &["br;q=0.5;x=1, gzip;q=0.1"],
            &["br;q=1.5, gzip;q=0.1"],
            &["br;q=0.5555, gzip;q=0.1"],
            &["br;q=1., gzip;q=0."],
            &["gzip;q=abc, br;q=0.5, *"],
            &["gzip ; q=0.5, br; q=0.6"],
            &["gzip; q =0.5, br;q=0.1"],
            &[" * ; q=0.5, identity;q=0.6"],
            &["deflate"],
            &["zstd, gzip;q=0.1"],
            &["identity;q=0, br"],
            &["deflate", "gzip"],
            &["br;q=0.1", "gzip;q=0.2"],
            &["*;q=0.1", "*;q=0.9, gzip;q=0.2"],
        ] {
            let mut h = HeaderMap::new();
            for v in lines {
                h.append(ACCEPT_ENCODING, v.parse().unwrap());
            }
            let picked = layer_picks(lines).await.unwrap_or(Coding::Identity);
            assert_eq!(of_layer(&h), picked, "{lines:?}");
        }
    }

    /// The layer compresses SVG, the one image type it does not leave alone.
    #[test]
    fn svg_is_compressed_and_other_images_are_not() {
        let mut h = HeaderMap::new();
        h.insert(ACCEPT_ENCODING, "br".parse().unwrap());
        assert_eq!(of_answer(&h, "image/svg+xml"), Coding::Br);
        assert_eq!(of_answer(&h, "image/png"), Coding::Identity);
        assert_eq!(of_answer(&h, "application/json"), Coding::Br);
    }

    #[tokio::test]
    async fn only_a_client_refusing_every_coding_is_refused() {
        for ok in [
            &[][..],
            &["gzip"],
            &["identity;q=0, gzip"],
            &["*;q=0, br"],
            &["identity;q=0", "gzip"],
            &["deflate"],
            &[""],
        ] {
            assert!(accepts(ok).await, "{ok:?}");
        }
        for refused in [
            &["identity;q=0"][..],
            &["*;q=0"],
            &["identity;q=0, gzip;q=0, br;q=0"],
            &["deflate, identity;q=0"],
        ] {
            assert!(!accepts(refused).await, "{refused:?}");
        }
    }
}
