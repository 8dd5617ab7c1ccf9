//! The command line's own decisions, made on parsed flags (`Cli::try_parse_from`, as the
//! binary parses them): what each command refuses before doing any work, what its
//! defaults are, and the lines it prints when done.

use std::io::{Read, Write};
use std::net::TcpListener;
use std::path::{Path, PathBuf};

use clap::Parser;

use super::*;
use crate::eval::terrain::Sweep;

fn parse(args: &[&str]) -> Command {
    Cli::try_parse_from(std::iter::once("zerotile").chain(args.iter().copied()))
        .unwrap()
        .command
}

fn serve_args(args: &[&str]) -> ServeArgs {
    let mut all = vec!["serve"];
    all.extend_from_slice(args);
    let Command::Serve(a) = parse(&all) else {
        panic!("not serve: {args:?}")
    };
    a
}

fn terrain_args(args: &[&str]) -> TerrainArgs {
    let mut all = vec!["eval", "terrain", "in.hgt"];
    all.extend_from_slice(args);
    let Command::Eval(EvalCommand::Terrain(a)) = parse(&all) else {
        panic!("not eval terrain: {args:?}")
    };
    a
}

fn refusal<T: std::fmt::Debug>(r: anyhow::Result<T>) -> String {
    format!("{:#}", r.expect_err("should be refused"))
}

#[test]
fn serve_defaults_and_sizes_come_through_as_given() {
    let defaults = crate::serve::Config::default();
    let c = serve_config(&serve_args(&[])).unwrap();
    assert_eq!(c.cache_bytes, 256 << 20);
    assert_eq!(
        (c.cpu_jobs, c.cpu_queue, c.render_threads),
        (
            defaults.cpu_jobs,
            defaults.cpu_queue,
            defaults.render_threads
        )
    );
    assert_eq!(c.png_compression, defaults.png_compression);
    assert_eq!(defaults.png_compression, PngCompression::Fast);
    assert!(c.cors_origins.is_empty() && c.public_url.is_none() && !c.trust_forwarded);

    let c = serve_config(&serve_args(&[
        "--cache-mb",
        "3",
        "--cpu-jobs",
        "5",
        "--cpu-queue",
        "7",
        "--render-threads",
        "3",
        "--png-compression",
        "best",
        "--trust-forwarded",
        "--cors-origin",
        "https://maps.example.org",
        "--cors-origin",
        "http://localhost:8080",
        "--public-url",
        "https://tiles.example.org/terrain",
    ]))
    .unwrap();
    assert_eq!(
        (c.cache_bytes, c.cpu_jobs, c.cpu_queue, c.render_threads),
        (3 << 20, 5, 7, 3)
    );
    assert_eq!(c.png_compression, PngCompression::Best);
    assert!(c.trust_forwarded && c.public_url.is_some());
    assert_eq!(
        c.cors_origins,
        ["https://maps.example.org", "http://localhost:8080"]
    );
    // A size past u64 saturates instead of wrapping to a tiny cache.
    let huge = u64::MAX.to_string();
    let c = serve_config(&serve_args(&["--cache-mb", &huge])).unwrap();
    assert_eq!(c.cache_bytes, u64::MAX);
}

/// `--addr` takes a host name as well as an IP address; `--fill` a height below sea level
/// written as a plain negative number.
#[test]
fn addresses_may_be_names_and_fill_heights_negative() {
    let a = serve_args(&["--addr", "localhost:0"]);
    // IPv4 first, so the server answers at 127.0.0.1 whatever order the resolver gives.
    assert!(
        a.addr.is_ipv4() && a.addr.ip().is_loopback() && a.addr.port() == 0,
        "{}",
        a.addr
    );
    assert_eq!(serve_args(&["--addr", "[::1]:8081"]).addr.port(), 8081);
    for bad in ["localhost", "127.0.0.1:99999"] {
        let e = Cli::try_parse_from(["zerotile", "serve", "--addr", bad]).unwrap_err();
        assert!(e.to_string().contains("--addr"), "{bad}: {e}");
    }
    // healthcheck's address is checked in form by the parser (exit 2) and resolved when the
    // check runs: a name that does not resolve yet is an unhealthy server (exit 1).
    for good in [
        "localhost:8080",
        "127.0.0.1:1",
        "[::1]:8081",
        "tiles-1.internal:80",
    ] {
        let Command::Healthcheck(h) = parse(&["healthcheck", "--addr", good]) else {
            panic!("not healthcheck")
        };
        assert_eq!(h.addr, good);
    }
    for bad in [
        "bogus",
        "127.0.0.1:99999",
        "127.0.0.1:0",
        ":8080",
        "127.0.0.1:",
        "a b:80",
        "::1:80",
    ] {
        let e = Cli::try_parse_from(["zerotile", "healthcheck", "--addr", bad]).unwrap_err();
        assert_eq!(e.exit_code(), 2, "{bad}: {e}");
        assert!(e.to_string().contains("--addr"), "{bad}: {e}");
    }
    let Command::Ingest(a) = parse(&["ingest", "in.hgt", "--name", "n", "--fill", "-5"]) else {
        panic!("not ingest")
    };
    assert_eq!(a.fill, Some(-5.0));
}

