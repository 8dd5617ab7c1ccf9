//! The octree LOD figures of `codec/src/mesh/octree/octree.md`: boxes of the modified against
//! the plain adaptive octree, per-level sizes, build/cut time and Metro distances, and the
//! memory of region-of-interest browsing against the full model.
//!
//! `cargo run --release -p zerotile-codec --example octree_report [MESH.obj ...]`
//! (default: fandisk, the Stanford bunny, the UV sphere and the rocker arm from
//! `../shared/data/meshes`).

use std::error::Error;
use std::path::PathBuf;
use std::time::Instant;

use glam::DVec3;
use zerotile_codec::mesh::io::{read_path, MeshLimits};
use zerotile_codec::mesh::octree::{OctreeLod, OctreeOptions, Roi, View};
use zerotile_codec::mesh::{inspect, repair, surface_distance, DistanceOptions};

const DEFAULT_MESHES: [&str; 4] = [
    "fandisk.obj",
    "stanford-bunny.obj",
    "uv-sphere-5002.obj",
    "rocker-arm.obj",
];

fn main() -> Result<(), Box<dyn Error>> {
    let shared = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/meshes");
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let paths = if args.is_empty() {
        DEFAULT_MESHES.iter().map(|m| shared.join(m)).collect()
    } else {
        args
    };
    for path in paths {
        let (mesh, _) = repair(&read_path(&path, &MeshLimits::default())?)?;
        let name = path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into());
        // Build once, as a server would at load.
        let start = Instant::now();
        let lod = OctreeLod::build(&mesh, &OctreeOptions::default())?;
        let build_ms = start.elapsed().as_secs_f64() * 1e3;
        let (boxes, plain) = lod.box_totals();
        println!(
            "\n## {name}: {} vertices, {} faces; build {build_ms:.1} ms (all level sizes included)",
            mesh.vertex_count(),
            mesh.face_count()
        );
        println!(
            "boxes: modified {boxes}, plain adaptive {plain}, ratio {:.3} ({:.0} % fewer)",
            boxes as f64 / plain as f64,
            100.0 * (1.0 - boxes as f64 / plain as f64)
        );
        println!(
            "| level | boxes | plain boxes | vertices | faces | cut ms | Hausdorff % | mean % \
             | boundary / non-manifold / flipped edges |"
        );
        println!("|---|---|---|---|---|---|---|---|---|");
        for l in lod.levels() {
            let start = Instant::now();
            let out = lod.level(l.level)?;
            let ms = start.elapsed().as_secs_f64() * 1e3;
            let distance = if out.face_count() == 0 {
                "- | -".to_string()
            } else {
                let d = surface_distance(&mesh, &out, &DistanceOptions::default())?;
                format!("{:.3} | {:.4}", d.hausdorff_pct(), d.mean_pct())
            };
            let r = inspect(&out);
            println!(
                "| {} | {} | {} | {} | {} | {ms:.2} | {distance} | {} / {} / {} |",
                l.level,
                l.boxes,
                l.plain_boxes,
                l.vertices,
                l.faces,
                r.boundary_edges,
                r.non_manifold_edges,
                r.inconsistent_orientation_edges
            );
        }
        // Browse: eye on +X three diagonals away, 30° field of view, a square region centred
        // on screen, from a few base levels.
        let b = mesh.bounding_box();
        let centre = (b.min + b.max) * 0.5;
        let view = View::looking_at(centre + DVec3::X * 3.0 * b.diagonal(), centre, 30.0, 1.0);
        println!("| base | roi (NDC half side) | refined boxes | vertices | faces | bytes / full | faces / full | ms |");
        println!("|---|---|---|---|---|---|---|---|");
        for base in 2..=4 {
            for half in [0.1, 0.25] {
                let roi = Roi {
                    x0: -half,
                    y0: -half,
                    x1: half,
                    y1: half,
                };
                let start = Instant::now();
                let browsed = lod.browse(base, &view, &roi)?;
                let ms = start.elapsed().as_secs_f64() * 1e3;
                let m = &browsed.cut.mesh;
                println!(
                    "| {base} | {half} | {} | {} | {} | {:.3} | {:.3} | {ms:.2} |",
                    browsed.refinement.opened,
                    m.vertex_count(),
                    m.face_count(),
                    browsed.bytes as f64 / browsed.full_bytes as f64,
                    m.face_count() as f64 / mesh.face_count() as f64
                );
            }
        }
    }
    Ok(())
}
