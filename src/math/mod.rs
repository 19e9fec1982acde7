//! L0 geometry helpers on glam types; nothing here knows about daylight.

pub mod bvh;
pub mod frame;
pub mod quadtree;
pub mod raster;
pub mod rng;
pub mod spherical_triangle;
