//! L8 orchestration: the one place that knows the whole order of the pipeline. A single
//! instant is a sequence of one step.

pub mod annual;
pub mod config;
pub mod convergence;
pub mod df;
pub mod directions;
pub mod instant;
pub mod operator;
pub mod report;
pub mod surfaces;

pub use config::{Quality, SkySpec};
pub use df::{run_df, write_df, DfResult, SensorDf};
pub use instant::{run_instant, write_instant, InstantResult, SensorValue};
pub use report::Report;
