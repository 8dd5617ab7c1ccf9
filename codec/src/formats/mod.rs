//! Wire formats for terrain tiles and their manifests.
//!
//! | module | what | clients |
//! |---|---|---|
//! | [`quantized_mesh`] | quantized-mesh-1.0 tiles: encoder and decoder | CesiumJS, loaders.gl |
//! | [`layer_json`] | Cesium's `layer.json` tileset manifest | CesiumJS |
//! | [`terrain_rgb`] | Mapbox terrain-RGB / Terrarium PNG height tiles | MapLibre, deck.gl |
//! | [`tilejson`] | TileJSON for those tiles (a `raster-dem` source's `url`) | MapLibre |
//! | [`mesh_bin`] | a compact binary mesh per tile | flight-sim and game front ends |
//!
//! Encoders check what they are given and return typed errors; decoders treat their input
//! as untrusted (no panic, allocations bounded by the input's size).

pub mod layer_json;
pub mod mesh_bin;
pub mod quantized_mesh;
pub mod terrain_rgb;
pub mod tilejson;
