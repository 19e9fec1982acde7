//! Wavefront OBJ/MTL geometry through tobj. PLACEHOLDER.
