//! `eval terrain`'s figures checked against what they claim to be, on real tiles from
//! `../shared/data` (read in place): the benchmark scripts and the README tables take
//! these numbers as given, so each is recomputed here independently of the sweep.

use zerotile_codec::raster::{self, ReadOptions};
use zerotile_codec::wavelet::Wavelet;
use zerotile_codec::Grid;

use super::parse_list;
use super::terrain::{
    check_rates, errors, floor_warning, is_8bit, load, parse_crop, psnr, run, table, Mesher, Point,
    Sweep, TerrainEval, DECODE_SHARE,
};
use crate::fixtures::shared_data;
use zerotile_codec::bintree::Hierarchy;

/// A sweep over a `size`² window of N44W072 at (300, 500), with every default.
fn n44(size: usize, sweep: Sweep) -> TerrainEval {
    TerrainEval {
        input: shared_data("dem/N44W072.hgt"),
        crop: Some((300, 500, size)),
        encoding: None,
        npz_key: None,
        wavelet: None,
        step: None,
        sweep,
        repeat: 1,
        eight_bit: false,
        mesher: None,
        decode_share: None,
        out: None,
    }
}

/// The same window read straight from the raster: its height range is the PSNR peak.
fn n44_range(size: usize) -> f64 {
    let map = raster::read_heightmap(shared_data("dem/N44W072.hgt"), &ReadOptions::default())
        .unwrap()
        .crop(300, 500, size, size)
        .unwrap();
    let (lo, hi) = map.min_max().unwrap();
    hi - lo
}

/// Rate and PSNR of `p` as the issue defines them: bits per sample, and 20 log10 of the
/// window's height range over the RMSE.
fn check_rate_and_psnr(p: &Point, peak: f64) {
    let n = (p.rows * p.cols) as f64;
    assert_eq!(p.bps, p.bytes as f64 * 8.0 / n, "{p:?}");
    let close = |a: Option<f64>, rmse: f64| {
        let want = 20.0 * (peak / rmse).log10();
        a.is_some_and(|a| (a - want).abs() < 1e-9)
    };
    assert!(close(p.psnr_db, p.rmse), "{p:?} peak {peak}");
    assert!(close(p.mesh_psnr_db, p.mesh_rmse), "{p:?} peak {peak}");
    assert!(
        p.rmse <= p.max_abs_err && p.mesh_rmse <= p.mesh_max_abs_err,
        "{p:?}"
    );
}

#[test]
fn errors_are_the_largest_and_the_root_mean_square_difference() {
    let a = Grid::new(2, 2, vec![0.0; 4]).unwrap();
    let b = Grid::new(2, 2, vec![1.0, -1.0, 3.0, 0.0]).unwrap();
    let (max, rmse) = errors(&a, &b);
    assert_eq!(max, 3.0);
    assert!((rmse - (11.0f64 / 4.0).sqrt()).abs() < 1e-12);
    assert!((psnr(255.0, 1.0).unwrap() - 48.130_803_608).abs() < 1e-6);
    // Exact is infinite, which JSON cannot hold.
    assert_eq!(psnr(255.0, 0.0), None);
}

/// In threshold mode on a 2^k + 1 window (the bintree), T is the mesh's true max error:
/// the decode stops at T · DECODE_SHARE and the mesh spends only what the decode left.
#[test]
fn a_threshold_point_keeps_the_mesh_within_t_and_decodes_to_its_share() {
    let ts = [2.0, 8.0, 32.0];
    let points = run(&n44(129, Sweep::Threshold(ts.to_vec()))).unwrap();
    let peak = n44_range(129);
    assert_eq!(points.len(), ts.len());
    let mut triangles = Vec::new();
    for (p, t) in points.iter().zip(ts) {
        assert_eq!(
            (p.mode, p.param, p.rows, p.cols),
            ("threshold", Some(t), 129, 129)
        );
        assert!(p.mesh_max_abs_err <= t + 1e-9, "{p:?}");
        assert!(p.threshold <= t * DECODE_SHARE, "{p:?}");
        check_rate_and_psnr(p, peak);
        triangles.push(p.mesh_triangles);
    }
    assert!(triangles.windows(2).all(|w| w[0] > w[1]), "{triangles:?}");
}

