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
