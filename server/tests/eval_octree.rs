//! `zerotile eval mesh --method octree` run as the benchmark script runs it.
#![allow(
    clippy::expect_used,
    reason = "test helpers: a binary that does not run or print JSON fails the test"
)]

use std::path::PathBuf;
use std::process::Command;

fn fandisk() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/meshes/fandisk.obj")
}

fn eval(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_zerotile"))
        .args(["eval", "mesh"])
        .arg(fandisk())
        .args(["--method", "octree", "--json", "--repeat", "1"])
        .args(args)
        .output()
        .expect("zerotile runs")
}

fn json(out: &std::process::Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

#[test]
fn a_face_budget_picks_the_deepest_level_within_it() {
    let p = json(&eval(&["--faces", "9000", "--samples", "0"]));
    let faces = p["faces"].as_u64().expect("faces");
    assert!(faces > 0 && faces <= 9000, "{p}");
    assert_eq!(p["method"], "octree");
    assert_eq!(p["faces_in"], 12946);
    // The next level is over the budget, or this is the deepest.
    let level = p["detail"]["level"].as_u64().expect("level");
    let levels = p["detail"]["levels"].as_array().expect("levels");
    if let Some(next) = levels.get(level as usize + 1) {
        assert!(next["faces"].as_u64().expect("faces") > 9000, "{p}");
    }
    assert!(p["detail"]["boxes"].as_u64() < p["detail"]["plain_boxes"].as_u64());
}

#[test]
fn a_level_is_measured_against_the_input() {
    let p = json(&eval(&["--level", "3", "--samples", "20000"]));
    assert_eq!(p["param"]["level"], 3);
    let h = p["hausdorff_pct"].as_f64().expect("measured");
    assert!(h > 0.0 && h < 100.0, "{p}");
}

#[test]
fn an_error_bound_or_a_missing_level_is_refused() {
    assert!(!eval(&["--error", "0.1"]).status.success());
    assert!(!eval(&["--level", "99", "--samples", "0"]).status.success());
}

/// The coarsest non-empty level answers a smaller budget, with a note on stderr so that
/// --faces does not look ignored.
#[test]
fn a_budget_below_every_level_gets_the_coarsest_non_empty_level() {
    let out = eval(&["--faces", "100", "--samples", "0"]);
    let p = json(&out);
    let levels = p["detail"]["levels"].as_array().expect("levels");
    let coarsest = levels
        .iter()
        .find(|l| l["faces"].as_u64() > Some(0))
        .expect("a non-empty level");
    assert_eq!(p["faces"], coarsest["faces"], "{p}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!(
            "--faces 100: the coarsest octree level with faces has {} on this mesh",
            coarsest["faces"]
        )),
        "{err}"
    );
    // Within the budget there is no note.
    let out = eval(&["--faces", "9000", "--samples", "0"]);
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
