//! The command line, run as a user would.

use std::process::Command;

#[test]
fn help_lists_the_commands() {
    let out = Command::new(zerotile_tests::zerotile_bin())
        .arg("--help")
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("eval"), "help did not mention eval: {text}");
}

/// `serve` options it cannot honour are refused at start with a message and exit 1.
#[test]
fn serve_refuses_what_it_cannot_honour() {
    for (args, says) in [
        (vec!["--data", "ftp://example.org/tiles"], "not supported"),
        (vec!["--data", "s3://"], "data URL"),
        (vec!["--cpu-jobs", "0"], "--cpu-jobs 0"),
    ] {
        let out = Command::new(zerotile_tests::zerotile_bin())
            .args(["serve", "--addr", "127.0.0.1:0"])
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
}
