//! The help texts, pinned: `cpg --help` and every subcommand's. A change to
//! a flag or its text shows up here; `UPDATE_SNAPSHOTS=1 cargo test -p cpg-cli
//! --test help` rewrites the files after a deliberate change.

#![allow(clippy::unwrap_used, clippy::expect_used)] // tests fail loudly

use std::path::PathBuf;
use std::process::Command;

/// `cpg` itself and every subcommand its help lists (so a new command gets a snapshot).
fn commands() -> Vec<String> {
    let top = help("");
    let listed = top.split("Commands:").nth(1).unwrap_or_default().split("\n\n").next().unwrap_or_default();
    let mut all = vec![String::new()];
    all.extend(listed.lines().filter_map(|l| l.split_whitespace().next()).filter(|c| *c != "help").map(str::to_owned));
    assert!(all.len() > 5, "subcommands listed in `cpg --help`: {all:?}");
    all
}

fn help(sub: &str) -> String {
    let mut c = Command::new(env!("CARGO_BIN_EXE_cpg"));
    if !sub.is_empty() {
        c.arg(sub);
    }
    let o = c.arg("--help").env("COLUMNS", "100").output().unwrap();
    assert!(o.status.success());
    String::from_utf8(o.stdout).unwrap()
}

#[test]
fn help_texts_match_their_snapshots() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/help");
    let mut changed = Vec::new();
    for sub in commands() {
        let sub = sub.as_str();
        let name = if sub.is_empty() { "cpg".to_owned() } else { format!("cpg-{sub}") };
        let path = dir.join(format!("{name}.txt"));
        let now = help(sub);
        if std::env::var_os("UPDATE_SNAPSHOTS").is_some() {
            std::fs::write(&path, &now).unwrap();
            continue;
        }
        let pinned = std::fs::read_to_string(&path).unwrap_or_default();
        if pinned != now {
            changed.push(format!("{name}:\n--- pinned\n{pinned}\n--- now\n{now}"));
        }
    }
    assert!(changed.is_empty(), "help texts changed (UPDATE_SNAPSHOTS=1 to accept):\n{}", changed.join("\n"));
}

#[test]
fn each_command_states_its_own_defaults() {
    assert!(help("generate").contains("[default: 30]"));
    assert!(help("evaluate").contains("[default: 900]"));
    let h = help("hoap2");
    assert!(h.matches("[default: hoap2]").count() == 2 && h.contains("assets/hoap2/cmu35_to_hoap2.tsv"), "{h}");
    assert!(help("evaluate").lines().count() > 15, "evaluate has a long description");
}
