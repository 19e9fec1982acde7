//! L7 images from a step's view-independent solution (Besuievsky & Martín §6.1): the
//! final gather per pixel ([`gather`]), and what is written from the images: linear HDR
//! OpenEXR, tone-mapped PNG, falsecolor maps with a legend, playable previews, and
//! daylight glare probability from angular fisheye images.
//!
//! Every image here is an [`Image`]: linear RGB radiance (W·sr⁻¹·m⁻²) or irradiance
//! (W/m², `-i` images), row-major from the top row, with a per-pixel stated error.

pub mod image; // the shared image type
pub mod gather; // the final gather: a step's solution seen through a camera
mod denoise; // the gather's error-guided, edge-aware filter
pub mod exr; // linear HDR OpenEXR with the error channel and provenance
pub mod rgbe; // Radiance HDR pictures (RGBE), read and written
pub mod tonemap; // tone-mapped 8-bit sRGB PNG
pub mod falsecolor; // falsecolor maps with a legend, as Radiance's falsecolor
mod text; // text in pictures: an embedded open-licence font
pub mod preview; // playable previews of sequences: animated PNG, HTML slider
pub mod glare; // daylight glare probability from angular fisheye images

pub use gather::{RenderOptions, Solution, ViewGeometry};
pub use image::{Image, Provenance, Quantity};