/// A threshold off a power of two times 8 is read as deep as the server reads it (the
/// decode budget rounded down to a power of two): T = 3 read to the 0.5 m pass here and to
/// the 0.25 m one by the server (a QA pass, from the tiles' `.ezw` prefix sizes).
#[test]
fn a_threshold_point_decodes_as_deep_as_the_server() {
    use crate::serve::threshold::Depth;
    let ts = [3.0, 5.0, 12.0, 16.0];
    let points = run(&n44(129, Sweep::Threshold(ts.to_vec()))).unwrap();
    for (p, t) in points.iter().zip(ts) {
        let Depth::Level(k) = Depth::for_threshold(t) else {
            panic!("T = {t} decodes every pass");
        };
        assert_eq!(p.threshold, f64::from(k).exp2(), "T = {t}: {p:?}");
    }
}

/// A `--bpp B` point decodes the prefix B bits per sample buy, never more.
#[test]
fn a_rate_point_decodes_at_most_its_rate() {
    let rates = [0.5, 1.0, 2.0];
    let points = run(&n44(129, Sweep::Bpp(rates.to_vec()))).unwrap();
    let peak = n44_range(129);
    for (p, b) in points.iter().zip(rates) {
        let budget = (b * 129.0 * 129.0 / 8.0).floor() as usize;
        assert!(
            p.bytes <= budget && p.bytes + 8 > budget,
            "{p:?} budget {budget}"
        );
        check_rate_and_psnr(p, peak);
    }
}

/// A `--max-error E` point keeps every decoded height within E of the source.
#[test]
fn a_max_error_point_holds_its_bound() {
    let points = run(&n44(65, Sweep::MaxError(vec![1.0, 4.0]))).unwrap();
    for (p, e) in points.iter().zip([1.0, 4.0]) {
        assert_eq!(p.mode, "max-error");
        assert!(p.max_abs_err <= e + 1e-9 && p.max_abs_err > 0.0, "{p:?}");
    }
    // A looser bound costs fewer bytes.
    assert!(points[1].bytes < points[0].bytes, "{points:?}");
}

/// Lossless is 5/3 whatever the default lossy wavelet, exact, and refused with 9/7.
#[test]
fn lossless_is_exact_on_the_5_3_wavelet_and_refused_on_9_7() {
    let points = run(&n44(65, Sweep::Lossless)).unwrap();
    let p = &points[0];
    assert_eq!((p.mode, p.param), ("lossless", None));
    assert_eq!(p.wavelet, Wavelet::LeGall53.name());
    assert_eq!((p.max_abs_err, p.rmse, p.psnr_db), (0.0, 0.0, None));
    // The bintree (a 2^k + 1 window) meshes within the lossless threshold, one step.
    assert!(
        p.mesh_max_abs_err > 0.0 && p.mesh_max_abs_err <= 1.0,
        "{p:?}"
    );
    // The zerotree mesher (any other window) keeps every sample there: its mesh is exact
    // too, and says so instead of printing the f64 residue as a PSNR (fuji's 0.1 m steps
    // are not exact in binary).
    let p = &run(&TerrainEval {
        input: shared_data("dem/fuji.png"),
        encoding: Some(raster::Encoding::TerrainRgb),
        crop: Some((0, 0, 64)),
        ..n44(64, Sweep::Lossless)
    })
    .unwrap()[0];
    assert_eq!(p.mesh_triangles, 2 * 63 * 63, "{p:?}");
    assert_eq!(
        (p.mesh_max_abs_err, p.mesh_rmse, p.mesh_psnr_db),
        (0.0, 0.0, None),
        "{p:?}"
    );
    let e = run(&TerrainEval {
        wavelet: Some(Wavelet::Cdf97),
        ..n44(65, Sweep::Lossless)
    })
    .unwrap_err();
    assert!(e.to_string().contains("reversible 5/3"), "{e}");
}

