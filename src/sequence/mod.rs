//! L8 orchestration: the one place that knows the whole order of the pipeline. One
//! timestep is written once, in [`step`]; an instant is a sequence of one step, and the
//! annual, daylight-factor and convergence runs are sequences of the same step.
//!
//! Modules in pipeline order: the run's knobs ([`config`]); the step's stages — sky and
//! sources ([`sky`]), per-direction data ([`directions`]), the operator ([`operator`]),
//! direct light onto the mesh and the sensors ([`direct`]), daylight coefficients for
//! annual steps ([`coefficients`], over the union of the steps' cuts, [`cuts`]), the stated error
//! ([`estimate`]) — and the step that runs them ([`step`]); then the sequences built from
//! it ([`instant`], [`df`], [`convergence`], [`annual`] with its [`surfaces`] export) and
//! their [`report`].

pub mod config;
pub mod sky;
pub mod directions;
pub mod operator;
pub mod direct;
pub mod cuts;
mod day_cuts;
mod day_suns;
pub mod coefficients;
pub mod estimate;
pub mod step;
pub mod step_types;
pub mod instant;
pub mod df;
pub mod convergence;
pub mod annual;
mod annual_options;
mod annual_steps;
mod day_feed;
pub mod merge;
pub mod light_paths;
mod path_pass;
pub mod compliance;
pub mod surfaces;
pub mod render;
mod render_frames; // a render run's frames: plan, frames.csv rows, resume fingerprint
pub mod report;

pub use config::{Quality, SkySpec};
pub use df::{run_df, write_df, DfResult, SensorDf};
pub use estimate::SensorValue;
pub use instant::{run_instant, write_instant, InstantResult};
pub use report::Report;
pub use step::{Engine, EngineOptions, Step, StepTime};
