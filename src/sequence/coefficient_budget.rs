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

/// Bytes of adjoint responses held at once: [`RESPONSE_MAX_BYTES`], or less when the cap
/// `max_memory` (0: none) minus what is held is smaller; at least `one_block` (the
/// smallest adjoint block). What is held is `held` (from sizes: the operator, the scene,
/// the coefficients and the directions in flight), or `resident` (the same with the
/// process's resident memory for the first two) when that is larger.
///
/// # Errors
/// `held + one_block` is above the cap: an input error naming `--max-memory` and the
/// smallest cap that fits (from sizes alone, so the same inputs name the same cap).
pub fn adjoint_budget(max_memory: u64, held: u64, resident: u64, one_block: u64) -> Result<u64> {
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
    Ok(free.min(RESPONSE_MAX_BYTES).max(one_block))
}
