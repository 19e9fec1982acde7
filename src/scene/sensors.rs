//! Radiance `.pts` sensor files: `x y z dx dy dz` per line. PLACEHOLDER.
