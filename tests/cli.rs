//! The command line, run as a user would.

use std::process::Command;

use zerotile_tests::server::Server;
use zerotile_tests::{fresh_dir, run_ok, shared_data, tools_ready, zerotile_bin};

#[test]
fn help_lists_the_commands() {
    let out = Command::new(zerotile_bin()).arg("--help").output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("eval"), "help did not mention eval: {text}");
}

/// `serve` options it cannot honour are refused at start with a message: exit 2 for a value
/// no machine could run (a usage error: a store URL of a scheme it has no client for, or
/// with no bucket, is one), 1 for data it cannot open.
#[test]
fn serve_refuses_what_it_cannot_honour() {
    let missing = fresh_dir("cli-serve-refuses").join("nothing-here");
    let missing = missing.to_str().unwrap();
    for (args, code, says) in [
        (
            vec!["--data", "ftp://example.org/tiles"],
            2,
            "--data ftp://example.org/tiles: scheme \"ftp\" is not supported",
        ),
        (vec!["--data", "s3://"], 2, "--data s3://: no bucket"),
        (vec!["--data", missing], 1, "nothing-here"),
        (vec!["--render-threads", "5000"], 2, "at most 1024"),
        (
            vec!["--rescan", "100000"],
            2,
            "--rescan 100000: at most 86400",
        ),
        (vec!["--cpu-jobs", "0"], 2, "--cpu-jobs 0"),
        (vec!["--cors-origin", "example.org"], 2, "--cors-origin"),
        (
            vec!["--cors-origin", "https://a.example/"],
            2,
            "--cors-origin",
        ),
        (
            vec!["--cors-origin", "https://a.example/path"],
            2,
            "--cors-origin",
        ),
        (vec!["--cors-origin", "https://"], 2, "--cors-origin"),
    ] {
        let out = Command::new(zerotile_bin())
            .args(["serve", "--addr", "127.0.0.1:0"])
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(code), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
}

/// A port in use is refused before any dataset is opened: the message names the address,
/// and no dataset was opened first (it was, every one, before the bind).
#[test]
fn serve_refuses_a_port_in_use_before_opening_datasets() {
    let data = fresh_dir("cli-serve-busy");
    run_ok(
        Command::new(zerotile_bin())
            .args(["demo-data", "--quiet", "--data"])
            .arg(&data),
    );
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap().to_string();
    let out = Command::new(zerotile_bin())
        .args(["serve", "--addr", &addr, "--data"])
        .arg(&data)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains(&format!("binding {addr}")), "{err}");
    assert!(!err.contains("opened"), "{err}");
}