/// Heights off the step grid (metres under a 0.3 m step here; float rasters in general)
/// cannot decode exactly, so lossless is refused and the max-error point that would keep
/// them within half a step is named.
#[test]
fn lossless_refuses_heights_off_the_step_grid() {
    let e = refusal(TerrainEval {
        step: Some(0.3),
        ..n44(65, Sweep::Lossless)
    });
    assert!(
        e.contains("not multiples of the height step 0.3") && e.contains("--max-error 0.15"),
        "{e}"
    );
}

/// The paper's 8-bit setting stretches the window to the integers 0..=255, peak 255; a
/// 16-bit window keeps its metres and peaks at its own range.
#[test]
fn eight_bit_stretches_the_window_to_0_255_and_metres_peak_at_their_range() {
    let (g, step, peak) = load(&TerrainEval {
        eight_bit: true,
        ..n44(65, Sweep::Lossless)
    })
    .unwrap();
    let lo = g.data().iter().copied().fold(f64::INFINITY, f64::min);
    let hi = g.data().iter().copied().fold(f64::NEG_INFINITY, f64::max);
    assert_eq!((lo, hi, step, peak), (0.0, 255.0, 1.0, 255.0));
    assert!(g.data().iter().all(|h| h.fract() == 0.0));

    let (g, step, peak) = load(&n44(65, Sweep::Lossless)).unwrap();
    assert_eq!((g.rows(), g.cols(), step), (65, 65, 1.0));
    assert_eq!(peak, n44_range(65));
}

#[test]
fn a_parameter_list_takes_zero_and_refuses_negatives() {
    assert_eq!(parse_list("--bpp", "0, 1.5", true).unwrap(), [0.0, 1.5]);
    let e = parse_list("--bpp", "1,-1", true).unwrap_err();
    assert!(e.contains("'-1' must be finite and ≥ 0"), "{e}");
    assert!(parse_list("--bpp", "1,x", true)
        .unwrap_err()
        .contains("'x' is not a number"));
    // Where 0 is refused too, one message says so for both.
    for bad in ["0", "-1", "inf", "nan"] {
        let e = parse_list("--max-error", bad, false).unwrap_err();
        assert!(
            e.ends_with(&format!("'{bad}' must be finite and > 0")),
            "{e}"
        );
    }
    assert_eq!(parse_list("--max-error", "0.5", false).unwrap(), [0.5]);
}

/// 8-bit means integer steps with every height in 0..=255: the peak is then 255, not the
/// window's range. One sample at 256, below 0, or a step other than 1 is not 8-bit.
#[test]
fn eight_bit_data_is_integer_steps_within_0_255() {
    let grid = |top: f64| Grid::new(1, 3, vec![0.0, 17.0, top]).unwrap();
    assert!(is_8bit(&grid(255.0), Some(1.0)));
    assert!(is_8bit(&grid(3.0), Some(1.0)));
    assert!(!is_8bit(&grid(256.0), Some(1.0)));
    assert!(!is_8bit(
        &Grid::new(1, 2, vec![-1.0, 3.0]).unwrap(),
        Some(1.0)
    ));
    assert!(!is_8bit(&grid(255.0), Some(0.5)));
    assert!(!is_8bit(&grid(255.0), None));
}

/// A `--bpp` rate must buy the whole header: exactly the header is usable, a byte less is
/// refused with the smallest usable rate named (rounded up, so it is itself usable).
#[test]
fn a_rate_below_the_header_is_refused_with_the_smallest_usable_rate() {
    // 100 header bytes over 800 samples: 1 bit a sample buys exactly the header.
    assert!(check_rates(&[1.0, 2.0], 100, 800).is_ok());
    let e = check_rates(&[2.0, 0.99], 100, 800).unwrap_err().to_string();
    assert!(
        e.contains("--bpp 0.99") && e.contains("rate for this window, 1 bits"),
        "{e}"
    );
    let e = check_rates(&[0.5], 77, 9).unwrap_err().to_string();
    assert!(e.contains("68.4445 bits/sample"), "{e}");
}

