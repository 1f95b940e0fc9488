//! # cpg-compare
//!
//! The three generator families of this workspace behind one step interface,
//! and the measures that compare them on the same data:
//!
//! - [`PatternGenerator`]: `step(out)` and `step_held(held, out)` (an outside
//!   force holds the outputs for one step), implemented by
//!   [`ReservoirCpg`] (cpg-reservoir, its own dynamics with output feedback),
//!   [`CentralizedCpg`] and [`SwitchedCpg`] (cpg-centralized, driven by phase
//!   or Hopf centers) and [`DmpCpg`] (cpg-dmp, a canonical phase plus a
//!   spring–damper). None of them allocates in a step.
//! - [`positions`]: marker positions from forward kinematics (world or body
//!   frame), joint angles from a generator turned into positions, and trials
//!   glued into one continuous sequence.
//! - [`measures`]: mean 3-D distance (mm), relative integral error (L1 and L2)
//!   and ErrABS, with phase alignment.
//! - [`fit`]: the centralized fitting recipe used in every comparison, the
//!   segmented fit glued by the switching module, and the Table 1 table.
//!
//! How a generator answers a push is measured one level up, in `cpg-lab`,
//! with the same definition as the reservoir's E3.
//!
//! The family crates do not know each other or this crate; each can be used alone.

pub mod fit;
mod generator;
pub mod measures;
pub mod positions;

pub use generator::{CentralizedCpg, Clock, DmpCpg, PatternGenerator, ReservoirCpg, SwitchedCpg, run};

/// What can go wrong.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Data of the wrong shape, empty, or not finite.
    #[error("invalid data: {0}")]
    Data(String),
    /// A parameter out of range.
    #[error("invalid parameter: {0}")]
    Parameter(String),
    /// From the reservoir CPG.
    #[error(transparent)]
    Reservoir(#[from] cpg_reservoir::Error),
    /// From the centralized networks.
    #[error(transparent)]
    Centralized(#[from] cpg_centralized::Error),
    /// From the DMP.
    #[error(transparent)]
    Dmp(#[from] cpg_dmp::Error),
    /// From the motion-capture layer.
    #[error(transparent)]
    Mocap(#[from] cpg_mocap::Error),
}

/// Result alias for this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
