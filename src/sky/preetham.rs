//! PLACEHOLDER sky model.