#[test]
fn a_crop_is_three_whole_numbers_with_a_size_of_two_or_more() {
    assert_eq!(parse_crop("300, 500,257"), Ok((300, 500, 257)));
    assert_eq!(parse_crop("0,0,2"), Ok((0, 0, 2)));
    assert!(parse_crop("0,0,1")
        .unwrap_err()
        .contains("SIZE must be at least 2"));
    // One stream of at most 2^26 samples: 8192² and no more.
    assert_eq!(parse_crop("0,0,8192"), Ok((0, 0, 8192)));
    assert!(parse_crop("0,0,8193")
        .unwrap_err()
        .contains("SIZE must be at most 8192"));
    for bad in [
        "1,2,0",
        "1,2,1",
        "1,2",
        "1,2,3,4",
        "a,b,c",
        "-1,2,3",
        "1.5,2,3",
        "0,0,100000",
    ] {
        let e = parse_crop(bad).unwrap_err();
        assert!(e.contains(&format!("--crop '{bad}'")), "{bad}: {e}");
    }
}

/// A whole file past the decoder's sample limit is refused from its header, before its
/// samples are read (an 8200² PNG of 65 KB was read, encoded and then refused, at 2.7 GB),
/// with --crop suggested: here an .npy whose header claims 8193² float32 samples and whose
/// body is empty.
#[test]
fn a_file_past_one_streams_limit_is_refused_from_its_header() {
    let dir = crate::fixtures::scratch("eval-window-limit");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("big.npy");
    let mut header = b"{'descr': '<f4', 'fortran_order': False, 'shape': (8193, 8193), }".to_vec();
    while !(10 + header.len() + 1).is_multiple_of(64) {
        header.push(b' ');
    }
    header.push(b'\n');
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
    bytes.extend_from_slice(&header);
    std::fs::write(&path, &bytes).unwrap();
    let e = refusal(TerrainEval {
        input: path,
        crop: None,
        ..n44(65, Sweep::Threshold(vec![4.0]))
    });
    assert!(
        e.starts_with(
            "eval terrain codes the window as one stream of at most 67108864 samples; give \
             --crop ROW,COL,SIZE (SIZE up to 8192): "
        ) && e.contains("big.npy: exceeds a limit: 8193 × 8193 samples (rows × columns)"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// An encoder refusal names the file and the flag that set what it refused (it was "height
/// range / step must be small enough for 63 bit planes …" alone).
#[test]
fn an_encoder_refusal_names_the_file_and_the_flag() {
    let e = refusal(TerrainEval {
        step: Some(1e-30),
        ..n44(65, Sweep::Threshold(vec![4.0]))
    });
    assert!(
        e.contains(
            "N44W072.hgt: encoding the window with --step 0.000000000000000000000000000001: "
        ) && e.contains("63 bit planes"),
        "{e}"
    );
}

/// The PSNR peak is the window's height range whatever --step says (a step past the range
/// made the step the peak: 545 dB beside a 1.9 km error).
#[test]
fn a_step_past_the_range_does_not_become_the_peak() {
    let p = &run(&TerrainEval {
        step: Some(1e6),
        ..n44(65, Sweep::Threshold(vec![4.0]))
    })
    .unwrap()[0];
    check_rate_and_psnr(p, n44_range(65));
    assert!(p.psnr_db.is_some_and(|db| db < 20.0), "{p:?}");
}

/// Why `eval` is refused, with its causes (`{:#}`).
fn refusal(eval: TerrainEval) -> String {
    format!("{:#}", run(&eval).unwrap_err())
}

/// An --out that is a file is refused before any work, by what it is.
#[test]
fn an_out_that_is_a_file_is_refused_up_front() {
    let dir = crate::fixtures::scratch("eval-out-file");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("afile");
    std::fs::write(&file, b"mine").unwrap();
    let e = refusal(TerrainEval {
        out: Some(file.clone()),
        ..n44(65, Sweep::Threshold(vec![4.0]))
    });
    assert!(
        e.ends_with("afile: is not a folder; give a folder for the meshes"),
        "{e}"
    );
    assert_eq!(std::fs::read(&file).unwrap(), b"mine");
    let _ = std::fs::remove_dir_all(&dir);
    // Neither a file nor a folder: it was "File exists (os error 17)" after the first point.
    #[cfg(unix)]
    {
        let e = refusal(TerrainEval {
            out: Some("/dev/null".into()),
            ..n44(65, Sweep::Threshold(vec![4.0]))
        });
        assert_eq!(
            e, "--out /dev/null: is not a folder; give a folder for the meshes",
            "{e}"
        );
    }
}

/// `--out`'s meshes are written as every atomic file is: a killed run's temporary copy of one
/// (a process that is gone) goes at the next write of it instead of staying for good.
#[test]
fn out_sweeps_what_a_killed_run_left_of_a_mesh() {
    let dir = crate::fixtures::scratch("eval-out-sweep");
    let eval = TerrainEval {
        out: Some(dir.clone()),
        ..n44(65, Sweep::Threshold(vec![4.0]))
    };
    let names = || {
        let mut n: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        n.sort();
        n
    };
    run(&eval).unwrap();
    let written = names();
    assert_eq!(written.len(), 1, "{written:?}");
    std::fs::write(
        dir.join(format!(".{}.tmp-4294967295-0", written[0])),
        b"partial",
    )
    .unwrap();
    run(&eval).unwrap();
    assert_eq!(names(), written);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--out` meshes are in the server's local-scheme frame: x the column, y minus the row, so
/// every face is counter-clockwise from above (normal up). They were (column, row), mirrored,
/// every face pointing down.
#[test]
fn out_meshes_face_up_with_y_minus_the_row() {
    let dir = crate::fixtures::scratch("eval-out-winding");
    let points = run(&TerrainEval {
        out: Some(dir.clone()),
        ..n44(65, Sweep::Threshold(vec![4.0]))
    })
    .unwrap();
    let limits = zerotile_codec::mesh::io::MeshLimits::default();
    let m = zerotile_codec::mesh::io::read_path(&dir.join("threshold-4.obj"), &limits).unwrap();
    assert_eq!(m.faces.len(), points[0].mesh_triangles);
    for f in &m.faces {
        let [a, b, c] = f.map(|i| m.positions[i as usize]);
        let up = (b - a).cross(c - a).z;
        assert!(up > 0.0, "{f:?} faces down");
    }
    // The window's north-west corner sample at the origin, its south-east at (64, -64).
    let window = raster::read_heightmap(shared_data("dem/N44W072.hgt"), &ReadOptions::default())
        .unwrap()
        .crop(300, 500, 65, 65)
        .unwrap();
    for (r, c) in [(0, 0), (64, 64)] {
        let v = m
            .positions
            .iter()
            .find(|p| (p.x, p.y) == (c as f64, -(r as f64)))
            .unwrap();
        // Vertices carry the decoded heights.
        let err = (v.z - window.heights.get(r, c)).abs();
        assert!(err <= points[0].max_abs_err + 1e-9, "({r}, {c}): {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bintree_sides_are_the_ones_the_hierarchy_builds() {
    for n in 0..=600 {
        assert_eq!(Hierarchy::supports(n), Hierarchy::new(n).is_some(), "{n}");
    }
    // The ends, without building a 4097² hierarchy.
    assert!(Hierarchy::supports(4097) && Hierarchy::supports(3));
    assert!(!Hierarchy::supports(8193) && !Hierarchy::supports(4096) && !Hierarchy::supports(2));
}

/// Without --crop the file's size decides the mesher: a bintree-only flag on a grid the
/// bintree cannot take is refused before any point is measured, naming the grid.
#[test]
fn bintree_flags_on_a_grid_the_bintree_cannot_take_are_refused() {
    let e = refusal(TerrainEval {
        mesher: Some(Mesher::Bintree),
        ..n44(64, Sweep::Threshold(vec![4.0]))
    });
    assert!(
        e.ends_with("--mesher bintree needs a square (2^k + 1)-sample grid, this one is 64×64 (e.g. --crop R,C,257)"),
        "{e}"
    );
    let e = refusal(TerrainEval {
        decode_share: Some(0.25),
        ..n44(64, Sweep::Threshold(vec![4.0]))
    });
    assert!(
        e.contains("--decode-share applies to the bintree mesher"),
        "{e}"
    );
    // On a side it takes, the share is the decode's: T · share, and no more.
    let p = &run(&TerrainEval {
        decode_share: Some(0.25),
        ..n44(65, Sweep::Threshold(vec![16.0]))
    })
    .unwrap()[0];
    assert!(p.threshold <= 4.0 && p.threshold > 2.0, "{p:?}");
}

/// A window with no-data samples has no heights to measure there: refused, with the count
/// and the file named (terra_elev.tif has no-data in its corners).
#[test]
fn a_window_with_no_data_is_refused_by_name() {
    let input = shared_data("dem/terra_elev.tif");
    let e = load(&TerrainEval {
        input: input.clone(),
        crop: None,
        ..n44(65, Sweep::Lossless)
    })
    .unwrap_err()
    .to_string();
    assert!(
        e.contains(&input.display().to_string()) && e.contains("3942 no-data samples"),
        "{e}"
    );
}

/// Table 1's layout: "remain" is each mesh's share of the full grid's triangles ("-" for a
/// grid without cells), and an exact PSNR prints as inf.
#[test]
fn the_table_gives_each_meshs_share_of_the_full_mesh() {
    let mut points = run(&n44(65, Sweep::Threshold(vec![4.0]))).unwrap();
    points[0].mesh_triangles = 2_048;
    let column = |text: &str, i: usize| -> String {
        let row = text.lines().nth(2).unwrap();
        row.split_whitespace().nth(i).unwrap().to_string()
    };
    // 65 × 65 samples: 2 · 64 · 64 = 8192 triangles in the full grid.
    let text = table(&points);
    let header = text.lines().nth(1).unwrap();
    assert_eq!(
        header.split_whitespace().rev().nth(1),
        Some("remain"),
        "{text}"
    );
    // The mesher is named, with what T bounds under it.
    assert!(
        text.starts_with(&format!(
            "{} (65×65, cdf97, bintree mesher: mesh within param − max err of the decoded \
             heights, so mesh err ≤ param)",
            points[0].input
        )),
        "{text}"
    );
    assert_eq!(column(&text, 10), "25.0%", "{text}");
    assert_eq!(column(&text, 9), "2048", "{text}");
    assert_eq!(
        column(&text, 8).parse::<f64>().unwrap(),
        (points[0].mesh_max_abs_err * 1e3).round() / 1e3,
        "{text}"
    );
    points[0].cols = 33;
    assert_eq!(column(&table(&points), 10), "50.0%");
    points[0].rows = 1;
    assert_eq!(column(&table(&points), 10), "-");
    points[0].psnr_db = None;
    assert_eq!(column(&table(&points), 4), "inf");
    // A 64² window is no (2^k + 1)² grid: the zerotree mesher, whose error T does not bound.
    let p = run(&n44(64, Sweep::Threshold(vec![4.0]))).unwrap();
    assert_eq!(p[0].mesher, "zerotree");
    assert!(
        table(&p).lines().next().unwrap().ends_with(
            "(64×64, cdf97, zerotree mesher: T stops the zerotree; mesh err not bounded by T)"
        ),
        "{}",
        table(&p)
    );
}

/// Outside `--threshold` the bintree meshes within the T column of the decoded heights, so
/// its error reaches T plus the decode's: the header said "mesh err ≤ T", which no rate or
/// max-error point kept. It states what each point holds.
#[test]
fn the_bintree_header_states_the_bound_the_rows_keep() {
    for sweep in [
        Sweep::Bpp(vec![0.25, 1.0, 2.0]),
        Sweep::MaxError(vec![1.0, 4.0]),
    ] {
        let points = run(&n44(65, sweep)).unwrap();
        let text = table(&points);
        assert!(
            text.lines().next().unwrap().ends_with(
                "bintree mesher: mesh within T of the decoded heights, so mesh err ≤ T + max err)"
            ),
            "{text}"
        );
        for p in &points {
            assert!(
                p.mesh_max_abs_err <= p.threshold + p.max_abs_err + 1e-9,
                "{p:?}"
            );
        }
        // What the header said before: some row breaks it.
        assert!(
            points.iter().any(|p| p.mesh_max_abs_err > p.threshold),
            "{points:?}"
        );
    }
}

/// Numbers far from a column's usual size keep the column and their size: a 1e12 threshold
/// does not widen the row past the header, a 1e-7 error does not print as 0.000.
#[test]
fn the_table_writes_extreme_numbers_in_exponent_form() {
    let mut points = run(&n44(65, Sweep::Threshold(vec![4.0]))).unwrap();
    let header_len = table(&points).lines().nth(1).unwrap().len();
    let p = &mut points[0];
    (p.param, p.threshold, p.max_abs_err, p.rmse) = (Some(1e12), 1e12, 1e-7, 0.0);
    let text = table(&points);
    let row = text.lines().nth(2).unwrap();
    let cells: Vec<&str> = row.split_whitespace().collect();
    assert_eq!(cells[1..3].to_vec(), ["1.00e12", "1.00e12"], "{text}");
    assert_eq!(cells[5], "1.00e-7", "{text}");
    assert_eq!(cells[6], "0.000", "exact zero stays plain: {text}");
    assert_eq!(row.chars().count(), header_len, "{text}");
}

/// A threshold below the 9/7 stream's floor (its last pass, set by the 1 m step, decodes
/// within ~0.04 m) cannot be kept: the point says so instead of passing a mesh error above T
/// off as T's. Above the floor nothing is said, and the mesh is within T.
#[test]
fn a_threshold_below_the_streams_floor_is_flagged() {
    let points = run(&n44(65, Sweep::Threshold(vec![0.001, 0.5]))).unwrap();
    let (below, above) = (&points[0], &points[1]);
    assert!(below.max_abs_err > 0.001, "{below:?}");
    assert!(
        below.below_floor && below.mesh_max_abs_err > 0.001,
        "{below:?}"
    );
    let w = floor_warning(below).unwrap();
    assert!(
        w.contains("--threshold 0.001") && w.contains("--wavelet 53"),
        "{w}"
    );
    assert!(
        !above.below_floor && above.mesh_max_abs_err <= 0.5,
        "{above:?}"
    );
    assert_eq!(floor_warning(above), None);
    // The exact 5/3 stream has no floor.
    let exact = run(&TerrainEval {
        wavelet: Some(Wavelet::LeGall53),
        ..n44(65, Sweep::Threshold(vec![0.001]))
    })
    .unwrap();
    assert!(!exact[0].below_floor && exact[0].mesh_max_abs_err <= 0.001);
}

/// A `--step` past the window's height range codes no pass: the decode is flat, the mesh
/// that follows it exactly is 2 triangles, and the warning said "the mesh keeps every
/// sample". It now gives the mesh's size, and the threshold no pass reached is infinite,
/// `null` in the JSON as the README says.
#[test]
fn a_step_that_codes_no_pass_is_warned_of_for_what_it_does() {
    let p = &run(&TerrainEval {
        step: Some(1e30),
        ..n44(65, Sweep::Threshold(vec![4.0]))
    })
    .unwrap()[0];
    assert!(p.below_floor && p.threshold.is_infinite(), "{p:?}");
    assert_eq!((p.mesh_triangles, p.mesh_vertices), (2, 4), "{p:?}");
    let w = floor_warning(p).unwrap();
    assert!(!w.contains("every sample"), "{w}");
    assert!(
        w.contains("decodes no pass at all")
            && w.contains("follows the decoded heights exactly (2 triangles, 4 of 4225 samples)"),
        "{w}"
    );
    let json = serde_json::to_value(p).unwrap();
    assert_eq!(json["threshold"], serde_json::Value::Null);
    // A floor the stream does reach is its last pass's.
    let p = &run(&n44(65, Sweep::Threshold(vec![0.001]))).unwrap()[0];
    let w = floor_warning(p).unwrap();
    assert!(
        p.threshold.is_finite() && w.contains("its last pass decodes within"),
        "{w}"
    );
    assert!(
        w.contains(&format!("({} triangles, ", p.mesh_triangles)),
        "{w}"
    );
}