/// `--vertical-datum` names a datum the server models; another is a usage error naming the
/// two, and without the flag the source's own stands.
#[test]
fn ingest_takes_the_vertical_datums_it_models() {
    for (given, want) in [
        ("egm96", VerticalDatum::Egm96),
        ("EGM96", VerticalDatum::Egm96),
        ("ellipsoid", VerticalDatum::Ellipsoid),
    ] {
        let args = ["ingest", "in.tif", "--name", "n", "--vertical-datum", given];
        let Command::Ingest(a) = parse(&args) else {
            panic!("not ingest")
        };
        assert_eq!(a.vertical_datum, Some(want), "{given}");
    }
    let Command::Ingest(a) = parse(&["ingest", "in.hgt", "--name", "n"]) else {
        panic!("not ingest")
    };
    assert_eq!(a.vertical_datum, None);
    let e = Cli::try_parse_from([
        "zerotile",
        "ingest",
        "in.tif",
        "--name",
        "n",
        "--vertical-datum",
        "navd88",
    ])
    .unwrap_err();
    assert_eq!(e.exit_code(), 2);
    let said = e.to_string();
    assert!(
        said.contains("--vertical-datum") && said.contains("egm96") && said.contains("ellipsoid"),
        "{said}"
    );
}

#[test]
fn serve_refuses_origins_and_urls_it_could_not_honour() {
    for origin in [
        "maps.example.org",
        "https://maps.example.org/",
        "ftp://maps.example.org",
        "https://maps example.org",
        "https://maps.example.org\u{e9}",
        // A path or query no browser's Origin carries, and no host at all.
        "https://maps.example.org/tiles",
        "https://maps.example.org?x=1",
        "https://",
    ] {
        let msg = refusal(serve_config(&serve_args(&["--cors-origin", origin])));
        assert!(
            msg.contains(&format!("--cors-origin {origin:?}")),
            "{origin}: {msg}"
        );
    }
    let msg = refusal(serve_config(&serve_args(&["--cpu-jobs", "0"])));
    assert!(msg.contains("--cpu-jobs 0"), "{msg}");
    let msg = refusal(serve_config(&serve_args(&["--render-threads", "0"])));
    assert!(msg.contains("--render-threads 0"), "{msg}");
    // Each thread is spawned at start: a huge pool never came up, with no word said.
    let most = MAX_RENDER_THREADS.to_string();
    assert_eq!(
        serve_config(&serve_args(&["--render-threads", &most]))
            .unwrap()
            .render_threads,
        MAX_RENDER_THREADS
    );
    let e = serve_config(&serve_args(&["--render-threads", "1025"])).unwrap_err();
    assert!(crate::usage::is_usage(&e), "{e:#}");
    assert!(e
        .to_string()
        .starts_with("--render-threads 1025: at most 1024"));
    // A day at most; 0 (SIGHUP only) and a day itself are taken.
    for ok in ["0", "86400"] {
        assert!(serve_config(&serve_args(&["--rescan", ok])).is_ok(), "{ok}");
    }
    let e = serve_config(&serve_args(&["--rescan", "86401"])).unwrap_err();
    assert!(crate::usage::is_usage(&e), "{e:#}");
    assert!(
        e.to_string()
            .starts_with("--rescan 86401: at most 86400 seconds"),
        "{e}"
    );
    // A store URL no store could answer is the command line's error, found before binding.
    for (data, says) in [
        (
            "ftp://x/y",
            "--data ftp://x/y: scheme \"ftp\" is not supported",
        ),
        ("s3://", "--data s3://: no bucket"),
    ] {
        let e = serve_config(&serve_args(&["--data", data])).unwrap_err();
        assert!(crate::usage::is_usage(&e), "{data}: {e:#}");
        assert!(e.to_string().starts_with(says), "{data}: {e:#}");
    }
    assert!(serve_config(&serve_args(&["--data", "s3://tiles/prod"])).is_ok());
    let msg = refusal(serve_config(&serve_args(&[
        "--public-url",
        "tiles.example.org",
    ])));
    assert!(msg.contains("--public-url \"tiles.example.org\""), "{msg}");
}

