//! Generated test and benchmark scenes built in code. PLACEHOLDER.
