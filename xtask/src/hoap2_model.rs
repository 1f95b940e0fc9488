//! `cargo xtask hoap2-model`: writes the HOAP-2's physical model from
//! the shapes of its spec, `assets/hoap2/robot.toml` (the URDF's links, the
//! MJCF, the doc's table).

use std::path::Path;

use anyhow::Context as _;
use cpg_robot::RobotSpec;
use cpg_robot::physics::{derivation_markdown, mjcf, physical_urdf};

/// The markers around the generated part of docs/hoap2-model.md.
pub const BEGIN: &str = "<!-- begin: written by `cargo xtask hoap2-model` -->\n";
pub const END: &str = "<!-- end: written by `cargo xtask hoap2-model` -->\n";

/// The three files' new texts from the URDF's current text.
pub fn texts(urdf_now: &str, doc_now: &str) -> anyhow::Result<(String, String, String)> {
    let path = Path::new("assets/hoap2/hoap2.urdf");
    let spec = RobotSpec::hoap2();
    let urdf = physical_urdf(urdf_now, path, &spec.shapes)?;
    let xml = mjcf(&urdf, path, &spec.shapes, &spec)?;
    let table = derivation_markdown(&urdf, path, &spec.shapes, &spec)?;
    let (Some(b), Some(e)) = (doc_now.find(BEGIN), doc_now.find(END)) else {
        anyhow::bail!("docs/hoap2-model.md: the markers {BEGIN:?} and {END:?} are missing");
    };
    let doc = format!("{}{BEGIN}{table}{}", &doc_now[..b], &doc_now[e..]);
    Ok((urdf, xml, doc))
}

fn write(path: &Path, text: &str) -> anyhow::Result<()> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, text).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("moving {} into place", path.display()))?;
    Ok(())
}

pub fn run() -> anyhow::Result<()> {
    let root = crate::root();
    let (urdf_path, xml_path, doc_path) =
        (root.join("assets/hoap2/hoap2.urdf"), root.join("assets/hoap2/hoap2.xml"), root.join("docs/hoap2-model.md"));
    let read = |p: &Path| std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()));
    let (urdf, xml, doc) = texts(&read(&urdf_path)?, &read(&doc_path)?)?;
    for (path, text) in [(&urdf_path, &urdf), (&xml_path, &xml), (&doc_path, &doc)] {
        write(path, text)?;
        println!("wrote {}", path.strip_prefix(&root).unwrap_or(path).display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_committed_files_are_what_the_command_writes() {
        let root = crate::root();
        let read = |p: &str| std::fs::read_to_string(root.join(p)).unwrap();
        let (urdf, xml, doc) = super::texts(&read("assets/hoap2/hoap2.urdf"), &read("docs/hoap2-model.md")).unwrap();
        let stale = "is stale: run `cargo xtask hoap2-model`";
        assert!(urdf == read("assets/hoap2/hoap2.urdf"), "assets/hoap2/hoap2.urdf {stale}");
        assert!(xml == read("assets/hoap2/hoap2.xml"), "assets/hoap2/hoap2.xml {stale}");
        assert!(doc == read("docs/hoap2-model.md"), "the table of docs/hoap2-model.md {stale}");
    }
}