#[test]
fn eval_terrain_takes_each_sweep_with_its_defaults() {
    let e = terrain_eval(terrain_args(&["--lossless"])).unwrap();
    assert_eq!(e.sweep, Sweep::Lossless);
    assert_eq!((e.decode_share, e.repeat, e.step), (None, 3, None));
    for (flag, want) in [
        ("--threshold", Sweep::Threshold(vec![1.0, 2.5])),
        ("--bpp", Sweep::Bpp(vec![1.0, 2.5])),
        ("--max-error", Sweep::MaxError(vec![1.0, 2.5])),
    ] {
        let e = terrain_eval(terrain_args(&[flag, "1, 2.5"])).unwrap();
        assert_eq!(e.sweep, want, "{flag}");
    }
    let e = terrain_eval(terrain_args(&[
        "--threshold",
        "4",
        "--step",
        "0.5",
        "--decode-share",
        "0.25",
        "--crop",
        "1,2,65",
    ]))
    .unwrap();
    assert_eq!(
        (e.step, e.decode_share, e.crop),
        (Some(0.5), Some(0.25), Some((1, 2, 65)))
    );
}

#[test]
fn eval_terrain_refuses_values_no_run_could_use() {
    // Flags as typed, split at spaces.
    for (args, want) in [
        (
            "--max-error 0",
            "--max-error: '0' must be finite and > 0 (use --lossless",
        ),
        ("--max-error 2,0", "--max-error: '0' must be finite and > 0"),
        // Said the same way: it was "≥ 0" for -1, then "> 0" for the 0 it suggested.
        (
            "--max-error=-1",
            "--max-error: '-1' must be finite and > 0 (use --lossless",
        ),
        ("--threshold 1,x", "--threshold: 'x' is not a number"),
        ("--bpp=0.5,-1", "--bpp: '-1' must be finite"),
        ("--lossless --step 0", "--step must be finite and > 0"),
        ("--lossless --step=-1", "--step must be finite and > 0"),
        ("--lossless --step inf", "--step must be finite and > 0"),
        (
            "--lossless --decode-share 0",
            "--decode-share must be in (0, 1)",
        ),
        (
            "--lossless --decode-share 1",
            "--decode-share must be in (0, 1)",
        ),
        (
            "--lossless --decode-share NaN",
            "--decode-share must be in (0, 1)",
        ),
        (
            "--lossless --encoding gray",
            "--encoding gray: applies to .png",
        ),
        ("--lossless --key dem", "--key dem: applies to .npz"),
        // Taken and ignored before: the run looked like a measured share.
        (
            "--lossless --decode-share 0.5",
            "--decode-share applies to --threshold",
        ),
        (
            "--bpp 1 --decode-share 0.5",
            "--decode-share applies to --threshold",
        ),
        (
            "--max-error 2 --decode-share 0.5",
            "--decode-share applies to --threshold",
        ),
        (
            "--threshold 4 --mesher zerotree --decode-share 0.5",
            "--decode-share applies to the bintree mesher",
        ),
        // The crop's side is on the command line: a usage error, not a failed run.
        (
            "--threshold 4 --crop 300,500,64 --mesher bintree",
            "--crop …,64: the bintree mesher (--mesher bintree) needs a side of 2^k + 1",
        ),
        (
            "--threshold 4 --crop 300,500,4099 --mesher bintree",
            "--crop …,4099: the bintree mesher",
        ),
        (
            "--threshold 4 --crop 300,500,256 --decode-share 0.5",
            "--crop …,256: the bintree mesher (which --decode-share measures)",
        ),
    ] {
        let argv: Vec<&str> = args.split(' ').collect();
        let msg = refusal(terrain_eval(terrain_args(&argv)));
        assert!(msg.contains(want), "{args}: {msg}");
    }
    // No stream fits in 0 bits (each has a header): a usage error naming the flag. It was
    // taken here and refused only once the window was coded, with exit 1.
    let e = terrain_eval(terrain_args(&["--bpp", "0.5,0"])).unwrap_err();
    assert!(crate::usage::is_usage(&e), "{e:#}");
    assert_eq!(e.to_string(), "--bpp: '0' must be finite and > 0");
}

#[test]
fn reader_flags_apply_to_their_own_formats_whatever_the_case() {
    let png = Path::new("fuji.PNG");
    assert!(check_reader_flags(png, Some(Encoding::TerrainRgb), None).is_ok());
    assert!(check_reader_flags(Path::new("j.npz"), None, Some("dem")).is_ok());
    assert!(check_reader_flags(Path::new("x.hgt"), None, None).is_ok());
    assert!(check_reader_flags(png, None, Some("dem")).is_err());
    assert!(check_reader_flags(Path::new("j.npz"), Some(Encoding::Gray), None).is_err());
}

