//! The URL clients reach the server at, for the one document that must carry absolute URLs:
//! TileJSON (its spec leaves relative tile URLs undefined and MapLibre fails on them).
//! Everything else the server writes links relatively.
//!
//! In order: `serve --public-url` when given (the robust choice behind a CDN); else the
//! request's `Host` (HTTP/2: `:authority`), over plain HTTP, which is all the server speaks.
//! `X-Forwarded-Proto`, `-Host` and `-Prefix` count only with `serve --trust-forwarded`: any
//! client can send them, and the answer is cacheable, so trusting them by default would let
//! one request point every map at another host for as long as a cache keeps it. Values are
//! checked, never copied as they come.

use axum::http::{HeaderMap, Uri};

use super::error::{echo, ApiError, ApiResult};
use super::Config;

/// `Vary` for an answer whose URLs follow the request (none is needed with `--public-url`).
pub fn vary(config: &Config) -> Option<&'static str> {
    match (&config.public_url, config.trust_forwarded) {
        (Some(_), _) => None,
        (None, false) => Some("Host"),
        (None, true) => Some("Host, X-Forwarded-Proto, X-Forwarded-Host, X-Forwarded-Prefix"),
    }
}

/// `scheme://host[:port][/prefix]`, without a trailing slash.
pub fn origin(config: &Config, headers: &HeaderMap, uri: &Uri) -> ApiResult<String> {
    if let Some(u) = &config.public_url {
        return Ok(u.clone());
    }
    // A proxy appends to these, to the last line or in a line of its own: the last value of
    // the last line is the one the nearest (trusted) proxy set. (`get` gives the first line,
    // which a client could send ahead of the proxy's.)
    let forwarded = |name: &str| -> ApiResult<Option<String>> {
        if !config.trust_forwarded {
            return Ok(None);
        }
        match headers.get_all(name).iter().next_back() {
            None => Ok(None),
            Some(v) => {
                let s = v.to_str().map_err(|_| bad(name, "is not ASCII"))?;
                Ok(s.rsplit(',').next().map(|s| s.trim().to_string()))
            }
        }
    };
    let proto = forwarded("x-forwarded-proto")?.unwrap_or_else(|| "http".into());
    if proto != "http" && proto != "https" {
        return Err(bad("X-Forwarded-Proto", "must be http or https"));
    }
    let forwarded_host = forwarded("x-forwarded-host")?;
    // Where the host comes from, for the error that names it. An absolute-form request
    // target (`GET http://h/… HTTP/1.1`) or HTTP/2's :authority names it ahead of `Host`,
    // which an origin server must then ignore (RFC 9112 §3.2.2).
    let (host, source) = match (forwarded_host, uri.authority()) {
        (Some(h), _) => (h, "X-Forwarded-Host"),
        (None, Some(a)) => (a.to_string(), "request target"),
        (None, None) => match headers.get("host") {
            Some(v) => (
                v.to_str()
                    .map_err(|_| bad("Host", "is not ASCII"))?
                    .to_string(),
                "Host",
            ),
            None => {
                return Err(ApiError::bad_request(
                    "missing_host",
                    "a Host header is needed to write the absolute tile URLs TileJSON holds \
                     (or start the server with --public-url)",
                ))
            }
        },
    };
    if !valid_host(&host) {
        return Err(bad(
            source,
            "must be a host name or address with an optional port",
        ));
    }
    let prefix = forwarded("x-forwarded-prefix")?.unwrap_or_default();
    let prefix = prefix.trim_end_matches('/');
    if !valid_path(prefix) {
        return Err(bad("X-Forwarded-Prefix", "must be a path starting with /"));
    }
    Ok(format!("{proto}://{host}{prefix}"))
}

/// Checks a base URL given on the command line (`serve --public-url`, `export --base-url`):
/// `http(s)://host[:port][/path]`, no query, fragment or user info. Returns it without a
/// trailing slash, ready to have `/{z}/…` appended.
pub fn parse_base(url: &str) -> Result<String, String> {
    let rest = url
        .strip_prefix("https://")
        .or_else(|| url.strip_prefix("http://"))
        .ok_or("it must start with http:// or https://")?;
    let (host, path) = match rest.find('/') {
        Some(i) => rest.split_at(i),
        None => (rest, ""),
    };
    if !valid_host(host) {
        return Err(format!(
            "{} is not a host name or address with an optional port",
            echo(host)
        ));
    }
    let path = path.trim_end_matches('/');
    if !valid_path(path) {
        return Err(format!(
            "the path {} may hold only letters, digits and / - . _ ~ (no query or fragment)",
            echo(path)
        ));
    }
    let scheme_len = url.len() - rest.len();
    Ok(format!("{}{host}{path}", &url[..scheme_len]))
}

