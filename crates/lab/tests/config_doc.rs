//! `docs/config.md` lists every key the parser accepts, and the errors speak
//! the file's language.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // tests fail loudly

use std::collections::BTreeMap;
use std::path::Path;

use cpg_lab::Config;
use cpg_lab::experiment::families::FamiliesConfig;
use serde_reflection::{ContainerFormat, Format, Samples, Tracer, TracerConfig, VariantFormat};

fn doc() -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/config.md")).unwrap()
}

/// Every dotted key path reachable from `root` in the traced registry.
fn paths(registry: &BTreeMap<String, ContainerFormat>, root: &str) -> Vec<String> {
    fn walk(reg: &BTreeMap<String, ContainerFormat>, f: &Format, prefix: &str, out: &mut Vec<String>) {
        match f {
            Format::TypeName(name) => {
                match reg.get(name) {
                    Some(ContainerFormat::Struct(fields)) => {
                        for field in fields {
                            let p =
                                if prefix.is_empty() { field.name.clone() } else { format!("{prefix}.{}", field.name) };
                            out.push(p.clone());
                            walk(reg, &field.value, &p, out);
                        }
                    }
                    // An externally tagged enum: a table named by the variant
                    // (unit variants are values, `activation = "tanh"`, not keys).
                    Some(ContainerFormat::Enum(variants)) => {
                        for v in variants.values().filter(|v| !matches!(v.value, VariantFormat::Unit)) {
                            let p = format!("{prefix}.{}", v.name);
                            out.push(p.clone());
                            if let VariantFormat::NewType(inner) = &v.value {
                                walk(reg, inner, &p, out);
                            }
                        }
                    }
                    _ => {}
                }
            }
            Format::Option(inner) | Format::Seq(inner) => walk(reg, inner, prefix, out),
            Format::TupleArray { content, .. } => walk(reg, content, prefix, out),
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk(registry, &Format::TypeName(root.into()), "", &mut out);
    out.sort();
    out.dedup();
    out
}

fn trace<T: serde::de::DeserializeOwned>(root: &str) -> Vec<String> {
    let mut tracer = Tracer::new(TracerConfig::default());
    // Every variant of the experiment's test (an enum is traced one variant a pass).
    tracer.trace_simple_type::<cpg_lab::config::ExperimentTest>().unwrap();
    tracer.trace_simple_type::<cpg_reservoir::Activation>().unwrap();
    tracer.trace_simple_type::<cpg_reservoir::Precision>().unwrap();
    tracer.trace_simple_type::<cpg_reservoir::Preset>().unwrap();
    tracer.trace_simple_type::<cpg_lab::config::Protocol>().unwrap();
    tracer.trace_simple_type::<cpg_lab::config::ScoreKind>().unwrap();
    tracer.trace_simple_type::<cpg_lab::config::Normalise>().unwrap();
    tracer.trace_simple_type::<cpg_lab::config::Trainer>().unwrap();
    tracer.trace_type::<T>(&Samples::new()).unwrap();
    let registry = tracer.registry().unwrap();
    paths(&registry, root)
}

#[test]
fn every_key_the_parser_accepts_is_documented() {
    let doc = doc();
    let mut missing = Vec::new();
    let keys: Vec<String> =
        trace::<Config>("Config").into_iter().chain(trace::<FamiliesConfig>("FamiliesConfig")).collect();
    assert!(keys.len() > 80, "traced only {} keys", keys.len());
    for k in &keys {
        // A key is documented in backticks, as a key (`training.score`) or as a table (`[data]`).
        if !doc.contains(&format!("`{k}`")) && !doc.contains(&format!("`[{k}]`")) {
            missing.push(k.clone());
        }
    }
    assert!(missing.is_empty(), "keys the parser accepts but docs/config.md does not list: {missing:?}");
}

#[test]
fn every_experiment_configuration_parses() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments");
    let mut n = 0;
    for sub in [dir.clone(), dir.join("tried")] {
        for e in std::fs::read_dir(&sub).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "toml") && p.file_name().is_some_and(|f| f != "families.toml") {
                let c = Config::load(&p).unwrap_or_else(|e| panic!("{e}"));
                assert!(c.experiment.is_some(), "{} has no [experiment]", p.display());
                n += 1;
            }
        }
    }
    assert!(n >= 8, "{n} configurations");
    FamiliesConfig::load(&dir.join("families.toml")).unwrap();
}