#[test]
fn export_notes_say_what_was_not_written() {
    let job = |format: &str, zooms| crate::export::Export {
        dataset: "n44".into(),
        data: PathBuf::from("data"),
        format: format.into(),
        out: PathBuf::from("out/tree"),
        zooms,
        base_url: None,
        png_compression: PngCompression::Balanced,
        progress: false,
    };
    let done = |no_tilejson| crate::export::Exported {
        tiles: 1,
        bytes: 1,
        no_tilejson,
        clamped: None,
    };
    assert!(export_notes(&job("terrain", None), &done(false)).is_empty());
    assert!(export_notes(&job("terrain", Some((0, 4))), &done(false)).is_empty());
    assert!(export_notes(&job("png", Some((2, 4))), &done(false)).is_empty());
    let notes = export_notes(&job("terrain", Some((2, 4))), &done(false));
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].starts_with("out/tree has no zooms below 2"),
        "{notes:?}"
    );
    let notes = export_notes(&job("png", None), &done(true));
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(notes[0].starts_with("no tiles.json written"), "{notes:?}");
    let clamped = crate::export::Exported {
        clamped: Some([-10_935.0, 8_848.0]),
        ..done(false)
    };
    let notes = export_notes(&job("png", None), &clamped);
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].starts_with("heights -10935 … 8848 m pass what terrain-RGB codes"),
        "{notes:?}"
    );
}

/// `--png-compression` on a tree without PNG is said to do nothing; left out, or on png, not.
#[test]
fn png_compression_on_another_format_is_noted() {
    let best = Some(PngCompression::Best);
    assert_eq!(unused_png_compression("png", best), None);
    assert_eq!(unused_png_compression("terrain", None), None);
    assert_eq!(
        unused_png_compression("terrain", best).as_deref(),
        Some("--png-compression applies to --format png; a terrain export has no PNG tiles")
    );
}

#[test]
fn done_lines_say_what_was_built() {
    let data = Path::new("data");
    let built = |terrain, meshes| crate::demo::Built { terrain, meshes };
    assert_eq!(
        demo_summary(data, &built(false, 0)),
        "data: already has datasets and meshes"
    );
    assert_eq!(
        demo_summary(data, &built(true, 3)),
        format!(
            "data: built dataset {}, 3 meshes",
            crate::demo::TERRAIN_NAME
        )
    );
    assert_eq!(demo_summary(data, &built(false, 2)), "data: built 2 meshes");

    // One root tile and a 2 × 3 block: 7 tiles; 8 bits a byte over the samples coded.
    let mut m = crate::fixtures::local_257(66_049);
    m.max_zoom = 1;
    m.available
        .push(vec![zerotile_codec::container::Availability {
            start_x: 0,
            start_y: 1,
            end_x: 1,
            end_y: 3,
        }]);
    assert_eq!(
        ingest_summary(Path::new("data/t.ztd"), &m, 2.46, false),
        "data/t.ztd: 7 tiles, zooms 0..=1, 66049 stream bytes (8.000 bits/sample), 2.5 s"
    );
    assert!(
        ingest_summary(Path::new("data/t.ztd"), &m, 2.46, true).ends_with(
            "2.5 s (replaced the dataset of that name; a running server serves it at its next \
             rescan, 5 s by default, or on SIGHUP)"
        )
    );
}

/// A one-connection server answering `reply` to whatever it is asked; its address.
fn answering(reply: &'static [u8]) -> String {
    serving(reply, None)
}

/// [`answering`], or with `drip`, sending `reply` a byte every `drip` and holding the
/// connection open after.
fn serving(reply: &'static [u8], drip: Option<std::time::Duration>) -> String {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    std::thread::spawn(move || {
        let Ok((mut s, _)) = listener.accept() else {
            return;
        };
        let mut ask = [0u8; 256];
        let _ = s.read(&mut ask);
        let Some(gap) = drip else {
            let _ = s.write_all(reply);
            return;
        };
        for b in reply {
            std::thread::sleep(gap);
            if s.write_all(&[*b]).is_err() {
                return;
            }
        }
        std::thread::sleep(std::time::Duration::from_secs(5));
    });
    addr
}

