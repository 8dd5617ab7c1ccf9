//! `eval mesh`'s points checked against what they claim, on the classic meshes in
//! `../shared/data/meshes` (read in place): object_mesh.py and the README tables take the
//! counts, the chosen level and the distances as given.

use std::path::PathBuf;

use zerotile_codec::mesh::curvature::PAPER_LEVELS;
use zerotile_codec::mesh::io::{self, MeshLimits};
use zerotile_codec::mesh::silhouette::ViewSphere;
use zerotile_codec::mesh::{OctreeLod, OctreeOptions};

use super::mesh::{
    budget_note, evaluate, load, measure, subdivide, subdivided_faces, table, MeshArgs, MeshPoint,
    Method, Param,
};
use crate::cli::SubdivideArgs;
use crate::fixtures::scratch;

fn shared_mesh(name: &str) -> PathBuf {
    crate::fixtures::shared_data(&format!("meshes/{name}"))
}

/// One run on `name` with `method` and no amount: each test sets the one it needs. Few
/// Metro samples: the tests check what the distances are, not their precision.
fn args(name: &str, method: Method) -> MeshArgs {
    MeshArgs {
        input: shared_mesh(name),
        method,
        error: None,
        level: None,
        faces: None,
        out: None,
        json: true,
        repeat: 1,
        samples: 2_000,
        weld: false,
        eye: None,
        target: None,
    }
}

fn faces(name: &str, method: Method, n: usize) -> MeshArgs {
    MeshArgs {
        faces: Some(n),
        ..args(name, method)
    }
}

fn level(name: &str, method: Method, k: u32) -> MeshArgs {
    MeshArgs {
        level: Some(k),
        ..args(name, method)
    }
}

fn error_of(a: &MeshArgs) -> String {
    format!("{:#}", evaluate(a).expect_err("should be refused"))
}

/// The input as `eval mesh` measures it: read and repaired.
fn repaired(name: &str) -> zerotile_codec::mesh::TriMesh {
    load(&shared_mesh(name), false).unwrap()
}

#[test]
fn exactly_one_finite_amount_is_taken() {
    let base = args("npm-bunny.obj", Method::Qem);
    for (error, level, faces, want) in [
        (None, None, None, "exactly one of"),
        (Some(0.01), None, Some(100), "exactly one of"),
        (None, Some(2), Some(100), "exactly one of"),
        (Some(f64::NAN), None, None, "finite and ≥ 0"),
        (Some(-0.1), None, None, "finite and ≥ 0"),
        (Some(f64::INFINITY), None, None, "finite and ≥ 0"),
        (None, None, Some(0), "--faces must be > 0"),
    ] {
        let a = MeshArgs {
            error,
            level,
            faces,
            ..base.clone()
        };
        let msg = error_of(&a);
        assert!(msg.contains(want), "{error:?} {level:?} {faces:?}: {msg}");
    }
}

#[test]
fn each_method_refuses_the_amounts_it_has_no_meaning_for() {
    let with_error = |method| MeshArgs {
        error: Some(0.01),
        ..args("npm-bunny.obj", method)
    };
    for (a, want) in [
        (
            level("npm-bunny.obj", Method::Qem, 1),
            "qem takes --faces N or --error E",
        ),
        (
            with_error(Method::Octree),
            "octree takes --level K or --faces N",
        ),
        (
            with_error(Method::Silhouette),
            "silhouette takes --level K or --faces N",
        ),
        (
            level("npm-bunny.obj", Method::Curvature, 0),
            "curvature --level is 1, 2 or 3",
        ),
        (
            level("npm-bunny.obj", Method::Curvature, 4),
            "curvature --level is 1, 2 or 3",
        ),
    ] {
        let msg = error_of(&a);
        assert!(msg.contains(want), "{:?} {:?}: {msg}", a.method, a.level);
    }
}