/// `subdivide` makes 4× the faces a step and writes a mesh `eval mesh` reads back; a step
/// count out of range and a missing input are refused with a message.
#[test]
fn subdivide_quadruples_the_faces_and_refuses_bad_input() {
    let dir = fresh_dir("cli-subdivide");
    let out = dir.join("fandisk-x4.obj");
    let input = shared_data().join("meshes/fandisk.obj");
    let run = |args: &[&std::ffi::OsStr]| {
        Command::new(zerotile_bin())
            .arg("subdivide")
            .args(args)
            .output()
            .unwrap()
    };
    run_ok(
        Command::new(zerotile_bin())
            .arg("subdivide")
            .arg(&input)
            .arg(&out)
            .args(["--times", "1"]),
    );
    let eval = run_ok(
        Command::new(zerotile_bin())
            .args(["eval", "mesh"])
            .arg(&out)
            .args([
                "--method",
                "qem",
                "--faces",
                "1000",
                "--samples",
                "0",
                "--json",
            ]),
    );
    let point: serde_json::Value = serde_json::from_slice(&eval.stdout).unwrap();
    assert_eq!(point["faces_in"], 4 * 12_946, "{point}");

    let too_many = run(&[
        input.as_os_str(),
        out.as_os_str(),
        "--times".as_ref(),
        "9".as_ref(),
    ]);
    assert_eq!(too_many.status.code(), Some(2));
    let missing = dir.join("missing.obj");
    let gone = run(&[missing.as_os_str(), out.as_os_str()]);
    assert_eq!(gone.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&gone.stderr).contains("missing.obj"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A `--bpp` rate too small to hold the stream header is refused with the smallest usable
/// rate, which then works.
#[test]
fn eval_terrain_names_the_smallest_usable_rate() {
    let hgt = shared_data().join("dem/N44W072.hgt");
    let eval = |bpp: &str| {
        Command::new(zerotile_bin())
            .args(["eval", "terrain"])
            .arg(&hgt)
            .args(["--crop", "0,0,65", "--repeat", "1", "--json", "--bpp", bpp])
            .output()
            .unwrap()
    };
    // 0.01 bits a sample over 65² samples is 5 bytes, short of any header (0 is a usage
    // error, refused before the window is coded).
    let out = eval("0.5,0.01");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("--bpp 0.01:") && err.contains("smallest usable rate"),
        "{err}"
    );
    assert!(!err.contains("truncated"), "{err}");
    let smallest = err
        .split("for this window, ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .unwrap();
    let ok = eval(smallest);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let point: serde_json::Value = serde_json::from_slice(&ok.stdout).unwrap();
    assert_eq!(point["mode"], "bpp", "{point}");
}

/// A threshold below the 9/7 stream's floor still gives its point (the scripts read every
/// line), with a warning on stderr that the mesh is within the floor, not T.
#[test]
fn eval_terrain_warns_below_the_streams_floor() {
    let hgt = shared_data().join("dem/N44W072.hgt");
    let out = Command::new(zerotile_bin())
        .args(["eval", "terrain"])
        .arg(&hgt)
        .args(["--crop", "0,0,65", "--repeat", "1", "--json"])
        .args(["--threshold", "0.001,4"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert_eq!(err.matches("warning:").count(), 1, "{err}");
    assert!(err.contains("--threshold 0.001: below"), "{err}");
    let points: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(points.len(), 2);
    assert!(points[0]["mesh_max_abs_err"].as_f64().unwrap() > 0.001);
    assert!(
        points[0].get("below_floor").is_none(),
        "the JSON fields stay the contract's"
    );
}

/// Flags that would be ignored or that no input could make right are refused as usage errors
/// (exit 2), whichever layer catches them: --encoding and --key on inputs whose reader does
/// not use them, a size or view the mesh method does not take (checked after the parser),
/// and --repeat outside 1–100 (by the parser).
#[test]
fn flags_that_would_be_ignored_are_refused() {
    let hgt = shared_data().join("dem/N44W072.hgt");
    let tif = shared_data().join("dem/terra_elev.tif");
    let fandisk = shared_data().join("meshes/fandisk.obj");
    let hgt = hgt.to_str().unwrap();
    let tif = tif.to_str().unwrap();
    let fandisk = fandisk.to_str().unwrap();
    let cases: [(&[&str], i32, &str); 15] = [
        (
            &["ingest", hgt, "--name", "x", "--encoding", "terrarium"],
            2,
            "--encoding terrarium: applies to .png",
        ),
        (
            &["ingest", tif, "--name", "x", "--key", "x"],
            2,
            "--key x: applies to .npz",
        ),
        (
            &["eval", "terrain", hgt, "--lossless", "--encoding", "gray"],
            2,
            "--encoding gray",
        ),
        (
            &["eval", "terrain", hgt, "--lossless", "--repeat", "0"],
            2,
            "--repeat",
        ),
        // A size the method does not take, or a view for another method: refused before
        // the mesh is read (the file named here does not exist).
        (
            &[
                "eval", "mesh", "gone.obj", "--method", "qem", "--level", "2",
            ],
            2,
            "qem takes --faces N or --error E",
        ),
        (
            &[
                "eval",
                "mesh",
                "gone.obj",
                "--method",
                "curvature",
                "--level",
                "4",
            ],
            2,
            "curvature --level is 1, 2 or 3",
        ),
        (
            &[
                "eval", "mesh", "gone.obj", "--method", "qem", "--faces", "9", "--eye", "1,1,1",
                "--target", "0,0,0",
            ],
            2,
            "--eye/--target apply to --method silhouette",
        ),
        (
            &[
                "eval",
                "mesh",
                "gone.obj",
                "--method",
                "silhouette",
                "--level",
                "9",
            ],
            2,
            "silhouette --level is 0 to 7",
        ),
        (
            &[
                "eval",
                "mesh",
                "gone.obj",
                "--method",
                "silhouette",
                "--level",
                "2",
                "--eye",
                "0,0,0",
                "--target",
                "0,0,0",
            ],
            2,
            "--eye and --target must differ",
        ),
        (
            &[
                "eval", "mesh", "gone.obj", "--method", "qem", "--faces", "9", "--out", "x.stl",
            ],
            2,
            "--out x.stl: stl is read, not written",
        ),
        (
            &["subdivide", "gone.obj", "x.txt"],
            2,
            "OUTPUT x.txt: unknown mesh extension",
        ),
        (
            &[
                "eval", "mesh", fandisk, "--method", "qem", "--faces", "9", "--out", fandisk,
            ],
            2,
            "writing the result there would replace it",
        ),
        (
            &["subdivide", fandisk, fandisk],
            2,
            "writing the result there would replace it",
        ),
        (
            &[
                "eval", "mesh", fandisk, "--method", "qem", "--faces", "9", "--repeat", "0",
            ],
            2,
            "--repeat",
        ),
        (
            &[
                "eval", "mesh", fandisk, "--method", "qem", "--faces", "9", "--repeat", "101",
            ],
            2,
            "--repeat",
        ),
    ];
    let dir = fresh_dir("cli-flags");
    for (args, code, says) in cases {
        let out = Command::new(zerotile_bin())
            .args(args)
            .current_dir(&dir)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(code), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
    assert!(!dir.join("data").exists(), "a refused ingest wrote data");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Errors name what was wrong, once: the mesh file's i/o cause is not repeated, healthcheck
/// names the address it could not reach, ingest says a --data that is a file is one, and
/// --help gives subdivide's step range.
#[test]
fn messages_name_what_was_wrong_once() {
    let dir = fresh_dir("cli-msg");
    let zerotile = |args: &[&str]| {
        Command::new(zerotile_bin())
            .args(args)
            .current_dir(&dir)
            .output()
            .unwrap()
    };
    // Runs a command that must fail with `code`; its stderr.
    let refused = |args: &[&str], code: i32| {
        let out = zerotile(args);
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert_eq!(out.status.code(), Some(code), "{args:?}: {err}");
        err
    };

    let err = refused(
        &[
            "eval",
            "mesh",
            "missing.obj",
            "--method",
            "qem",
            "--faces",
            "9",
        ],
        1,
    );
    assert!(err.contains("missing.obj"), "{err}");
    assert_eq!(err.matches("(os error").count(), 1, "{err}");

    // A port nothing listens on: bound, then released.
    let addr = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .to_string();
    let err = refused(&["healthcheck", "--addr", &addr], 1);
    assert!(err.contains(&addr), "{err}");

    std::fs::write(dir.join("afile"), "x").unwrap();
    let tif = shared_data().join("dem/terra_elev.tif");
    let ingest_to = |data: &str, code: i32| {
        let args = [
            "ingest",
            tif.to_str().unwrap(),
            "--name",
            "x",
            "--data",
            data,
            "--quiet",
        ];
        refused(&args, code)
    };
    let err = ingest_to("afile", 1);
    assert!(
        err.contains("--data afile: is a file, not a folder"),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(dir.join("afile")).unwrap(), "x");
    // A store URL is for serve: ingest once wrote it as a local folder named "s3:" and
    // printed the URL, as if it had uploaded.
    let err = ingest_to("s3://tiles/prod", 2);
    assert!(err.contains("ingest writes a local folder"), "{err}");
    assert!(!dir.join("s3:").exists());
    // Metro samples are bounded (10^12 once asked for 24 TB and aborted): a usage error.
    let fandisk = shared_data().join("meshes/fandisk.obj");
    let err = refused(
        &[
            "eval",
            "mesh",
            fandisk.to_str().unwrap(),
            "--method",
            "qem",
            "--faces",
            "100",
            "--samples",
            "1000000000000",
        ],
        2,
    );
    assert!(
        err.contains("--samples") && err.contains("10000000"),
        "{err}"
    );

    let out = zerotile(&["subdivide", "--help"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("1–4"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A lossless point is exact: PSNR is infinite, `null` in JSON (which has no infinity) and
/// `inf` in the table, not the ~330 dB the f64 residue of the height products would give.
#[test]
fn lossless_psnr_is_infinite() {
    // Terrain-RGB: 0.1 m steps, which f64 cannot hold exactly.
    let png = shared_data().join("dem/fuji.png");
    let eval = |json: bool| {
        let mut cmd = Command::new(zerotile_bin());
        cmd.args(["eval", "terrain"]).arg(&png).args([
            "--encoding",
            "terrain-rgb",
            "--crop",
            "100,100,65",
            "--repeat",
            "1",
            "--lossless",
        ]);
        if json {
            cmd.arg("--json");
        }
        run_ok(&mut cmd)
    };
    let point: serde_json::Value = serde_json::from_slice(&eval(true).stdout).unwrap();
    assert!(point["psnr_db"].is_null(), "{point}");
    assert_eq!(point["rmse"], 0.0, "{point}");
    let table = String::from_utf8_lossy(&eval(false).stdout).into_owned();
    let row = table.lines().last().unwrap();
    assert!(row.split_whitespace().any(|w| w == "inf"), "{table}");
}

/// `eval terrain --out DIR` writes each point's mesh, and it is the mesh the point measured.
#[test]
fn eval_terrain_writes_the_meshes_it_measured() {
    let dir = fresh_dir("cli-meshes").join("out");
    let out = run_ok(
        Command::new(zerotile_bin())
            .args(["eval", "terrain"])
            .arg(shared_data().join("dem/N44W072.hgt"))
            .args([
                "--crop",
                "300,500,129",
                "--threshold",
                "2,16",
                "--repeat",
                "1",
            ])
            .args(["--json", "--out"])
            .arg(&dir),
    );
    let points: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(points.len(), 2);
    for (p, name) in points.iter().zip(["threshold-2.obj", "threshold-16.obj"]) {
        let mesh = zerotile_codec::mesh::io::read_path(
            &dir.join(name),
            &zerotile_codec::mesh::io::MeshLimits::default(),
        )
        .unwrap();
        assert_eq!(
            mesh.faces.len() as u64,
            p["mesh_triangles"].as_u64().unwrap()
        );
        assert_eq!(
            mesh.positions.len() as u64,
            p["mesh_vertices"].as_u64().unwrap()
        );
        // Columns and rows of the 129² window, heights in metres.
        assert!(mesh.positions.iter().all(|v| (0.0..=128.0).contains(&v.x)));
        assert!(mesh.positions.iter().all(|v| v.z > 100.0));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Float heights off the step grid cannot decode exactly: `--lossless` says what to use
/// instead rather than failing its own exactness check as an "internal error".
#[test]
fn lossless_on_float_heights_points_to_max_error() {
    let out = Command::new(zerotile_bin())
        .args(["eval", "terrain"])
        .arg(shared_data().join("dem/rio_rgbify_elev.tif"))
        .args(["--crop", "0,0,64", "--repeat", "1", "--lossless"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("not multiples of the height step 0.01"),
        "{err}"
    );
    assert!(err.contains("--max-error 0.005"), "{err}");
    assert!(!err.contains("internal error"), "{err}");
}

/// The README's first command: `serve` with no `--data` fills in what `./data` lacks (the
/// terrain dataset and the object meshes, each only when missing), says what it built, and
/// serves it.
#[test]
fn serve_without_data_fills_in_only_what_data_lacks() {
    let cwd = fresh_dir("cli-serve-default");
    let data = cwd.join("data");
    let serve = |said: Option<&str>| {
        let server = Server::start_default(&cwd);
        let log = server.log_text();
        let lines: Vec<&str> = log
            .lines()
            .filter(|l| l.contains("generated the default data"))
            .collect();
        match said {
            Some(what) => assert_eq!(
                lines,
                [format!(
                    "zerotile: generated the default data in data ({what})"
                )],
                "{log}"
            ),
            None => assert!(lines.is_empty(), "{log}"),
        }
        let datasets = server.get("/v1/datasets", &[]).json();
        let names: Vec<&str> = datasets["datasets"]
            .as_array()
            .unwrap()
            .iter()
            .map(|d| d["name"].as_str().unwrap())
            .collect();
        assert_eq!(names, ["demo-ridges"]);
        let meshes = server.get("/v1/meshes", &[]).json();
        assert_eq!(meshes["meshes"].as_array().unwrap().len(), 3, "{meshes}");
    };
    serve(Some("1 dataset, 3 meshes"));
    serve(None);
    std::fs::remove_dir_all(data.join("meshes")).unwrap();
    serve(Some("no dataset, 3 meshes"));
    std::fs::remove_file(data.join("demo-ridges.ztd")).unwrap();
    serve(Some("1 dataset, 0 meshes"));
    let _ = std::fs::remove_dir_all(&cwd);
}

/// What a progress test lacks: `script` (util-linux), which runs a command on a terminal.
fn script_missing() -> Vec<String> {
    match Command::new("script").arg("--version").output() {
        Ok(_) => Vec::new(),
        Err(_) => vec!["script (util-linux, Debian's bsdutils)".to_string()],
    }
}

/// Long commands draw a progress bar on a terminal, and `--quiet` (or `info --json`) hides
/// it. Each command runs under `script`, on a pseudo-terminal: off a terminal the bars never
/// draw, so a test without one could not tell `--quiet` from its absence.
#[test]
fn progress_bars_draw_on_a_terminal_unless_quiet() {
    if !tools_ready("the progress bar test", &script_missing()) {
        return;
    }
    let dir = fresh_dir("cli-progress");
    let bin = zerotile_bin();
    let on_terminal = |args: &str| -> String {
        let line = format!("'{}' {args} --data '{}'", bin.display(), dir.display());
        // -e: script exits with the command's status.
        let out = Command::new("script")
            .args(["-qec", &line, "/dev/null"])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        assert!(out.status.success(), "{line}: {text}");
        text
    };
    // The bar's template is "VERB {bar} POS/LEN tiles": the verb, then the bar's glyphs.
    let drew = |text: &str, verb: &str| {
        ['█', '░']
            .iter()
            .any(|g| text.contains(&format!("{verb} {g}")))
    };
    let hgt = shared_data().join("dem/N44W072.hgt");
    let tree = dir.join("tree");
    // The quiet export replaces the loud one's tree (an earlier export may be replaced).
    let cases = [
        (
            format!(
                "ingest '{}' --name n44 --scheme geodetic --max-zoom 8",
                hgt.display()
            ),
            "encoding",
        ),
        ("info n44 --verify".to_string(), "verifying"),
        (
            format!("export n44 --zoom 0-8 --out '{}'", tree.display()),
            "exporting",
        ),
        ("demo-data --force".to_string(), "encoding"),
    ];
    for (command, verb) in cases {
        let text = on_terminal(&command);
        assert!(drew(&text, verb), "{command}: no {verb} bar in {text:?}");
        let quiet = format!("{command} --quiet");
        let text = on_terminal(&quiet);
        assert!(!drew(&text, verb), "{quiet}: a {verb} bar in {text:?}");
    }
    let text = on_terminal("info n44 --verify --json");
    assert!(!drew(&text, "verifying"), "info --json: a bar in {text:?}");
    assert!(text.contains("\"tiles\""), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Output to a reader that has gone (`info --json | head -c 1`) ends the command quietly with
/// exit 0, as the standard tools do; `print!` panicked (exit 101, a backtrace).
#[test]
fn a_reader_that_goes_away_ends_the_output_quietly() {
    let data = fresh_dir("cli-closed-pipe");
    zerotile_tests::ingest_n44_geodetic(&data);
    let mut child = Command::new(zerotile_bin())
        .args(["info", "n44g", "--json", "--data"])
        .arg(&data)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Closed before the dataset is read: the first write meets EPIPE.
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(err.is_empty(), "{err}");
}

/// `info` on copies of one good dataset: under a file name serve would not take it exits 0
/// with a note (it exited 3, "a check failed"); with a bad header, unknown flags or bytes
/// appended it exits 3 naming what, and `--json` prints one object with `ok` and `error`
/// for each (a header failure printed nothing); a device is "not a regular file" (it was
/// "no such dataset file").
#[test]
fn info_tells_a_bad_copy_from_a_badly_named_one() {
    let data = fresh_dir("cli-info-copies");
    zerotile_tests::ingest_n44_geodetic(&data);
    let good = std::fs::read(data.join("n44g.ztd")).unwrap();
    let info = |file: &str, bytes: &[u8], json: bool| {
        let path = data.join(file);
        std::fs::write(&path, bytes).unwrap();
        let mut cmd = Command::new(zerotile_bin());
        cmd.arg("info").arg(&path).args(["--verify", "--quiet"]);
        if json {
            cmd.arg("--json");
        }
        let out = cmd.output().unwrap();
        let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
        (out.status.code(), text(&out.stdout), text(&out.stderr))
    };

    let (code, out, err) = info("n44.v2.ztd", &good, false);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.contains("verified: all"), "{out}");
    assert!(
        out.contains("note: serve skips this file under its name (dataset name \"n44.v2\"")
            && out.contains("e.g. as n44-v2.ztd"),
        "{out}"
    );

    let mut magic = good.clone();
    magic[0] ^= 1;
    let mut flags = good.clone();
    flags[6] = 1;
    let mut junk = good.clone();
    junk.extend_from_slice(&[0; 1000]);
    for (file, bytes, says) in [
        ("magic.ztd", &magic, "not a zerotile dataset (bad magic)"),
        ("flags.ztd", &flags, "header flags 0x0001 are not known"),
        ("junk.ztd", &junk, "1000 bytes follow the last tile record"),
    ] {
        let (code, _, err) = info(file, bytes, false);
        assert_eq!(code, Some(3), "{file}: {err}");
        assert!(err.contains(file) && err.contains(says), "{file}: {err}");
        let (code, out, err) = info(file, bytes, true);
        assert_eq!(code, Some(3), "{file}: {err}");
        let v: serde_json::Value = serde_json::from_str(&out).unwrap_or_else(|e| {
            panic!("{file}: stdout is not one JSON object ({e}): {out:?}");
        });
        assert_eq!(v["ok"], false, "{file}: {v}");
        assert!(v["error"].as_str().unwrap().contains(says), "{file}: {v}");
        assert!(v["path"].as_str().unwrap().ends_with(file), "{file}: {v}");
    }

    let out = Command::new(zerotile_bin())
        .args(["info", "/dev/null"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("/dev/null: not a regular file (a device)"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&data);
}

/// `healthcheck` against a server that takes the connection and never answers says it
/// timed out, within its 3 s: it said "Resource temporarily unavailable (os error 11)".
#[test]
fn healthcheck_says_a_silent_server_timed_out() {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    // Accepted by the kernel's backlog; never read nor answered.
    let t = std::time::Instant::now();
    let out = Command::new(zerotile_bin())
        .args(["healthcheck", "--addr", &addr])
        .output()
        .unwrap();
    let elapsed = t.elapsed();
    drop(listener);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(
        err.trim(),
        format!("zerotile: no answer from {addr} within 3 s")
    );
    assert!(elapsed < std::time::Duration::from_secs(5), "{elapsed:?}");
}
