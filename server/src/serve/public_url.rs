//! The origin (and path prefix) a client reached the server at, for the one document that
//! must carry absolute URLs: TileJSON (its spec leaves relative tile URLs undefined and
//! MapLibre fails on them). Everything else the server writes links relatively.
//!
//! Behind a proxy, `X-Forwarded-Proto`, `X-Forwarded-Host` and `X-Forwarded-Prefix` say what
//! the client used; else the `Host` header, over plain HTTP (which is all the server speaks).
//! The values end up in a document caches keep, so they are checked, not copied.

use axum::http::HeaderMap;

use super::error::{ApiError, ApiResult};

/// The headers the answer depends on, for `Vary`.
pub const VARY: &str = "Host, X-Forwarded-Proto, X-Forwarded-Host, X-Forwarded-Prefix";

/// `scheme://host[:port][/prefix]`, without a trailing slash.
pub fn origin(headers: &HeaderMap) -> ApiResult<String> {
    let first = |name: &str| -> ApiResult<Option<String>> {
        match headers.get(name) {
            None => Ok(None),
            Some(v) => {
                let s = v.to_str().map_err(|_| bad(name, "is not ASCII"))?;
                // A proxy chain appends: the first value is what the client sent.
                Ok(s.split(',').next().map(|s| s.trim().to_string()))
            }
        }
    };
    let proto = first("x-forwarded-proto")?.unwrap_or_else(|| "http".into());
    if proto != "http" && proto != "https" {
        return Err(bad("X-Forwarded-Proto", "must be http or https"));
    }
    let host = match first("x-forwarded-host")? {
        Some(h) => h,
        None => first("host")?.ok_or_else(|| {
            ApiError::bad_request(
                "missing_host",
                "a Host header is needed to write the absolute tile URLs TileJSON holds",
            )
        })?,
    };
    if !valid_host(&host) {
        return Err(bad(
            "Host",
            "must be a host name or address with an optional port",
        ));
    }
    let prefix = first("x-forwarded-prefix")?.unwrap_or_default();
    let prefix = prefix.trim_end_matches('/');
    let path_char = |c: char| c.is_ascii_alphanumeric() || "/-._~".contains(c);
    if !(prefix.is_empty() || prefix.starts_with('/') && prefix.chars().all(path_char)) {
        return Err(bad("X-Forwarded-Prefix", "must be a path starting with /"));
    }
    Ok(format!("{proto}://{host}{prefix}"))
}

fn bad(header: &str, why: &str) -> ApiError {
    ApiError::bad_request("bad_header", format!("{header} {why}"))
}

/// A DNS name or IPv4 address, or a bracketed IPv6 address, then an optional `:port`.
fn valid_host(h: &str) -> bool {
    let (name, port) = if let Some(rest) = h.strip_prefix('[') {
        let Some((addr, after)) = rest.split_once(']') else {
            return false;
        };
        let ipv6 = |c: char| c.is_ascii_hexdigit() || c == ':' || c == '.';
        if addr.is_empty() || !addr.chars().all(ipv6) {
            return false;
        }
        let port = match after {
            "" => None,
            a => match a.strip_prefix(':') {
                Some(p) => Some(p),
                None => return false,
            },
        };
        (None, port)
    } else {
        match h.rsplit_once(':') {
            Some((n, p)) => (Some(n), Some(p)),
            None => (Some(h), None),
        }
    };
    let name_ok = name.is_none_or(|n| {
        !n.is_empty()
            && n.len() <= 253
            && n.chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '.')
    });
    let port_ok = port.is_none_or(|p| !p.is_empty() && p.len() <= 5 && p.parse::<u16>().is_ok());
    name_ok && port_ok
}

#[cfg(test)]
mod tests {
    use super::*;

    fn headers(pairs: &[(&'static str, &str)]) -> HeaderMap {
        let mut h = HeaderMap::new();
        for (k, v) in pairs {
            h.append(*k, v.parse().unwrap());
        }
        h
    }

    #[test]
    fn host_header_over_http() {
        let o = origin(&headers(&[("host", "127.0.0.1:8080")])).unwrap();
        assert_eq!(o, "http://127.0.0.1:8080");
        let o = origin(&headers(&[("host", "[::1]:9000")])).unwrap();
        assert_eq!(o, "http://[::1]:9000");
    }

    #[test]
    fn a_proxy_says_what_the_client_used() {
        let h = headers(&[
            ("host", "10.0.0.7:8080"),
            ("x-forwarded-proto", "https, http"),
            ("x-forwarded-host", "tiles.example.org"),
            ("x-forwarded-prefix", "/terrain/"),
        ]);
        assert_eq!(origin(&h).unwrap(), "https://tiles.example.org/terrain");
    }

    #[test]
    fn odd_values_are_refused_not_echoed() {
        for h in [
            headers(&[]),
            headers(&[("host", "a.example\"><script>")]),
            headers(&[("host", "a.example:99999")]),
            headers(&[("host", "a.example:")]),
            headers(&[("host", "[::1]x")]),
            headers(&[("host", "a.example"), ("x-forwarded-proto", "javascript")]),
            headers(&[("host", "a.example"), ("x-forwarded-prefix", "terrain")]),
            headers(&[("host", "a.example"), ("x-forwarded-prefix", "/a?b")]),
        ] {
            assert!(origin(&h).is_err(), "{h:?}");
        }
    }
}