#[test]
fn eye_and_target_are_three_finite_numbers_and_only_for_silhouette() {
    let view = |method, eye: &str, target: &str| MeshArgs {
        eye: Some(eye.into()),
        target: Some(target.into()),
        ..level("npm-bunny.obj", method, 2)
    };
    assert!(
        error_of(&view(Method::Octree, "0,0,5", "0,0,0")).contains("apply to --method silhouette")
    );
    for (eye, want) in [
        ("1,2", "three finite numbers"),
        ("1,2,3,4", "three finite numbers"),
        ("1,inf,3", "three finite numbers"),
        ("a,b,c", "must be x,y,z numbers"),
    ] {
        let msg = error_of(&view(Method::Silhouette, eye, "0,0,0"));
        assert!(msg.contains("--eye") && msg.contains(want), "{eye}: {msg}");
    }
    let msg = error_of(&view(Method::Silhouette, "0,0,5", "0;0;0"));
    assert!(msg.contains("--target"), "{msg}");
    // Spaces around the numbers are fine, and a view answers with what it drew.
    let p = evaluate(&view(Method::Silhouette, " 0, 0.2 ,5", "0,0,0")).unwrap();
    let count = |kind: &str| p.detail[kind].as_u64().unwrap() as usize;
    assert_eq!(p.detail["level"], 2, "{p:?}");
    assert!(
        count("facing_faces") > 0 && count("silhouette_faces") > 0,
        "{p:?}"
    );
    let kinds = count("facing_faces") + count("silhouette_faces") + count("other_faces");
    assert!(kinds <= p.faces_in && p.faces > 0, "{p:?}");
}

/// Counts of the repaired input, distances that are distances (mean ≤ Hausdorff, both
/// above zero for a simplified mesh), and none at all with `--samples 0`.
#[test]
fn a_point_reports_the_input_the_output_and_their_distance() {
    let input = repaired("npm-bunny.obj");
    let a = faces("npm-bunny.obj", Method::Qem, 1_000);
    let p = evaluate(&a).unwrap();
    assert_eq!(
        (p.vertices_in, p.faces_in),
        (input.vertex_count(), input.face_count())
    );
    assert_eq!(p.param, Param::Faces(1_000));
    assert!((990..=1_000).contains(&p.faces), "{p:?}");
    assert!(p.vertices < p.vertices_in && p.ms > 0.0, "{p:?}");
    let (h, m) = (p.hausdorff_pct.unwrap(), p.mean_pct.unwrap());
    assert!(0.0 < m && m <= h && h < 5.0, "{p:?}");
    assert_eq!(p.detail["faces_out"], p.faces, "{p:?}");
    let p = evaluate(&MeshArgs { samples: 0, ..a }).unwrap();
    assert!(p.hausdorff_pct.is_none() && p.mean_pct.is_none(), "{p:?}");
}

/// An error bound in place of a face count: a smaller bound keeps more faces.
#[test]
fn qem_to_an_error_bound_keeps_more_faces_for_a_tighter_bound() {
    let at = |e| {
        evaluate(&MeshArgs {
            error: Some(e),
            ..args("npm-bunny.obj", Method::Qem)
        })
        .unwrap()
    };
    let (tight, loose) = (at(0.002), at(0.01));
    assert_eq!(tight.param, Param::Error(0.002));
    assert!(
        loose.faces < tight.faces && tight.faces < tight.faces_in,
        "{loose:?} {tight:?}"
    );
    let max = |p: &MeshPoint| p.detail["max_error"].as_f64().unwrap();
    assert!(
        max(&tight) <= 0.002 && max(&loose) <= 0.01,
        "{tight:?} {loose:?}"
    );
}

