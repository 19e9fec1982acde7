//! # daystep — incremental time-series daylight engine
//!
//! The method is Besuievsky & Martín, "A Hierarchical Algorithm for Radiosity Daylighting":
//! the sky is subdivided into spherical triangles, each a parallel light source (E = L̂·ω),
//! plus the sun; each source is scan-converted into a Layered Depth Image whose per-patch
//! visibility ratio VR = n_v/n_p drives quad-tree refinement and the direct transfer
//! B_i += ρ_i E (Ap_i/A_i) VR_i.
//!
//! ```text
//! scene.toml ─ OBJ/MTL ─► scene ──────────────┐
//! site + instant ─► site::solar_position      │
//! sky options ────► sky (Preetham|Perez|CIE)  │
//!        └─► sources (octahedral quadtree + snapped sun)
//!               └─► projection (LDI, VR, refinement) per source ─► transfer (element irradiance)
//!                                              └─► sensors (direct sun + sky + ground glow)
//!                                                     └─► sequence (the run, report, outputs)
//! ```
//!
//! Units: metres; scene frame x east, y north, z up; RGB radiance W·sr⁻¹·m⁻²; irradiance
//! W/m²; illuminance lux = 179 × (0.265 R + 0.670 G + 0.065 B).
//!
//! Layers (a module uses only lower layers; `tests/layers.rs` checks it):
//! L0 error, files, math, photometry · L1 site, scene, weather (scene and weather may use
//! site) · L2 sky, sources · L3 hierarchy · L4 projection · L5 transfer, cache, trace ·
//! L6 sensors, radiosity · L7 metrics, export (export may use metrics) · L8 sequence · L9 cli.
#![warn(missing_docs)]
#![deny(unsafe_code)] // the one exception: cache::store::map_readonly

// L0 foundations
pub mod error; // Error enum: input errors name file, line, value
pub mod files; // atomic writes, text reads with paths
pub mod math; // frames, spherical triangles, rasteriser, BVH, counter-based RNG
pub mod photometry; // RGB ↔ lux at 179 lm/W

// L1 inputs
pub mod scene; // scene.toml, OBJ/MTL, .pts, generated scenes
pub mod site; // site, solar position
pub mod weather; // EPW and WEA weather files: site + DNI/DHI records at sun-evaluation times

// L2 light
pub mod sky; // sky radiance models and the sun
pub mod sources; // sky subdivision into parallel sources; snapped sun

// L3–L5 the method
pub mod cache; // direction-keyed, memory-mapped store of projection records
pub mod hierarchy; // element quadtree keys and arena
pub mod projection; // LDI per source, visibility ratio, refinement
pub mod trace; // one BVH per geometry: rays through glazing, the glazing mirror
pub mod transfer; // direct transfer to elements

// L6 results
pub mod radiosity; // global-line interreflection operator, its solve and sensor responses
pub mod sensors; // sensor illuminance from every source, with error estimate

// L7 results over time
pub mod export; // illuminance.csv (stream, read, merge shards), .ill, metrics.csv, summary.json, surfaces.csv
pub mod metrics; // annual metrics (DA, cDA, UDI, ASE, sDA, DF) as honeybee computes them

// L8 orchestration
pub mod sequence; // one run: config, pipeline, report, outputs

// L9 command line
pub mod cli; // clap arguments → sequence

pub use error::{Error, Result};
