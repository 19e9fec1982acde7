//! The memory the daylight coefficients' preparation may take: what it holds besides the
//! adjoint responses, and how many bytes of responses fit under `--max-memory`.

use super::RESPONSE_MAX_BYTES;
use crate::error::{Error, Result};
use crate::scene::Scene;

/// Bytes one direction in flight takes while its coefficients are computed, at LDI
/// resolution `resolution` (an estimate: the LDI's pixel offsets and fragments, 16 bytes
/// per pixel of its longer side squared, and its record and mesh weights, smaller). On
/// the generated building, the coefficients' stage peaks about 130 MB above the steps
/// with two threads at 2048 pixels: this allows 128 MB.
pub(super) fn direction_bytes(resolution: u32) -> u64 {
    resolution as u64 * resolution as u64 * 16
}

/// Bytes the scene, its ray tracer (BVH) and its projection copy take, estimated per
/// triangle.
pub(super) fn scene_bytes(scene: &Scene) -> u64 {
    scene.triangles.len() as u64 * 600 + scene.sensors.len() as u64 * 64
}

/// Bytes of adjoint responses held at once: what the cap `max_memory` (0: none) leaves
/// beside what is held, at most [`RESPONSE_MAX_BYTES`] unless the user gave the cap
/// (`given`), and at least `one_block` (the smallest adjoint block). What is held is
/// `held` (from sizes: the operator, the scene, the coefficients and the directions in
/// flight), or `resident` (the same with the process's resident memory for the first two)
/// when that is larger.
///
/// Why a given cap is filled: it is room the user set aside, and fewer, larger blocks
/// each go over the directions once (the 100 000-triangle model's 104 blocks under 4G
/// spent most of their profile recomputing the same directions' mesh weights; on the
/// 10 000-triangle building with 9 540 sensors, 2 blocks instead of 22 took 0.96× the
/// time). The machine's default cap is not: its 128 MB ceiling keeps a large model's
/// year within a few times Radiance's memory.
///
/// # Errors
/// `held + one_block` is above the cap: an input error naming `--max-memory` and the
/// smallest cap that fits (from sizes alone, so the same inputs name the same cap).
pub fn adjoint_budget(
    max_memory: u64,
    given: bool,
    held: u64,
    resident: u64,
    one_block: u64,
) -> Result<u64> {
    if max_memory == 0 {
        return Ok(RESPONSE_MAX_BYTES);
    }
    let needed = held + one_block;
    if needed > max_memory {
        return Err(Error::arg(
            "--max-memory",
            crate::memory::format_size(max_memory),
            format!(
                "the daylight coefficients need at least {} (held {}, one block of adjoint \
                 responses {}); give --max-memory {} or more",
                crate::memory::format_size(needed),
                crate::memory::format_size(held),
                crate::memory::format_size(one_block),
                crate::memory::format_size(needed),
            ),
        ));
    }
    let free = max_memory - held.max(resident.min(max_memory));
    // A given cap keeps a tenth of itself free for what the sizes do not count (the
    // allocator's slack, the batch's terms and sums), since blocks fill the rest.
    let ceiling = if given {
        free.saturating_sub(max_memory / 10)
    } else {
        RESPONSE_MAX_BYTES
    };
    Ok(free.min(ceiling).max(one_block))
}

#[cfg(test)]
mod tests {
    use super::*;

    const M: u64 = 1 << 20;
    const G: u64 = 1 << 30;

    #[test]
    fn a_given_cap_is_filled_but_the_default_one_stops_at_the_ceiling() {
        // 1 GiB held, 100 MiB resident (less than held: held counts), 4 GiB cap.
        let given = adjoint_budget(4 * G, true, G, 100 * M, 10 * M).unwrap();
        assert_eq!(given, 3 * G - 4 * G / 10);
        let default = adjoint_budget(4 * G, false, G, 100 * M, 10 * M).unwrap();
        assert_eq!(default, RESPONSE_MAX_BYTES);
        // No cap: the ceiling, whatever is held.
        assert_eq!(
            adjoint_budget(0, true, 100 * G, 0, 10 * M).unwrap(),
            RESPONSE_MAX_BYTES
        );
        // A resident figure above the sizes shrinks the blocks, never below one.
        assert_eq!(
            adjoint_budget(4 * G, true, G, 2 * G, 10 * M).unwrap(),
            2 * G - 4 * G / 10
        );
        assert_eq!(
            adjoint_budget(2 * G, true, G, 2 * G, 10 * M).unwrap(),
            10 * M
        );
    }

    #[test]
    fn a_cap_below_one_block_names_the_cap_needed() {
        let e = adjoint_budget(G, true, G, 0, 10 * M)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--max-memory"), "{e}");
        assert!(e.contains(&crate::memory::format_size(G + 10 * M)), "{e}");
        // The same for a default cap: the smallest cap is from sizes alone.
        let d = adjoint_budget(G, false, G, 5 * G, 10 * M)
            .unwrap_err()
            .to_string();
        assert_eq!(e, d);
    }
}
