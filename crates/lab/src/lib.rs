//! # cpg-lab
//!
//! What an experiment is, for users and for the report alike:
//!
//! - [`config`]: the TOML configuration that `cpg train` reads and that every
//!   file in `experiments/` is written in (reference: `docs/config.md`).
//! - [`prepare`]: from a configuration to training data: motions read,
//!   channels selected (names, globs, groups: [`channels`]) and normalised,
//!   seamless loops cut, the training sequence (blocks, repeats, morphs or a
//!   tempo), the validation run (the paper's NMSE or our orbit score) and the
//!   teachers, one per control setting.
//! - [`train`]: a model from a configuration, within a stated memory budget.
//! - [`schedule`]: control inputs over time.
//! - [`measure`]: one definition each of a rhythm's period and amplitude,
//!   *decayed*, *accurate*, *converged*, and of recovery after a push.
//! - [`tune`]: a seeded random search for settings that keep the rhythm.
//! - [`stream`]: a trained CPG ticking at any rate, optionally mapped onto a
//!   robot within its limits (`cpg stream`, the Python `Stream`).
//! - [`scene`]: what a trained CPG looks like: teacher, model and robot as a
//!   `cpg_view::Scene` (rendered as HTML or GIF by `cpg-view`).
//! - [`experiment`]: E1–E6 of wyffels & Schrauwen (2009) and the comparison
//!   of generator families (Vakulenko et al. 2017), each returning typed
//!   results that derive `Serialize`, with their claims ([`experiment::claim`]:
//!   the paper's words, what was measured, the rule and the verdict) and
//!   the conditions validation and test each used ([`experiment::conditions`]).
//! - [`stats`]: the aggregates over seeds (median, range, a count with its
//!   95 % interval), defined once.
//!
//! ```no_run
//! # fn main() -> Result<(), cpg_lab::Error> {
//! use cpg_lab::{Config, experiment};
//! let config = Config::load("experiments/e1.toml".as_ref())?;
//! let (model, _data) = cpg_lab::train::train(&config, 2)?;  // the model `cpg train` writes
//! model.save(&config.output.model)?;
//! let outcome = experiment::run(&config, experiment::Options::default(), &experiment::Quiet)?;
//! let (passed, seeds) = outcome.passed();
//! # Ok(()) }
//! ```
//!
//! Nothing here prints or knows where the checkout is: paths come from the
//! configuration files, resolved against their own directory.

pub mod channels;
pub mod config;
mod error;
pub mod experiment;
pub mod fit;
pub mod format;
pub mod measure;
pub mod memory;
pub mod prepare;
pub mod retarget;
pub mod run;
pub mod scene;
pub mod schedule;
pub mod stats;
pub mod stream;
pub mod train;
pub mod travel;
pub mod tune;

pub use config::Config;

/// Runs `work` on a rayon pool of its own with `threads` threads, so that
/// every parallel loop inside uses that many and no more, whatever the
/// global pool holds. Every thread of the pool carries the calling thread's
/// watch ([`cpg_reservoir::watch`]), if it has one: cancelling it stops
/// the free runs, validations and trainings inside at their next check, and
/// the work returns [`cpg_reservoir::Error::Cancelled`] (in [`Error::Reservoir`]).
pub fn in_pool<T: Send>(threads: usize, work: impl FnOnce() -> Result<T> + Send) -> Result<T> {
    let mut builder = rayon::ThreadPoolBuilder::new().num_threads(threads.max(1));
    if let Some(watch) = cpg_reservoir::watch::current() {
        builder = builder.start_handler(move |_| cpg_reservoir::watch::set_for_this_thread(Some(watch.clone())));
    }
    let pool = builder.build().map_err(|e| Error::Unusable(format!("a pool of {threads} threads: {e}")))?;
    pool.install(work)
}
pub use error::{Error, Result};
pub use schedule::ControlSchedule;
