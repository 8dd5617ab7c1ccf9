//! Curvature-error decimation: Kim, Lim & Kim, *New Discrete Curvature Error Metric for the
//! Generation of LOD Meshes* (KIISE 2000; `seeds/curvature-error-metric-lod.ko.md`).
//!
//! Every vertex gets a discrete curvature W from its area and its bending R = √(2H² − K)
//! (weighted up on features and saddles, [`measure`]). Vertices leave in order of W; each
//! hole is refilled by the ear of least connection curvature (`retriangulate`); a removal
//! is allowed only while ε, the largest change of W on its 1-ring *against the input mesh*,
//! stays under the level's bound. Levels are cut by ε (0.15, 0.20, 0.25 …), not by ratio,
//! and nest: each continues from the one before. Choices the paper leaves open are in
//! `curvature.md` beside this file.

pub(crate) mod decimate;
pub(crate) mod ladder;
pub mod measure;
pub(crate) mod refill;
pub(crate) mod retriangulate;
pub(crate) mod ring;
#[cfg(test)]
mod tests;

use std::time::Instant;

use serde::Serialize;

pub use decimate::Decimator;
pub use measure::{Measure, Weights};

use super::error::MeshError;
use super::indexed::TriMesh;
use crate::error::ParamError;

/// λ_c of eq. 10: weight of the ear's shape against its side lengths.
pub const DEFAULT_LAMBDA_C: f64 = 0.5;

/// The paper's Table 1 error bounds.
pub const PAPER_LEVELS: [f64; 3] = [0.15, 0.20, 0.25];

/// How to decimate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CurvatureOptions {
    pub weights: Weights,
    pub lambda_c: f64,
}

impl Default for CurvatureOptions {
    fn default() -> Self {
        Self {
            weights: Weights::default(),
            lambda_c: DEFAULT_LAMBDA_C,
        }
    }
}

impl CurvatureOptions {
    fn check(&self) -> Result<(), ParamError> {
        let w = &self.weights;
        let unit = "in [0, 1]";
        let positive = "finite and > 0";
        for (name, expected, v, ok) in [
            (
                "area weight λ_a",
                unit,
                w.area,
                (0.0..=1.0).contains(&w.area),
            ),
            (
                "feature weight λ_f",
                positive,
                w.feature,
                w.feature.is_finite() && w.feature > 0.0,
            ),
            (
                "saddle weight λ_s",
                positive,
                w.saddle,
                w.saddle.is_finite() && w.saddle > 0.0,
            ),
            (
                "feature angle",
                "in [0, π]",
                w.feature_angle,
                (0.0..=std::f64::consts::PI).contains(&w.feature_angle),
            ),
            (
                "λ_c",
                unit,
                self.lambda_c,
                (0.0..=1.0).contains(&self.lambda_c),
            ),
        ] {
            if !ok {
                return Err(bad(name, expected, v));
            }
        }
        Ok(())
    }
}

/// One LOD level.
#[derive(Clone, Debug)]
pub struct Level {
    /// The ε bound of the level.
    pub error: f64,
    pub mesh: TriMesh,
    /// Time to go from the previous level (or the input) to this one.
    pub ms: f64,
}

/// The nested levels cut at each ε of `errors` (ascending).
pub fn levels(
    mesh: &TriMesh,
    errors: &[f64],
    options: &CurvatureOptions,
) -> Result<Vec<Level>, MeshError> {
    options.check()?;
    mesh.check()?;
    if let Some(&e) = errors.iter().find(|e| !(e.is_finite() && **e >= 0.0)) {
        return Err(bad("ε", "finite and ≥ 0", e).into());
    }
    if let Some(w) = errors.windows(2).find(|w| w[1] < w[0]) {
        return Err(bad("ε levels", "ascending", w[1]).into());
    }
    let start = Instant::now();
    let mut d = Decimator::new(mesh, options.weights, options.lambda_c);
    let mut out = Vec::with_capacity(errors.len());
    let mut last = start.elapsed();
    for &e in errors {
        let t0 = Instant::now();
        d.run_to_error(e);
        let ms = (t0.elapsed() + std::mem::take(&mut last)).as_secs_f64() * 1e3;
        out.push(Level {
            error: e,
            mesh: d.mesh(),
            ms,
        });
    }
    Ok(out)
}

/// Decimates to at most `faces` faces, least-ε removal first; returns the mesh and the
/// largest ε used.
pub fn to_faces(
    mesh: &TriMesh,
    faces: usize,
    options: &CurvatureOptions,
) -> Result<(TriMesh, f64), MeshError> {
    options.check()?;
    mesh.check()?;
    let mut d = Decimator::new(mesh, options.weights, options.lambda_c);
    d.run_to_faces(faces);
    Ok((d.mesh(), d.worst_error()))
}

/// The ε bound [`to_error`]`(error)` decimates to: the highest rung of the ladder at or below
/// `error`, or `error` itself below the first rung (0.15). What a client is told the mesh's
/// ε is: two errors between the same rungs give one mesh, and it was cut at the rung.
pub fn bound_of(error: f64) -> f64 {
    ladder::top_rung(error).map_or(error, ladder::rung)
}

/// Decimates to ε ≤ `error`, climbing the fixed ladder of bounds to its highest rung at or
/// below `error` ([`ladder`]): a larger bound never keeps more faces, which one greedy run
/// straight to the bound does not give. From 0.15 up it continues the run [`levels`] cuts
/// the paper's levels from (`to_error(0.25)` is their third); below, one run to `error`.
pub fn to_error(
    mesh: &TriMesh,
    error: f64,
    options: &CurvatureOptions,
) -> Result<TriMesh, MeshError> {
    options.check()?;
    mesh.check()?;
    if !(error.is_finite() && error >= 0.0) {
        return Err(bad("ε", "finite and ≥ 0", error).into());
    }
    let mut d = Decimator::new(mesh, options.weights, options.lambda_c);
    d.climb_to_error(error);
    Ok(d.mesh())
}

fn bad(name: &'static str, expected: &'static str, got: f64) -> ParamError {
    ParamError::OutOfRange {
        name,
        expected,
        got: got.to_string(),
    }
}
