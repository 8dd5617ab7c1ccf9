//! Object meshes: the indexed triangle mesh, its file formats, validation and repair, shared
//! adjacency, quadric simplification and Metro-style distances.
//!
//! - [`TriMesh`] ([`indexed`]) is what every algorithm takes and returns.
//! - [`io`] reads OBJ / PLY / STL / JSON and writes OBJ / PLY / GLB / JSON under [`MeshLimits`].
//! - [`validate`] counts defects and repairs what can be repaired.
//! - [`topology`] is the adjacency the simplifiers share.
//! - [`octree`] builds octree LOD levels once per mesh and browses a screen region at full detail.
//! - [`qem`] is the Garland–Heckbert baseline every other simplifier is measured against.
//! - [`distance`] measures any of them: symmetric Hausdorff and mean surface distance.
//! - [`subdivide`] makes large smooth meshes for tests and benchmarks.

pub mod curvature;
pub mod distance;
pub mod error;
pub mod indexed;
pub mod io;
pub mod octree;
pub mod qem;
pub mod silhouette;
pub mod subdivide;
pub mod topology;
pub mod validate;

pub use distance::{surface_distance, DistanceOptions, SurfaceDistance};
pub use error::{InvalidMesh, MeshError};
pub use indexed::{Aabb, TriMesh};
pub use io::{Format, MeshLimits};
pub use octree::{OctreeLod, OctreeOptions};
pub use qem::{simplify, QemOptions, QemReport};
pub use topology::{OneRing, Topology, VertexKind};
pub use validate::{inspect, repair, ValidationReport};