#[test]
fn healthcheck_passes_on_200_only_and_names_the_address() {
    assert!(healthcheck(&answering(
        b"HTTP/1.1 200 OK\r\ncontent-length: 2\r\n\r\nok"
    ))
    .is_ok());
    let addr = answering(b"HTTP/1.1 503 Service Unavailable\r\n\r\n");
    let msg = refusal(healthcheck(&addr));
    assert!(
        msg.contains(&format!("{addr}: /healthz answered HTTP/1.1 503")),
        "{msg}"
    );
    let addr = answering(b"HTTP/1.1");
    let msg = refusal(healthcheck(&addr));
    assert!(msg.contains(&format!("reading {addr}'s answer")), "{msg}");
    // A port nothing listens on (bound, then released).
    let closed = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .to_string();
    let msg = refusal(healthcheck(&closed));
    assert!(msg.contains(&format!("connecting to {closed}")), "{msg}");
    let msg = refusal(healthcheck("no-port"));
    assert!(msg.contains("--addr no-port"), "{msg}");
}

/// A server that takes the connection and then says nothing, or drips its status line a
/// byte at a time, fails the check at its one deadline, saying it timed out: before, each
/// read had the whole 3 s (a drip of a byte every 2 s passed after 22 s) and a silent
/// server failed with "Resource temporarily unavailable (os error 11)".
#[test]
fn healthcheck_fails_a_silent_or_dripping_server_at_its_deadline() {
    use std::time::{Duration, Instant};
    let limit = Duration::from_millis(600);
    let silent = serving(b"", Some(Duration::ZERO));
    let t = Instant::now();
    let msg = refusal(check_health(&silent, limit));
    assert_eq!(msg, format!("no answer from {silent} within 0.6 s"));
    assert!(
        t.elapsed() < Duration::from_millis(1500),
        "{:?}",
        t.elapsed()
    );
    // Every byte well within a read timeout of the whole limit; the line not within it.
    let slow = serving(b"HTTP/1.1 200 OK\r\n\r\n", Some(Duration::from_millis(100)));
    let t = Instant::now();
    let msg = refusal(check_health(&slow, limit));
    assert_eq!(
        msg,
        format!("no whole status line from {slow} within 0.6 s")
    );
    assert!(
        t.elapsed() < Duration::from_millis(1500),
        "{:?}",
        t.elapsed()
    );
    // The same line at once passes.
    let quick = serving(b"HTTP/1.1 200 OK\r\n\r\n", Some(Duration::ZERO));
    assert!(check_health(&quick, limit).is_ok());
}

/// A negative number is a value, refused by its option's own check, not an unknown flag
/// with clap's tip to write `-- -1` (which would make it a positional argument).
#[test]
fn negative_numbers_are_values_refused_by_their_range() {
    use clap::error::ErrorKind;
    for args in [
        &["serve", "--cache-mb", "-1"][..],
        &["ingest", "in.hgt", "--name", "x", "--max-zoom", "-1"],
        &["subdivide", "a.obj", "b.obj", "--times", "-1"],
        &["eval", "mesh", "a.obj", "--method", "qem", "--faces", "-1"],
    ] {
        let kind = Cli::try_parse_from(std::iter::once("zerotile").chain(args.iter().copied()))
            .map(|_| ())
            .unwrap_err()
            .kind();
        assert!(
            matches!(kind, ErrorKind::ValueValidation | ErrorKind::InvalidValue),
            "{args:?}: {kind:?}"
        );
    }
    // Parsed, then refused by the command's own check before any work.
    let Command::Eval(EvalCommand::Terrain(t)) = parse(&[
        "eval",
        "terrain",
        "in.hgt",
        "--threshold",
        "4",
        "--step",
        "-1",
    ]) else {
        panic!("not eval terrain")
    };
    assert_eq!(t.step, Some(-1.0));
}

/// `info` and `export` take a dataset path that is not UTF-8 (a Latin-1 file name), as
/// `ingest` takes its input: clap refused it as invalid UTF-8, a usage error (exit 2).
#[test]
fn a_dataset_path_need_not_be_utf8() {
    use std::ffi::{OsStr, OsString};
    use std::os::unix::ffi::OsStrExt;
    let latin1 = OsStr::from_bytes(b"./caf\xe9.ztd");
    for args in [&["info"][..], &["export", "--out", "tree"]] {
        let argv = ["zerotile"]
            .iter()
            .chain(args)
            .map(OsString::from)
            .chain([latin1.to_owned()]);
        let dataset = match Cli::try_parse_from(argv).map(|c| c.command) {
            Ok(Command::Info(a)) => a.dataset,
            Ok(Command::Export(a)) => a.dataset,
            other => panic!("{args:?}: {other:?}"),
        };
        assert_eq!(dataset, latin1, "{args:?}");
    }
}
