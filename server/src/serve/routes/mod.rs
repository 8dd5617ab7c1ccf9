//! Route handlers: HTTP in, HTTP out; the work lives in `pipeline` and `render`.

pub mod meshes;
pub mod meta;
pub mod site;
pub mod tiles;
pub mod view;