fn bad(header: &str, why: &str) -> ApiError {
    ApiError::bad_request("bad_header", format!("{header} {why}"))
}

/// Empty, or `/`-led letters, digits and `/-._~`.
fn valid_path(p: &str) -> bool {
    let path_char = |c: char| c.is_ascii_alphanumeric() || "/-._~".contains(c);
    // No empty segment: `//evil.example` put a double slash into every tile URL.
    p.is_empty() || p.starts_with('/') && !p.contains("//") && p.chars().all(path_char)
}

/// A host name (labels of letters, digits, `-` and `_`, as container names have) or IPv4
/// address, or a bracketed IPv6 address, then an optional `:port` of digits.
pub(crate) fn valid_host(h: &str) -> bool {
    let (name_ok, port) = if let Some(rest) = h.strip_prefix('[') {
        let Some((addr, after)) = rest.split_once(']') else {
            return false;
        };
        let ipv6 = addr.parse::<std::net::Ipv6Addr>().is_ok();
        let port = match after {
            "" => None,
            a => match a.strip_prefix(':') {
                Some(p) => Some(p),
                None => return false,
            },
        };
        (ipv6, port)
    } else {
        let (name, port) = match h.rsplit_once(':') {
            Some((n, p)) => (n, Some(p)),
            None => (h, None),
        };
        let label = |l: &str| {
            !l.is_empty()
                && l.len() <= 63
                && !l.starts_with('-')
                && !l.ends_with('-')
                && l.chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        };
        let name = name.strip_suffix('.').unwrap_or(name);
        (name.len() <= 253 && name.split('.').all(label), port)
    };
    let port_ok = port.is_none_or(|p| {
        (1..=5).contains(&p.len())
            && p.bytes().all(|b| b.is_ascii_digit())
            && p.parse::<u16>().is_ok()
    });
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

    fn trusting() -> Config {
        Config {
            trust_forwarded: true,
            ..Config::default()
        }
    }

    /// A request target as HTTP/1.1 sends it: a path, no authority.
    fn path() -> Uri {
        Uri::from_static("/v1/datasets/a/tiles.json")
    }

    #[test]
    fn host_header_over_http() {
        let c = Config::default();
        let o = origin(&c, &headers(&[("host", "127.0.0.1:8080")]), &path()).unwrap();
        assert_eq!(o, "http://127.0.0.1:8080");
        let o = origin(&c, &headers(&[("host", "[::1]:9000")]), &path()).unwrap();
        assert_eq!(o, "http://[::1]:9000");
        let o = origin(&c, &headers(&[("host", "terrain_server:8080")]), &path()).unwrap();
        assert_eq!(o, "http://terrain_server:8080");
        // HTTP/2 has no Host header: the authority.
        let h2 = Uri::from_static("http://tiles.example:81/v1/datasets/a/tiles.json");
        assert_eq!(
            origin(&c, &headers(&[]), &h2).unwrap(),
            "http://tiles.example:81"
        );
        // An absolute-form target names the host ahead of `Host`, which is then ignored
        // (RFC 9112 §3.2.2): the URLs followed the header before.
        let h = headers(&[("host", "other.example")]);
        assert_eq!(origin(&c, &h, &h2).unwrap(), "http://tiles.example:81");
    }

    #[test]
    fn forwarded_headers_count_only_when_trusted() {
        let h = headers(&[
            ("host", "10.0.0.7:8080"),
            ("x-forwarded-proto", "http, https"),
            ("x-forwarded-host", "evil.example, tiles.example.org"),
            ("x-forwarded-prefix", "/terrain/"),
        ]);
        assert_eq!(
            origin(&Config::default(), &h, &path()).unwrap(),
            "http://10.0.0.7:8080"
        );
        // The nearest proxy's values: the last ones.
        assert_eq!(
            origin(&trusting(), &h, &path()).unwrap(),
            "https://tiles.example.org/terrain"
        );
        // A configured URL wins over everything.
        let fixed = Config {
            public_url: Some("https://cdn.example/dem".into()),
            ..trusting()
        };
        assert_eq!(
            origin(&fixed, &h, &path()).unwrap(),
            "https://cdn.example/dem"
        );
        assert_eq!(vary(&fixed), None);
        assert_eq!(vary(&Config::default()), Some("Host"));
    }

    /// A proxy that adds a line of its own (rather than appending to the client's) still
    /// wins: the client's line comes first and must not be the one read.
    #[test]
    fn the_last_line_of_a_repeated_forwarded_header_is_the_proxys() {
        let h = headers(&[
            ("host", "10.0.0.7:8080"),
            ("x-forwarded-proto", "http"),
            ("x-forwarded-proto", "https"),
            ("x-forwarded-host", "evil.example"),
            ("x-forwarded-host", "a.example, tiles.example.org"),
            ("x-forwarded-prefix", "/evil"),
            ("x-forwarded-prefix", "/terrain"),
        ]);
        assert_eq!(
            origin(&trusting(), &h, &path()).unwrap(),
            "https://tiles.example.org/terrain"
        );
    }

    #[test]
    fn odd_values_are_refused_not_echoed() {
        for h in [
            headers(&[]),
            headers(&[("host", "a.example\"><script>")]),
            headers(&[("host", "a.example:99999")]),
            headers(&[("host", "a.example:+80")]),
            headers(&[("host", "a.example:")]),
            headers(&[("host", "-")]),
            headers(&[("host", "...")]),
            headers(&[("host", "[:::]")]),
            headers(&[("host", "[::1]x")]),
            headers(&[("host", "a.example"), ("x-forwarded-proto", "javascript")]),
            headers(&[("host", "a.example"), ("x-forwarded-prefix", "terrain")]),
            headers(&[("host", "a.example"), ("x-forwarded-prefix", "/a?b")]),
            headers(&[
                ("host", "a.example"),
                ("x-forwarded-prefix", "//evil.example"),
            ]),
            headers(&[("host", "a.example"), ("x-forwarded-prefix", "/a//b")]),
        ] {
            assert!(origin(&trusting(), &h, &path()).is_err(), "{h:?}");
        }
        // The refusal names the header the bad host came from.
        for (h, named) in [
            (headers(&[("host", "a b")]), "): Host must"),
            (
                headers(&[("host", "a.example"), ("x-forwarded-host", "a b")]),
                "): X-Forwarded-Host must",
            ),
        ] {
            let e = origin(&trusting(), &h, &path()).unwrap_err();
            assert!(e.to_string().contains(named), "{e}");
        }
    }

    #[test]
    fn base_urls_are_checked_and_trimmed() {
        assert_eq!(
            parse_base("https://cdn.example/dem/").unwrap(),
            "https://cdn.example/dem"
        );
        assert_eq!(
            parse_base("http://127.0.0.1:9000").unwrap(),
            "http://127.0.0.1:9000"
        );
        for bad in [
            "https://",
            "cdn.example/dem",
            "ftp://cdn.example",
            "https://cdn.example/x?token=1",
            "https://cdn.example/a b",
            "https://cdn.example/#frag",
            "https://user@cdn.example/",
        ] {
            assert!(parse_base(bad).is_err(), "{bad}");
        }
    }

    /// Host names follow DNS label rules: a label of 1–63 characters that neither starts nor
    /// ends with `-`, and 253 characters in all; a fully qualified name may end with a dot.
    #[test]
    fn host_names_follow_dns_label_rules() {
        let c = Config::default();
        let origin_of = |host: &str| origin(&c, &headers(&[("host", host)]), &path());
        let label63 = "a".repeat(63);
        assert_eq!(
            origin_of(&format!("{label63}.example")).unwrap(),
            format!("http://{label63}.example")
        );
        assert_eq!(
            origin_of("tiles.example.:8080").unwrap(),
            "http://tiles.example.:8080"
        );
        let long = ["abcdefghi"; 26].join("."); // 259 characters, every label valid
        for refused in [
            format!("{}.example", "a".repeat(64)),
            "-tiles.example".to_string(),
            "tiles-.example".to_string(),
            long,
            "a.example:65536".to_string(),
            "[not:an:address]".to_string(),
            "[::1".to_string(),
        ] {
            assert!(origin_of(&refused).is_err(), "{refused}");
        }
    }

    /// With forwarding trusted the answer follows all three forwarded headers, so a cache
    /// must key on every one of them or it serves one proxy's URLs to another's clients.
    #[test]
    fn trusted_forwarding_varies_on_every_forwarded_header() {
        assert_eq!(
            vary(&trusting()),
            Some("Host, X-Forwarded-Proto, X-Forwarded-Host, X-Forwarded-Prefix")
        );
    }
}
