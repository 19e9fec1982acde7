//! # daystep — incremental time-series daylight engine
//!
//! The method is Besuievsky & Martín, "A Hierarchical Algorithm for Radiosity Daylighting":
//! the sky is subdivided into spherical triangles, each a parallel light source (E = L̂·ω),
//! plus the sun; each source is scan-converted into a Layered Depth Image whose per-patch
//! visibility ratio VR = n_v/n_p drives quad-tree refinement and the direct transfer
//! B_i += ρ_i E (Ap_i/A_i) VR_i. Interreflection is a global-line operator over a mesh,
//! estimated once per geometry through the same LDIs and solved for every timestep.
//!
//! One timestep, in pipeline order ([`sequence::step`] runs it; an instant is a sequence
//! of one step, and annual, daylight-factor and convergence runs are sequences of it):
//!
//! ```text
//! scene.toml ─ OBJ/MTL ─ .pts ─► scene            weather file (EPW/WEA) ─► weather
//!                                  │                                          │
//!  1 time, site ─► site::solar_position ─► sky (Perez | CIE | Preetham, ground glow)
//!  2               sources (octahedral sky/ground quadtree nodes + snapped sun)
//!  3 per source:   projection (LDI, VR refinement) + sensors::node_response ──► cache
//!                  (keyed by direction; memory-mapped records)       (keys, records, store)
//!  4               transfer (element irradiance) ─► averaged onto the interreflection mesh
//!  5               radiosity (global-line operator, built once ──► cache; warm-started
//!                  Gauss–Seidel solve per step, or daylight coefficients)
//!  6               sensors: direct from the cached responses, one level coarser for the
//!                  error, + the operator's indirect gather
//!  7               stated error (sequence::estimate) ─► sensors.csv, report.json
//!  over time:      metrics (DA, cDA, UDI, ASE, sDA, DF) ─► export (CSV, .ill, JSON)
//! ```
//!
//! Units: metres; scene frame x east, y north, z up; RGB radiance W·sr⁻¹·m⁻²; irradiance
//! W/m²; illuminance lux = 179 × (0.265 R + 0.670 G + 0.065 B).
//!
//! Layers (a module uses only lower layers; `tests/layers.rs` checks it):
//! L0 error, files, math, photometry, memory, allocator · L1 site, scene, weather (scene
//! and weather may use site) · L2 sky, sources · L3 hierarchy · L4 projection · L5
//! transfer, cache, trace · L6 sensors, radiosity · L7 metrics, export, render (export may
//! use metrics) · L8 sequence · L9 cli.
#![warn(missing_docs)]
#![deny(unsafe_code)] // exceptions: cache::store::map_readonly, cache::record::release_map, allocator::trim, the AVX2 dispatch of sequence::coefficient_sums and radiosity::response, and math::bvh's traversal (its AVX2 dispatch and uninitialised stack)

// Modules in pipeline order (rustfmt.toml keeps this order).

// L0 foundations
pub mod error; // Error enum: input errors name file, line, value
pub mod files; // atomic writes, text reads with paths
pub mod math; // frames, spherical triangles, rasteriser, BVH, counter-based RNG
pub mod photometry; // RGB ↔ lux at 179 lm/W
pub mod memory; // the memory cap (--max-memory), resident memory from /proc
pub mod allocator; // glibc's trim and mapping thresholds, raised once per process

// L1 inputs
pub mod scene; // scene.toml, OBJ/MTL, .pts, a builder for scenes in code
pub mod site; // site, solar position
pub mod weather; // EPW and WEA weather files: site + DNI/DHI records at sun-evaluation times

// L2 light
pub mod sky; // sky radiance models and the sun
pub mod sources; // sky subdivision into parallel sources; snapped sun

// L3–L5 the method
pub mod hierarchy; // element quadtree keys and arena
pub mod projection; // LDI per source, visibility ratio, refinement
pub mod transfer; // direct transfer to elements
pub mod cache; // direction-keyed, memory-mapped store of projection records
pub mod trace; // the one ray tracer: one BVH per geometry, glazing τ(θ) and mirror

// L6 results
pub mod radiosity; // global-line interreflection operator, its solve and gather
pub mod sensors; // sensor illuminance from every source, with error estimate

// L7 results over time, and images
pub mod metrics; // annual metrics (DA, cDA, UDI, ASE, sDA, DF) as honeybee computes them
pub mod export; // illuminance.csv (stream, read, merge shards), .ill, metrics.csv, summary.json, surfaces.csv
pub mod render; // final gather of a step's solution into images; EXR, PNG, falsecolor, previews, glare

// L8 orchestration
pub mod sequence; // one timestep (step), and the runs made of it

// L9 command line
pub mod cli; // clap arguments → validated configuration → one file per command

pub use error::{Error, Result};
