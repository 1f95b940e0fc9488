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

/// Every TOML example of the README and of `docs/` that is a whole
/// configuration (it has `[data]`) trains as written: placed in a folder of
/// the checkout (its paths are relative to the file), `cpg train`'s training
/// gives a model whose free run follows its teacher (`unstable` is what
/// `cpg train` refuses). The docs' minimal file once did not.
#[test]
fn every_configuration_in_the_docs_trains() {
    let root = cpg_tests::workspace_root();
    let mut pages = vec![root.join("README.md")];
    for e in std::fs::read_dir(root.join("docs")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "md") {
            pages.push(p);
        }
    }
    pages.sort();
    let mut trained = 0;
    for page in pages {
        let text = std::fs::read_to_string(&page).unwrap();
        for (k, block) in text.split("```toml\n").skip(1).enumerate() {
            let toml = block.split("```").next().unwrap();
            if !toml.lines().any(|l| l.trim() == "[data]") {
                continue;
            }
            let dir = tempfile::tempdir_in(&root).unwrap();
            let file = dir.path().join("example.toml");
            std::fs::write(&file, toml).unwrap();
            let where_ = format!("{} (TOML block {})", page.display(), k + 1);
            let c = cpg_lab::Config::load(&file).unwrap_or_else(|e| panic!("{where_}: {e}"));
            let (model, _) = cpg_lab::train::train(&c, 2).unwrap_or_else(|e| panic!("{where_}: {e}"));
            assert_eq!(cpg_lab::train::unstable(&model), None, "{where_}");
            trained += 1;
        }
    }
    assert!(trained >= 1, "the docs hold at least the minimal configuration");
}
