//! `cargo xtask train`: trains experiment configurations and saves their models.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, bail};
use cpg_lab::Config;

/// `cargo xtask train`.
#[derive(Debug, clap::Args)]
pub struct TrainArgs {
    /// Which configurations of experiments/ to train: a file's name without
    /// .toml (e1, e1-paper, e4, e4-extension, …) or all (every configuration
    /// there with an `[experiment]` table).
    #[arg(long, default_value = "e1")]
    experiment: String,
    /// Reservoir seed [default: the configuration's].
    #[arg(long)]
    seed: Option<u64>,
    /// Directory for the model files [default: the model path of each configuration's output section].
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(args: &TrainArgs) -> anyhow::Result<()> {
    let dir = crate::root().join("experiments");
    let all = crate::report::reservoir_experiments()?;
    let stem = |p: &PathBuf| p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let names: Vec<String> = if args.experiment == "all" {
        all.iter().map(stem).collect()
    } else {
        vec![args.experiment.trim_end_matches(".toml").to_owned()]
    };
    for name in names {
        let path = dir.join(format!("{name}.toml"));
        if !path.is_file() {
            let known: Vec<String> = all.iter().map(stem).collect();
            bail!("no configuration {} (choose one of {} or all)", path.display(), known.join(", "));
        }
        let mut c = Config::load(&path)?;
        if let Some(s) = args.seed {
            c.reservoir.seed = s;
        }
        let model_path = match &args.out {
            Some(d) => {
                let d = if d.is_absolute() { d.clone() } else { crate::root().join(d) };
                d.join(format!("{name}-seed{}.cpg", c.reservoir.seed))
            }
            None => c.output.model.clone(),
        };
        let t = Instant::now();
        let (m, p) = cpg_lab::train::train(&c, crate::cores()).with_context(|| format!("training {name}"))?;
        m.save(&model_path)?;
        let pv = &m.provenance;
        println!(
            "{name} (seed {}): trained in {:.2} s, penalty {:.2e} (validation score {:.4}, one-step training NMSE {:.2e}) → {}",
            c.reservoir.seed,
            t.elapsed().as_secs_f64(),
            pv.chosen_penalty,
            pv.validation_curve.iter().map(|v| v.nmse).fold(f64::INFINITY, f64::min),
            pv.train_nmse,
            model_path.strip_prefix(crate::root()).unwrap_or(&model_path).display()
        );
        println!("  data: {}", p.description);
        let curve: Vec<String> =
            pv.validation_curve.iter().step_by(10).map(|v| format!("{:.0e}→{:.3}", v.penalty, v.nmse)).collect();
        println!("  validation curve (every 10th): {}", curve.join("  "));
    }
    Ok(())
}
