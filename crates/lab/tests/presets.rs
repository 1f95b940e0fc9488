//! The presets `cpg_lab::fit` trains with stay what the experiments they
//! name use: every setting a preset gives equals the file's.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // tests fail loudly

use std::path::PathBuf;

fn table(text: &str) -> toml::Table {
    text.parse().expect("TOML")
}

fn experiment(name: &str) -> toml::Table {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../experiments").join(name);
    table(&std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display())))
}

/// Every value of `preset` (recursively) is the same in `file`, but `except`.
fn same(preset: &toml::Table, file: &toml::Table, at: &str, except: &[&str]) {
    for (k, v) in preset {
        let key = if at.is_empty() { k.clone() } else { format!("{at}.{k}") };
        if except.contains(&key.as_str()) {
            continue;
        }
        let w = file.get(k).unwrap_or_else(|| panic!("the experiment has no `{key}`, which the preset sets"));
        match (v, w) {
            (toml::Value::Table(a), toml::Value::Table(b)) => same(a, b, &key, except),
            _ => assert_eq!(v, w, "`{key}`: the preset says {v}, the experiment {w}"),
        }
    }
}

#[test]
fn the_one_segment_preset_is_e1s_protocol() {
    same(&table(cpg_lab::fit::PRESET_ONE), &experiment("e1.toml"), "", &[]);
}

#[test]
fn the_several_segments_preset_is_e5_extensions_protocol() {
    same(&table(cpg_lab::fit::PRESET_SEVERAL), &experiment("e5-extension.toml"), "", &[]);
}
