//! Training a CPG from a configuration: what `cpg train` and every
//! experiment run, so that both compute the same model.

use cpg_regression::PenaltyGrid;
use cpg_reservoir::{Precision, Reservoir, ReservoirConfig, TrainSettings, TrainedCpg};

use crate::config::Config;
use crate::error::{Error, Result};
use crate::prepare::{Prepared, prepare};

/// The memory a training run may use, MiB (estimated before anything is allocated).
pub const MEMORY_BUDGET_MIB: u64 = 4096;

/// The reservoir of a configuration: the preset with the overrides applied.
pub fn reservoir_config(c: &Config, n_outputs: usize) -> Result<ReservoirConfig> {
    c.reservoir
        .resolve(n_outputs, &c.data.controls)
        .map_err(|e| c.error(&format!("reservoir.{}", e.field), format!("{}; {}", e.value, e.expected)))
}

/// The training settings of a configuration.
pub fn train_settings(c: &Config) -> Result<TrainSettings> {
    // The grid's size and the draws are bounded by `Config::check`.
    let t = &c.training;
    let p = t.penalty_log10;
    Ok(TrainSettings {
        washout: t.washout,
        penalties: PenaltyGrid::log10_range(p.start, p.step, p.stop)?,
        noise_variance: t.noise_variance,
        n_noise_draws: t.noise_draws,
        noise_seed: t.noise_seed,
        teacher_noise: t.teacher_noise,
        prefer_larger_within: t.prefer_larger_within,
        self_fed: t.self_fed,
    })
}

/// Estimated peak memory of training, MiB: the harvested states, the Gram
/// matrix and its eigendecomposition, the batched validation states and noise.
pub fn memory_estimate_mib(rc: &ReservoirConfig, s: &TrainSettings, p: &Prepared) -> u64 {
    let n = rc.n_neurons as f64;
    let d = rc.n_outputs as f64;
    let rows = p.data.train.len(rc.n_outputs) as f64;
    let steps = p.data.validation.len(rc.n_outputs) as f64;
    let word = match rc.precision {
        Precision::F32 => 4.0,
        Precision::F64 => 8.0,
    };
    let cols = s.penalties.len() as f64 * s.n_noise_draws as f64;
    // Training on the own output adds up to a share free / (free + forced) of the rows per round, and stacking copies them once.
    let sf = s.self_fed;
    let grown = if sf.rounds == 0 {
        1.0
    } else {
        2.0 * (1.0 + sf.rounds as f64 * sf.free_steps as f64 / (sf.free_steps + sf.forced_steps) as f64)
    };
    let harvest = grown * rows * (n + d) * 8.0;
    let gram = 4.0 * n * n * 8.0 + s.penalties.len() as f64 * n * d * 8.0;
    let validation = 3.0 * cols * n * word + s.n_noise_draws as f64 * steps * n * word + cols * steps * d * 8.0;
    ((harvest + gram + validation) / (1024.0 * 1024.0)).ceil() as u64
}

/// Trains a model on prepared data with the reservoir seed `seed`, its
/// validation on `threads` threads (the bits do not depend on it).
pub fn train_prepared(c: &Config, p: &Prepared, seed: u64, threads: usize) -> Result<TrainedCpg> {
    train_prepared_on(c, p, seed, None, threads)
}

/// The reservoir `c` draws for `seed` on prepared data `p`.
pub fn reservoir_for(c: &Config, p: &Prepared, seed: u64) -> Result<Reservoir> {
    let rc = reservoir_config(c, p.outputs.len())?.check().map_err(cpg_reservoir::Error::from)?;
    Ok(Reservoir::new(&rc, seed)?)
}

/// [`train_prepared`] on a reservoir already drawn (by [`reservoir_for`] for
/// the same configuration and seed: the same model, without drawing the
/// weights and their spectral radius again); `None` draws it.
pub fn train_prepared_on(
    c: &Config,
    p: &Prepared,
    seed: u64,
    drawn: Option<Reservoir>,
    threads: usize,
) -> Result<TrainedCpg> {
    let rc = reservoir_config(c, p.outputs.len())?.check().map_err(cpg_reservoir::Error::from)?;
    let settings = train_settings(c)?;
    let mib = memory_estimate_mib(&rc, &settings, p);
    if mib > MEMORY_BUDGET_MIB {
        return Err(Error::Budget {
            what: format!(
                "training {} neurons on {} samples with {} penalties × {} noise draws",
                rc.n_neurons,
                p.data.train.len(rc.n_outputs),
                settings.penalties.len(),
                settings.n_noise_draws
            ),
            needed_mib: mib,
            limit_mib: MEMORY_BUDGET_MIB,
            hint: "fewer neurons, samples, penalties or noise draws",
        });
    }
    let reservoir = match drawn {
        Some(r) if r.seed() == seed && r.config() == rc.get() => r,
        _ => Reservoir::new(&rc, seed)?,
    };
    let training = match c.training.trainer {
        crate::config::Trainer::Ridge => cpg_reservoir::train_on(&reservoir, &p.data, &settings, threads)?,
        crate::config::Trainer::Force => {
            cpg_reservoir::train_force_on(&reservoir, &p.data, &settings, &c.training.force, threads)?
        }
    };
    let model = TrainedCpg::new(
        reservoir,
        training,
        settings,
        p.data.scoring.clone(),
        p.outputs.clone(),
        c.data.controls.clone(),
        p.description.clone(),
        c.data.rate_hz,
    )?;
    let model = model.with_teachers(p.teachers.clone())?;
    Ok(match &p.skeleton_asf {
        Some(asf) => model.with_skeleton(asf.clone()),
        None => model,
    })
}

/// Prepares the data of `c` and trains with its own seed, on `threads` threads.
pub fn train(c: &Config, threads: usize) -> Result<(TrainedCpg, Prepared)> {
    let p = prepare(c)?;
    let m = train_prepared(c, &p, c.reservoir.seed, threads)?;
    Ok((m, p))
}

/// The worst best validation score a model may have and still count as
/// trained: a flat line at the teacher's mean scores 1.
pub const UNSTABLE_SCORE: f64 = 1.0;

/// Why a trained model does not follow its teacher, when it does not: its
/// best validation score is worse than [`UNSTABLE_SCORE`] (or not a number).
/// `cpg train` refuses to write such a model and the Python package refuses
/// to return it (both unless asked to keep it); this is the one message both give.
pub fn unstable(m: &TrainedCpg) -> Option<String> {
    let pv = &m.provenance;
    let best = pv.validation_curve.iter().map(|v| v.nmse).fold(f64::INFINITY, f64::min);
    (best.is_nan() || best > UNSTABLE_SCORE).then(|| {
        format!(
            "the best validation score is {best:.4} (penalty {:.2e}), worse than {UNSTABLE_SCORE} (a flat line at the mean scores 1): the free run does not follow the teacher",
            pv.chosen_penalty
        )
    })
}

/// Whether the chosen penalty is the first or last of the grid (the search may want a wider grid).
pub fn penalty_at_edge(m: &TrainedCpg) -> bool {
    let v = m.provenance.settings.penalties.values();
    let p = m.provenance.chosen_penalty;
    v.len() > 1 && (v.first() == Some(&p) || v.last() == Some(&p))
}
