//! `cpg train`.

use std::path::Path;
use std::time::Instant;

use cpg_regression::PenaltyGrid;
use cpg_reservoir::{Reservoir, TrainSettings, TrainedCpg, train};

use cpg_cli::config::Config;
use cpg_cli::pipeline::prepare;

pub fn run(config: &Path, output: Option<&Path>) -> anyhow::Result<()> {
    let mut c = Config::load(config)?;
    if let Some(o) = output {
        c.output.model = o.to_owned();
    }
    let rc = c.reservoir()?.check()?;
    let p = prepare(&c)?;
    let t = &c.training;
    let settings = TrainSettings {
        washout: t.washout,
        penalties: PenaltyGrid::log10_range(t.penalty_log10.start, t.penalty_log10.step, t.penalty_log10.stop)?,
        noise_variance: t.noise_variance,
        n_noise_draws: t.noise_draws,
        noise_seed: t.noise_seed,
    };
    eprintln!("data: {}", p.description);
    let start = Instant::now();
    eprintln!("building a {}-neuron reservoir (seed {}) …", rc.n_neurons, c.reservoir.seed);
    let res = Reservoir::new(&rc, c.reservoir.seed)?;
    eprintln!(
        "training: {} samples, {} penalties × {} noise draws validated over {} free-run steps …",
        p.data.train.len(rc.n_outputs),
        settings.penalties.len(),
        settings.n_noise_draws,
        p.data.validation.len(rc.n_outputs)
    );
    let tr = train(&res, &p.data, &settings)?;
    let mut model =
        TrainedCpg::new(res, tr, settings, p.outputs, c.data.controls.clone(), p.description, c.data.rate_hz)?;
    if let Some(cycle) = p.reference_cycle {
        model = model.with_reference_cycle(cycle)?;
    }
    model.save(&c.output.model)?;
    let pv = &model.provenance;
    let best = pv.validation_curve.iter().map(|v| v.nmse).fold(f64::INFINITY, f64::min);
    println!(
        "trained in {:.2} s: penalty {:e} (validation NMSE {best:.4}, one-step training NMSE {:.2e}) → {}",
        start.elapsed().as_secs_f64(),
        pv.chosen_penalty,
        pv.train_nmse,
        c.output.model.display()
    );
    Ok(())
}