#[test]
fn errors_name_the_key_its_line_and_what_it_takes() {
    let file = Path::new("x.toml");
    let base = "[data]\nskeleton = \"s.asf\"\nchannels = [\"lfemur.rx\"]\n\n[[data.segments]]\nmotion = \"m.amc\"\n\n[output]\nmodel = \"m.cpg\"\n";
    let err = |text: &str| Config::from_toml(text, file, Path::new(".")).unwrap_err().to_string();
    assert!(Config::from_toml(base, file, Path::new(".")).is_ok());
    let e = err(&format!("{base}\n[training]\npenalty_log10 = [1, -8]\n"));
    assert!(
        e.contains("x.toml:12") && e.contains("`training.penalty_log10`") && e.contains("{start, step, stop}"),
        "{e}"
    );
    let e = err(&base.replace("[output]", "[output]\nmodle = 1"));
    assert!(e.contains("unknown field `modle`"), "{e}");
    let e = err(&format!("{base}\n[training]\nscore = \"fast\"\n"));
    assert!(e.contains("`training.score`") && e.contains("nmse") && e.contains("orbit"), "{e}");
    let e = err(&format!("\u{feff}{base}\n[reservoir]\ntempo_input = \"u\"\n"));
    assert!(e.contains("`reservoir.tempo_input`") && e.contains("not a control input"), "{e}");
    let e = err(&base.replace("skeleton = \"s.asf\"", "skeleton = \"s.asf\"\nrate_hz = 0.001"));
    assert!(e.contains("`data.rate_hz`") && e.contains("1 to"), "{e}");
    let e = err(&format!("{base}\n[training]\nscore = \"orbit\"\n"));
    assert!(e.contains("[training.orbit]"), "{e}");
    let exp = "\n[experiment]\nid = \"E1\"\ntitle = \"t\"\nprotocol = \"ours\"\n";
    let e = err(&format!("{base}{exp}[experiment.test.juggling]\nrun_s = 3\n"));
    assert!(e.contains("`experiment.test`") && e.contains("stability") && e.contains("coupling"), "{e}");
    let e = err(&format!("{base}{exp}[experiment.test.stability]\nlong_run_s = 1e9\n"));
    assert!(e.contains("`experiment.test.stability.long_run_s`") && e.contains("86400"), "{e}");
    let e = err(&format!("{base}{exp}[experiment.test.stability]\n[experiment.test.gaits]\nrun_s = 3\n"));
    assert!(e.contains("`experiment.test`"), "{e}");
    // A retargeted walk: segments give tempos, not motions.
    let rt = "[data]\nchannels = [\"lleg_joint_4.rx\"]\n[data.retarget]\ntrials = [\"w.amc\"]\n[[data.segments]]\ntempo = 3\n[output]\nmodel = \"m.cpg\"\n";
    let e = err(rt);
    assert!(e.contains("`data.segments[0].tempo`") && e.contains("0.5 to 2"), "{e}");
    let e = err(&rt.replace("tempo = 3", "motion = \"m.amc\""));
    assert!(e.contains("`data.segments[0].motion`") && e.contains("give its tempo instead"), "{e}");
    let e = err(&rt.replace("tempo = 3", "tempo = 1\nstand = true"));
    assert!(e.contains("`data.segments[0].tempo`") && e.contains("standing segment"), "{e}");
    let e = err(&rt.replace("tempo = 3", "stand = true"));
    assert!(e.contains("`data.segments`") && e.contains("at least one rhythm"), "{e}");
    let e = err(&base.replace("motion = \"m.amc\"", "motion = \"m.amc\"\nstand = true"));
    assert!(e.contains("`data.segments`") && e.contains("at least one rhythm"), "{e}");
    let e = err(&base.replace("motion = \"m.amc\"", "motion = \"m.amc\"\ntempo = 1"));
    assert!(e.contains("`data.segments[0].tempo`") && e.contains("only with [data.retarget]"), "{e}");
    let e = err(&base.replace("channels = [\"lfemur.rx\"]", "channels = [\"lfemur.rx\"]\ncontrols = [\"a,b\"]"));
    assert!(e.contains("`data.controls[0]`") && e.contains("commas"), "{e}");
}

#[test]
fn a_configuration_written_back_reads_the_same() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments");
    let c = Config::load(&dir.join("e5.toml")).unwrap();
    let out = tempfile::tempdir().unwrap();
    let text = c.to_toml(out.path()).unwrap();
    let path = out.path().join("again.toml");
    std::fs::write(&path, &text).unwrap();
    let again = Config::load(&path).unwrap();
    let canon = |p: &Path| p.canonicalize().unwrap_or_else(|_| p.to_owned());
    assert_eq!(canon(again.data.skeleton.as_ref().unwrap()), canon(c.data.skeleton.as_ref().unwrap()));
    assert_eq!(canon(&again.data.segments[1].motion), canon(&c.data.segments[1].motion));
    let robot = |c: &Config| match &c.experiment.as_ref().unwrap().test {
        cpg_lab::config::ExperimentTest::Gaits(g) => g.robot.clone().unwrap(),
        other => panic!("e5 is a gaits experiment, not {}", other.kind()),
    };
    assert_eq!(canon(&robot(&again).urdf), canon(&robot(&c).urdf));
    assert_eq!(canon(&robot(&again).map), canon(&robot(&c).map));
    let paper = |c: &Config| c.experiment.as_ref().and_then(|e| e.paper_config.clone()).unwrap();
    assert_eq!(canon(&paper(&again)), canon(&paper(&c)));
    let (mut a, mut b) = (again.clone(), c.clone());
    for x in [&mut a, &mut b] {
        if let Some(cpg_lab::config::ExperimentTest::Gaits(g)) = x.experiment.as_mut().map(|e| &mut e.test)
            && let Some(r) = g.robot.as_mut()
        {
            r.urdf = Default::default();
            r.map = Default::default();
        }
        if let Some(e) = x.experiment.as_mut() {
            e.paper_config = None;
        }
        x.source = Default::default();
        x.data.skeleton = Default::default();
        x.output.model = Default::default();
        for s in &mut x.data.segments {
            s.motion = Default::default();
        }
    }
    assert_eq!(a, b, "every other field survives the round trip");
}
