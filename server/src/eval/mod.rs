//! `zerotile eval`: measure the codec and meshers on one input, as the benchmarks and the
//! papers' tables report them.

pub mod mesh;
#[cfg(test)]
mod mesh_tests;
pub mod terrain;
#[cfg(test)]
mod terrain_tests;

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use zerotile_codec::mesh::{io, TriMesh};

/// Writes `mesh` to `path` in the format its extension names, through
/// [`crate::ingest::write_atomically`] rather than the codec's `io::write_path`: its temporary
/// file is one the next write of `path` sweeps when a run was killed mid-write, where
/// `write_path`'s stayed for good.
pub fn write_mesh(mesh: &TriMesh, path: &Path) -> Result<()> {
    let format = io::Format::from_path(path).with_context(|| {
        format!(
            "{}: unknown extension (use .obj, .ply, .glb or .json)",
            path.display()
        )
    })?;
    let bytes =
        io::write_bytes(mesh, format).with_context(|| format!("writing {}", path.display()))?;
    crate::ingest::write_atomically(path, &bytes)
}

/// Median wall time of `repeat` runs of `f` in milliseconds, and the last result.
pub fn median_ms<T>(repeat: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut times = Vec::with_capacity(repeat.max(1));
    let mut out = None;
    for _ in 0..repeat.max(1) {
        let t = Instant::now();
        out = Some(f());
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    let median = times.get(times.len() / 2).copied().unwrap_or(f64::NAN);
    match out {
        Some(v) => (median, v),
        None => unreachable!("at least one run"),
    }
}

/// `v` for a table cell `width` wide: fixed with `decimals` places where that fits and does
/// not round a nonzero value to zero, else three significant digits in exponent form, so a
/// 1e12 threshold or a 1e-7 error keeps its column and its size.
pub fn cell(v: f64, decimals: usize, width: usize) -> String {
    let fixed = format!("{v:.decimals$}");
    let rounds_away = v != 0.0 && v.abs() < 0.5 * 10f64.powi(-(decimals as i32));
    if !v.is_finite() || (fixed.len() <= width && !rounds_away) {
        fixed
    } else {
        format!("{v:.2e}")
    }
}

/// A parameter as the user would write it (`0.5`, `16`), in exponent form when that is
/// longer than `width`.
pub fn short(v: f64, width: usize) -> String {
    let plain = v.to_string();
    if plain.len() <= width {
        plain
    } else {
        format!("{v:.2e}")
    }
}

/// `--repeat`: 1–100 timed runs, refused outside that range (clap's usage error) rather
/// than clamped, so the count run is the count asked for.
pub fn parse_repeat() -> clap::builder::RangedU64ValueParser<usize> {
    clap::builder::RangedU64ValueParser::new().range(1..=100)
}

/// Parses "a,b,c" into finite numbers ≥ 0, or > 0 unless `zero_ok`, naming the flag in the
/// error (one message for -1 and 0 where both are refused).
pub fn parse_list(flag: &str, s: &str, zero_ok: bool) -> Result<Vec<f64>, String> {
    s.split(',')
        .map(|p| {
            let v: f64 = p
                .trim()
                .parse()
                .map_err(|_| format!("{flag}: '{p}' is not a number"))?;
            if v.is_finite() && (v > 0.0 || (zero_ok && v == 0.0)) {
                Ok(v)
            } else {
                let bound = if zero_ok { "≥ 0" } else { "> 0" };
                Err(format!("{flag}: '{p}' must be finite and {bound}"))
            }
        })
        .collect()
}
