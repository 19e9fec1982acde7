//! L5 direct transfer (Besuievsky & Martín §5.3): for every source s and lit leaf i of its
//! record, E_i += E_s ⊙ w_s,i, w = (Ap_i/A_i)·VR_i with glazing transmission. The paper's
//! B_i += ρ_i E (Ap_i/A_i) VR_i is ρ_i times this irradiance; the irradiance is kept, sun and
//! sky apart (§6.1 needs them apart), and pushed down to the leaves of the union hierarchy.

use crate::hierarchy::Hierarchy;
use crate::photometry::Rgb;
use crate::projection::DirectionRecord;
use crate::sources::Source;

/// Direct irradiance per element of a hierarchy (RGB, W/m²), sun and sky apart.
#[derive(Clone, Debug, Default)]
pub struct DirectIrradiance {
    /// From the sun, per element (same indexing as `Hierarchy::elements`).
    pub sun: Vec<Rgb>,
    /// From the sky and the ground glow, per element.
    pub sky: Vec<Rgb>,
}

/// Merges the refinements of all records into `hierarchy` and returns each element's
/// direct irradiance, pushed down so every leaf holds the total it receives. Sources and
/// records are paired by index and summed in order, so the result does not depend on
/// how the projections were scheduled.
pub fn transfer(
    hierarchy: &mut Hierarchy,
    sources: &[Source],
    records: &[&DirectionRecord],
) -> DirectIrradiance {
    for r in records {
        for l in &r.leaves {
            hierarchy.insert(l.key);
        }
    }
    let n = hierarchy.elements.len();
    let mut out = DirectIrradiance {
        sun: vec![Rgb::ZERO; n],
        sky: vec![Rgb::ZERO; n],
    };
    for (s, r) in sources.iter().zip(records) {
        let target = if s.is_sun() {
            &mut out.sun
        } else {
            &mut out.sky
        };
        for l in &r.leaves {
            let i = hierarchy.get(l.key).expect("inserted above") as usize;
            target[i] += s.normal_irradiance * l.weight;
        }
    }
    // Push: arena order puts parents before children.
    for i in 0..n {
        if let Some(p) = hierarchy.elements[i].parent {
            let p = p as usize;
            let (ps, pk) = (out.sun[p], out.sky[p]);
            out.sun[i] += ps;
            out.sky[i] += pk;
        }
    }
    out
}

/// Power (W, RGB) of irradiance `e` over the leaves of `hierarchy`.
pub fn leaf_power(hierarchy: &Hierarchy, e: &[Rgb]) -> Rgb {
    hierarchy
        .leaves()
        .map(|i| e[i as usize] * hierarchy.elements[i as usize].area)
        .fold(Rgb::ZERO, |a, b| a + b)
}
