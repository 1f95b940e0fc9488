//! # cpg-regression
//!
//! Linear least squares with a ridge penalty, built for choosing the penalty
//! by validation:
//!
//! - [`RidgePath`] centres the data (the bias is never penalised), forms the
//!   Gram matrix once and eigendecomposes it, after which the solution for any
//!   penalty costs one `N × N` by `N × D` product instead of a new factorisation.
//! - [`PenaltyGrid`] holds candidate penalties; [`PenaltyGrid::wyffels_2009`] is
//!   the paper's grid `10^(1 : −0.1 : −8)`.
//! - [`sweep`] and [`sweep_chunked`] score candidates in parallel (rayon) and
//!   return the scores in candidate order, identical whatever the thread count,
//!   provided the scoring closure is deterministic.
//! - [`nmse`]: mean squared error normalised by the target's variance.
//!
//! The crate knows nothing of reservoirs or motion data: callers bring the
//! feature matrix and a scoring closure. All linear algebra runs sequentially
//! in `f64` (faer with `Par::Seq`) so that results do not depend on the number
//! of threads; parallelism is across candidates.

mod error;
mod exp;
mod ridge;
mod sweep;

pub mod fixed;
pub use error::{Error, Result};
pub use exp::exp_det;
pub use ridge::{Readout, RidgePath, STILL_VARIANCE, nmse, ridge_direct};
pub use sweep::{PenaltyGrid, sweep, sweep_chunked};
