//! L6 diffuse interreflection by global lines (Besuievsky & Martín §6, with the paper's
//! references \[10\] and \[15\]): a fixed operator over a mesh, estimated once per geometry
//! with bundles of parallel lines through the same LDI machinery as the direct light
//! ([`transport`]), then solved deterministically for each timestep, warm-started from the
//! previous one; the sensors read it through a sparse gather matrix, and daylight
//! coefficients ([`response`]) turn it into per-direction sensor responses. Rays go
//! through the run's one [`crate::trace::Tracer`], shared with the direct sensors.
//!
//! A local-line hierarchical Monte Carlo solver (Bekaert et al. 1998) lived here until
//! issue 12: it was biased by 30–45 % deep in rooms and was removed; its measured
//! comparison is in `docs/design.md`.

mod bundles; // the operator estimate: line bundles through LDIs, glazing mirror links
pub mod coefficients; // grey daylight coefficients of many directions, blocked adjoint
mod coarse; // the operator one level coarser, for the discretisation estimate
mod gather; // sensor gather matrix, and the sensors' reading of a solution
mod link_sum; // the operator build's sum of links over directions, spilled as sorted runs
pub mod mesh; // the fixed mesh: unknowns, point → row, area averages onto it
pub mod response; // adjoint daylight coefficients
mod solve; // Gauss–Seidel, stop rule, warm start
mod sparse; // sparse RGB rows, held or read in place from a cache record
mod spread; // the batched apply's kernel: a held response spread over directions
mod strata; // equal-area direction strata of the bundles
pub mod transport; // the Transport type, its parameters and build

pub use coefficients::{AdjointBlock, DirectionTerms};
pub use gather::TransportSensor;
pub use mesh::Mesh;
pub use response::{DirectionResponse, SensorResponse};
pub use solve::{TransportReport, TransportState};
pub use sparse::Buf;
pub use transport::{Transport, TransportParams, TransportStats};

use crate::photometry::Rgb;

pub(crate) use crate::hierarchy::child_of;

/// Reflectances are clamped to this (the system is singular at ρ = 1).
pub const MAX_RHO: f64 = 0.999;

/// Per-channel square root of a variance (negative rounding noise → 0).
pub(crate) fn sqrt3(v: Rgb) -> Rgb {
    v.max(Rgb::ZERO).to_array().map(f64::sqrt).into()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hierarchy::split;
    use glam::DVec3;

    #[test]
    fn child_of_matches_the_geometric_split() {
        let v = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.3, 0.0),
            DVec3::new(0.4, 1.7, 0.1),
        ];
        for (u, w) in [(0.1, 0.2), (0.7, 0.1), (0.2, 0.6), (0.3, 0.3), (0.45, 0.45)] {
            let b = [1.0 - u - w, u, w];
            let p = v[0] * b[0] + v[1] * b[1] + v[2] * b[2];
            let mut nb = b;
            let k = child_of(&mut nb);
            let c = split(v)[k as usize];
            let q = c[0] * nb[0] + c[1] * nb[1] + c[2] * nb[2];
            assert!((p - q).length() < 1e-12, "{k}: {p} vs {q}");
        }
    }
}
