//! L7 images from a step's view-independent solution (Besuievsky & Martín §6.1): the
//! final gather per pixel ([`gather`]), and what is written from the images: linear HDR
//! OpenEXR, tone-mapped PNG, falsecolor maps with a legend, playable previews, and
//! daylight glare probability from angular fisheye images.
//!
//! Every image here is an [`Image`]: linear RGB radiance (W·sr⁻¹·m⁻²) or irradiance
//! (W/m², `-i` images), row-major from the top row, with a per-pixel stated error.

pub mod glare;
pub mod image;
pub mod rgbe;

pub use image::{Image, Provenance, Quantity};
