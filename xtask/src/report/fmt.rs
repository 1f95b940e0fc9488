//! The report's markdown and the writing of sections: their text as
//! markdown, their figures drawn, their pages and files written. The
//! sections themselves are built by the experiments (`cpg_lab::experiment`).

use std::path::Path;

use anyhow::Context;
use cpg_lab::experiment::doc::{Block, Section};

/// Markdown text built line by line.
#[derive(Debug, Default)]
pub struct Md(pub String);

impl Md {
    pub fn line(&mut self, s: impl AsRef<str>) {
        self.0.push_str(s.as_ref());
        self.0.push('\n');
    }

    pub fn blank(&mut self) {
        self.0.push('\n');
    }

    /// A table: header cells, alignment per column (`l` or `r`), rows.
    pub fn table(&mut self, head: &[&str], align: &str, rows: &[Vec<String>]) {
        let mut s = Section::default();
        s.table(head, align, rows);
        self.0.push_str(&s.markdown());
    }

    /// A section: its text here; with `dir`, its figures drawn and its pages and files written there.
    pub fn section(&mut self, s: &Section, dir: Option<&Path>) -> anyhow::Result<()> {
        self.0.push_str(&s.markdown());
        let Some(dir) = dir else { return Ok(()) };
        for b in &s.blocks {
            match b {
                Block::Figure { stem, panels, columns, size } => {
                    crate::figures::save(&dir.join(stem), panels, *columns, *size)?;
                }
                Block::Page { name, scene, gif_s } => {
                    std::fs::write(dir.join(format!("{name}.html")), scene.to_html())?;
                    if let Some(seconds) = gif_s {
                        let opts = cpg_view::GifOptions { seconds: Some(*seconds), ..Default::default() };
                        std::fs::write(dir.join(format!("{name}.gif")), scene.to_gif(&opts)?)?;
                    }
                }
                Block::File { name, bytes } => {
                    std::fs::write(dir.join(name), bytes).with_context(|| format!("writing {name}"))?;
                }
                Block::Line(_) | Block::Blank | Block::Table { .. } => {}
            }
        }
        Ok(())
    }
}