/// Levels 1–3 are one continuing decimation cut at the paper's ε: each level is coarser,
/// reports its ε, and times every step up to it.
#[test]
fn curvature_levels_are_nested_cuts_at_the_papers_epsilon() {
    let mut before = usize::MAX;
    for k in 1..=3 {
        let p = evaluate(&level("npm-bunny.obj", Method::Curvature, k)).unwrap();
        assert!(p.faces < before && p.faces < p.faces_in, "level {k}: {p:?}");
        before = p.faces;
        assert_eq!(p.detail["epsilon"], PAPER_LEVELS[k as usize - 1], "{p:?}");
        assert_eq!(
            p.detail["steps_ms"].as_array().unwrap().len(),
            k as usize,
            "{p:?}"
        );
    }
    let p = evaluate(&faces("npm-bunny.obj", Method::Curvature, 2_000)).unwrap();
    assert!(
        p.faces <= 2_000 && p.detail["steps_ms"] == serde_json::json!([]),
        "{p:?}"
    );
    assert_eq!(budget_note(&p), None);
    // A budget past what the decimation can reach is answered with what it reaches, and
    // said (it was silent: the 10 faces asked looked ignored).
    let p = evaluate(&faces("cow.obj", Method::Curvature, 10)).unwrap();
    let note = budget_note(&p).unwrap_or_default();
    let want = format!(
        "--faces 10: curvature decimation stops at {} faces on this mesh",
        p.faces
    );
    assert!(p.faces > 10 && note.starts_with(&want), "{note:?}: {p:?}");
    // A budget at or past the input's faces asks for nothing, and says so.
    for method in [Method::Qem, Method::Curvature] {
        for budget in [p.faces_in, 99_999_999] {
            let q = evaluate(&faces("cow.obj", method, budget)).unwrap();
            assert_eq!(q.faces, q.faces_in, "{method:?} {budget}: {q:?}");
            assert_eq!(
                budget_note(&q).as_deref(),
                Some(
                    format!(
                        "--faces {budget}: the mesh has only {} faces, so the budget asks for \
                         no simplification",
                        q.faces_in
                    )
                    .as_str()
                ),
                "{method:?}"
            );
        }
    }
    let q = evaluate(&faces("cow.obj", Method::Qem, p.faces_in - 1)).unwrap();
    assert_eq!(budget_note(&q), None, "{q:?}");
}

/// `--faces N` on the level methods: the finest level with at most N faces, or the coarsest
/// level when none has so few.
#[test]
fn level_methods_take_the_finest_level_within_a_face_budget() {
    let input = repaired("npm-bunny.obj");
    let vs = ViewSphere::new(&input).unwrap();
    let counts: Vec<usize> = (0..=vs.max_level())
        .map(|k| vs.level(k).unwrap().face_count())
        .collect();
    let lod = OctreeLod::build(&input, &OctreeOptions::default()).unwrap();
    let octree: Vec<usize> = (0..=lod.max_level())
        .map(|k| lod.level(k).unwrap().face_count())
        .collect();
    for (method, counts) in [(Method::Silhouette, &counts), (Method::Octree, &octree)] {
        // A budget between two levels' counts, and one below every level.
        let fits = counts
            .iter()
            .rposition(|&f| f > 0 && f < input.face_count())
            .unwrap();
        let budget = counts[fits] + 1;
        let p = evaluate(&faces("npm-bunny.obj", method, budget)).unwrap();
        let k = p.detail["level"].as_u64().unwrap() as usize;
        assert_eq!(p.faces, counts[k], "{method:?}: {p:?}");
        assert!(p.faces <= budget, "{method:?}: {p:?}");
        assert!(
            counts[k + 1..].iter().all(|&f| f > budget),
            "{method:?} {counts:?}: {p:?}"
        );
        assert_eq!(budget_note(&p), None, "{p:?}");
        let coarsest = counts.iter().copied().filter(|&f| f > 0).min().unwrap();
        let p = evaluate(&faces("npm-bunny.obj", method, coarsest - 1)).unwrap();
        assert_eq!(p.faces, coarsest, "{method:?} {counts:?}: {p:?}");
        // Said, not left to look like a budget ignored.
        let note = budget_note(&p);
        let name = format!("{method:?}").to_lowercase();
        let want = format!(
            "--faces {}: the coarsest {name} level with faces has {coarsest} on this mesh",
            coarsest - 1
        );
        assert!(
            note.as_ref().is_some_and(|n| n.starts_with(&want)),
            "{note:?}"
        );
        // Exactly at the budget is within it.
        let p = evaluate(&faces("npm-bunny.obj", method, coarsest)).unwrap();
        assert_eq!((p.faces, budget_note(&p)), (coarsest, None), "{method:?}");
    }
    let p = evaluate(&level("npm-bunny.obj", Method::Octree, 3)).unwrap();
    assert_eq!(
        (p.faces, &p.detail["level"]),
        (octree[3], &serde_json::json!(3))
    );
    assert_eq!(
        p.detail["levels"].as_array().unwrap().len(),
        octree.len(),
        "{p:?}"
    );
    // A level past this mesh's octree names the flag and the file (it named neither).
    let deeper = octree.len() as u32;
    let e = evaluate(&level("npm-bunny.obj", Method::Octree, deeper)).unwrap_err();
    let m = format!("{e:#}");
    assert!(
        m.contains("npm-bunny.obj: ") && m.contains(&format!("--level {deeper}: ")),
        "{m}"
    );
}

