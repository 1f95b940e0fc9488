//! The README's library example, run. A second test checks that the README
//! shows exactly this code (between the markers), so the two cannot drift.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

// README-BEGIN
use cpg_lab::measure::{free_run, stability};
use cpg_lab::{Config, ControlSchedule};
use cpg_reservoir::Generator;

fn quick_start(path: &std::path::Path) -> Result<(), Box<dyn std::error::Error>> {
    let config = Config::load(path)?; // e.g. experiments/e1.toml
    let (model, _data) = cpg_lab::train::train(&config, 2)?; // the model `cpg train` writes (2 threads)
    let mut g = Generator::new(&model);
    for _ in 0..120 {
        let hip_deg = g.step(&[])?; // one step per servo tick; allocates nothing
        assert!(hip_deg[0].abs() < 90.0);
    }
    // 900 s of free run, judged against the rhythm it was taught.
    let y = free_run(&model, &ControlSchedule::none(), 108_000, None)?;
    let s = stability(&y, 1, &model.teachers[0], 0, 120.0);
    println!("period {:?} steps, accurate: {}, converged: {}", s.end.period_steps, s.accurate, s.converged);
    Ok(())
}
// README-END

#[test]
fn the_readme_library_example_runs() {
    quick_start(&cpg_tests::workspace_root().join("experiments/e1.toml")).unwrap();
}

#[test]
fn the_readme_shows_this_example_verbatim() {
    let me = std::fs::read_to_string(cpg_tests::workspace_root().join("tests/readme.rs")).unwrap();
    let code = me.split("// README-BEGIN\n").nth(1).unwrap().split("// README-END").next().unwrap();
    let readme = std::fs::read_to_string(cpg_tests::workspace_root().join("README.md")).unwrap();
    assert!(readme.contains(&format!("```rust\n{code}```")), "README.md must show tests/readme.rs between the markers");
}