/// `--weld` merges the teapot's bit-identical patch seams before repair: fewer vertices in.
#[test]
fn weld_merges_seam_vertices_before_the_simplifier_sees_them() {
    let a = faces("teapot.obj", Method::Qem, 3_000);
    let plain = evaluate(&a).unwrap();
    let welded = evaluate(&MeshArgs { weld: true, ..a }).unwrap();
    assert!(
        welded.vertices_in < plain.vertices_in,
        "{welded:?} {plain:?}"
    );
    assert_eq!(welded.faces_in, plain.faces_in, "{welded:?} {plain:?}");
}

/// `--out` writes the mesh the point measured, and a bad path or input names itself.
#[test]
fn out_writes_the_measured_mesh_and_errors_name_the_file() {
    let dir = scratch("evalmesh-out");
    let out = dir.join("lod.obj");
    let p = evaluate(&MeshArgs {
        out: Some(out.clone()),
        ..faces("npm-bunny.obj", Method::Qem, 800)
    })
    .unwrap();
    let back = io::read_path(&out, &MeshLimits::default()).unwrap();
    assert_eq!(
        (back.vertex_count(), back.face_count()),
        (p.vertices, p.faces)
    );
    let names: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert_eq!(names.len(), 1, "a temp file was left: {names:?}");

    let missing = dir.join("none.obj");
    let msg = error_of(&MeshArgs {
        input: missing.clone(),
        ..faces("npm-bunny.obj", Method::Qem, 800)
    });
    assert!(msg.contains(&missing.display().to_string()), "{msg}");
    let into_file = out.join("x.obj");
    let msg = error_of(&MeshArgs {
        out: Some(into_file.clone()),
        ..faces("npm-bunny.obj", Method::Qem, 800)
    });
    assert!(msg.contains(&into_file.display().to_string()), "{msg}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `subdivide` refuses a run that would pass the face limit before doing any of it.
#[test]
fn subdivide_refuses_beyond_the_face_limit_and_writes_four_times_the_faces_a_step() {
    let dir = scratch("evalmesh-subdivide");
    let output = dir.join("fine.obj");
    let input = repaired("npm-bunny.obj");
    subdivide(&SubdivideArgs {
        input: shared_mesh("npm-bunny.obj"),
        output: output.clone(),
        times: 2,
    })
    .unwrap();
    let back = io::read_path(&output, &MeshLimits::default()).unwrap();
    assert_eq!(back.face_count(), 16 * input.face_count());

    let big = dir.join("big.obj");
    let limit = MeshLimits::default().max_faces;
    let times = (0u8..)
        .find(|&t| input.face_count() * 4usize.pow(u32::from(t)) > limit)
        .unwrap();
    let err = subdivide(&SubdivideArgs {
        input: shared_mesh("npm-bunny.obj"),
        output: big.clone(),
        times,
    })
    .expect_err("above the face limit");
    assert!(format!("{err:#}").contains("more than the"), "{err:#}");
    assert!(!big.exists());
    // An output it cannot write is refused before the input is even read.
    let err = subdivide(&SubdivideArgs {
        input: dir.join("absent.obj"),
        output: dir.join("fine.xyz"),
        times: 1,
    })
    .expect_err("no such format");
    assert!(
        format!("{err:#}").contains("fine.xyz: unknown mesh extension"),
        "{err:#}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// What a killed `subdivide` or `eval mesh --out` left of its temporary file (a process that
/// is gone, pid past Linux's pid_max) goes at the next write of that output: the codec's
/// `write_path` named it so that nothing ever removed it.
#[test]
fn a_killed_runs_temporary_output_is_swept_by_the_next_write() {
    let dir = scratch("evalmesh-sweep");
    std::fs::create_dir_all(&dir).unwrap();
    let left = |name: &str| dir.join(format!(".{name}.tmp-4294967295-0"));
    for name in ["fine.obj", "lod.obj"] {
        std::fs::write(left(name), b"partial").unwrap();
    }
    subdivide(&SubdivideArgs {
        input: shared_mesh("npm-bunny.obj"),
        output: dir.join("fine.obj"),
        times: 1,
    })
    .unwrap();
    evaluate(&MeshArgs {
        out: Some(dir.join("lod.obj")),
        ..faces("npm-bunny.obj", Method::Qem, 800)
    })
    .unwrap();
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["fine.obj", "lod.obj"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn subdivision_counts_four_times_the_faces_a_step_up_to_the_limit() {
    assert_eq!(subdivided_faces(10, 0, 10), Some(10));
    assert_eq!(subdivided_faces(10, 2, 160), Some(160));
    assert_eq!(subdivided_faces(10, 2, 159), None);
    // Past usize, in either factor, is past every limit.
    assert_eq!(subdivided_faces(usize::MAX / 2, 1, usize::MAX), None);
    assert_eq!(subdivided_faces(1, 40, usize::MAX), None);
}

/// `--samples N` is the face-sample count in each direction, and no mesh means no distance.
#[test]
fn distances_use_the_samples_asked_for() {
    let input = repaired("npm-bunny.obj");
    let output = zerotile_codec::mesh::qem::simplify(
        &input,
        &zerotile_codec::mesh::QemOptions::to_faces(800),
    )
    .unwrap()
    .0;
    let d = measure(&input, &output, 1_234).unwrap().unwrap();
    // Every vertex, and the face samples spread by area (the last one can be lost to the
    // rounding of the shares).
    let on_faces = |samples: usize, mesh: &zerotile_codec::mesh::TriMesh| {
        (1_233..=1_234).contains(&(samples - mesh.vertex_count()))
    };
    assert!(on_faces(d.a_to_b.samples, &input), "{d:?}");
    assert!(on_faces(d.b_to_a.samples, &output), "{d:?}");
    assert!(measure(&input, &output, 0).unwrap().is_none());
    let empty = zerotile_codec::mesh::TriMesh::default();
    assert!(measure(&input, &empty, 1_234).unwrap().is_none());
}

/// The readable form: the input's counts, then the point's row, distances as % of the
/// diagonal ("-" when not measured).
#[test]
fn the_table_gives_the_point_in_one_row() {
    let mut p = evaluate(&faces("npm-bunny.obj", Method::Qem, 1_000)).unwrap();
    p.ms = 12.345;
    p.hausdorff_pct = Some(0.5);
    p.mean_pct = None;
    let text = table(&p);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 3, "{text}");
    assert_eq!(
        lines[0],
        format!(
            "{} ({} vertices, {} faces)",
            p.input, p.vertices_in, p.faces_in
        )
    );
    let row: Vec<&str> = lines[2].split_whitespace().collect();
    let (v, f) = (p.vertices.to_string(), p.faces.to_string());
    assert_eq!(
        row,
        ["qem", "faces", "1000", &v, &f, "12.35", "0.5000%", "-"],
        "{text}"
    );
}

/// A cell is fixed-point while that fits its width and keeps a nonzero value nonzero, and
/// exponent form otherwise.
#[test]
fn a_cell_switches_to_exponent_form_only_when_fixed_would_mislead() {
    use super::{cell, short};
    assert_eq!(cell(12.345, 2, 9), "12.35");
    assert_eq!(cell(0.0, 3, 9), "0.000");
    assert_eq!(cell(0.0006, 3, 9), "0.001");
    assert_eq!(cell(0.0004, 3, 9), "4.00e-4");
    assert_eq!(cell(123_456_789.0, 3, 9), "1.23e8");
    assert_eq!(cell(-5.5, 1, 4), "-5.5");
    assert_eq!(cell(f64::INFINITY, 2, 9), "inf");
    assert_eq!(short(0.5, 9), "0.5");
    assert_eq!(short(1e12, 9), "1.00e12");
    assert_eq!(short(1.0 / 3.0, 9), "3.33e-1");
}

/// A mesh with faces but no surface (three vertices on one point; four on one line) is
/// refused, as an upload of it is, instead of measured at 0 % from a zero diagonal.
#[test]
fn a_mesh_without_area_is_refused() {
    let dir = scratch("eval-mesh-flat");
    for (name, text) in [
        ("point.obj", "v 1 2 3\nv 1 2 3\nv 1 2 3\nf 1 2 3\n"),
        (
            "line.obj",
            "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nf 1 2 3\nf 2 3 4\n",
        ),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        let err = format!("{:#}", load(&path, false).unwrap_err());
        assert!(err.contains(name) && err.contains("zero area"), "{err}");
    }
    // Areas past the f64 range would make every distance NaN.
    let path = dir.join("huge.obj");
    std::fs::write(&path, "v 0 0 0\nv 1e200 0 0\nv 0 1e200 0\nf 1 2 3\n").unwrap();
    let err = format!("{:#}", load(&path, false).unwrap_err());
    assert!(err.contains("beyond the f64 range"), "{err}");
    // Small faces far apart: every area finite, the diagonal not. QEM dropped one of the two
    // triangles and reported a Hausdorff distance of 0 %.
    let path = dir.join("far.obj");
    let far = "v -1.7e308 0 0\nv -1.7e308 1 0\nv -1.7e308 0 1\n\
               v 1.7e308 0 0\nv 1.7e308 1 0\nv 1.7e308 0 1\nf 1 2 3\nf 4 5 6\n";
    std::fs::write(&path, far).unwrap();
    let err = format!("{:#}", load(&path, false).unwrap_err());
    assert!(
        err.contains("far.obj") && err.contains("diagonal is NaN): too large to measure"),
        "{err}"
    );
}

/// An output that is the input, by any name, is refused and the input is left as it was:
/// `subdivide cow.obj cow.obj` replaced the cow with its subdivision.
#[test]
fn an_output_that_is_the_input_is_refused_and_the_input_kept() {
    let dir = scratch("evalmesh-same-file");
    let input = dir.join("cow.obj");
    std::fs::copy(shared_mesh("cow.obj"), &input).unwrap();
    let before = std::fs::read(&input).unwrap();
    let link = dir.join("link.obj");
    std::os::unix::fs::symlink(&input, &link).unwrap();
    let hard = dir.join("hard.obj");
    std::fs::hard_link(&input, &hard).unwrap();
    let dotted = dir.join(".").join("cow.obj");
    for out in [&input, &link, &hard, &dotted] {
        let err = subdivide(&SubdivideArgs {
            input: input.clone(),
            output: out.clone(),
            times: 1,
        })
        .expect_err("the input as output");
        assert!(format!("{err:#}").contains("is the input"), "{err:#}");
        let msg = error_of(&MeshArgs {
            input: input.clone(),
            out: Some(out.clone()),
            ..faces("cow.obj", Method::Qem, 1000)
        });
        assert!(msg.contains("is the input"), "{msg}");
        assert_eq!(std::fs::read(&input).unwrap(), before, "{}", out.display());
    }
    // Another file is written as before.
    let other = dir.join("fine.obj");
    subdivide(&SubdivideArgs {
        input: input.clone(),
        output: other.clone(),
        times: 1,
    })
    .unwrap();
    assert!(other.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A one-triangle mesh was told "only 1 faces" and tabled as "1 faces": the counts take
/// their noun's number.
#[test]
fn a_one_face_mesh_is_counted_in_the_singular() {
    let dir = scratch("evalmesh-one-face");
    let path = dir.join("tri.obj");
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let p = evaluate(&MeshArgs {
        input: path,
        ..faces("cow.obj", Method::Qem, 1)
    })
    .unwrap();
    assert_eq!(
        budget_note(&p).as_deref(),
        Some("--faces 1: the mesh has only 1 face, so the budget asks for no simplification")
    );
    let text = table(&p);
    assert!(text.contains("tri.obj (3 vertices, 1 face)\n"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}
