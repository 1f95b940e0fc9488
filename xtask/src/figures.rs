//! Figures in the paper's style: teacher dashed gray, model black, controls
//! dashed gray; every figure is written as PNG and SVG from the same drawing code.

use std::path::Path;
use std::sync::OnceLock;

use anyhow::{Context, bail};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::series::DashedLineSeries;

use cpg_lab::experiment::doc::{Look, Panel};

const FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
];

/// Registers DejaVu Sans for the text of the PNG figures (pure Rust rendering;
/// no system font library). SVG text needs no font file.
fn font() -> anyhow::Result<()> {
    static DONE: OnceLock<Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        let path = FONT_PATHS.iter().find(|p| Path::new(p).is_file()).ok_or_else(|| {
            format!(
                "no DejaVu Sans font found (looked in {}); install Debian's fonts-dejavu-core",
                FONT_PATHS.join(", ")
            )
        })?;
        let bytes: &'static [u8] =
            Box::leak(std::fs::read(path).map_err(|e| format!("{path}: {e}"))?.into_boxed_slice());
        plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
            .map_err(|_| format!("{path}: not a usable font"))
    })
    .clone()
    .map_err(anyhow::Error::msg)
}

fn range(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) =
        v.fold(
            (f64::INFINITY, f64::NEG_INFINITY),
            |(a, b), x| if x.is_finite() { (a.min(x), b.max(x)) } else { (a, b) },
        );
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05).max(1e-9);
    (lo - pad, hi + pad)
}

/// A y range with room above the data for the legend (a fifth of the span),
/// so that the legend box never covers a curve.
fn legend_room(y0: f64, y1: f64) -> (f64, f64) {
    (y0, y1 + 0.25 * (y1 - y0))
}

/// Ranges widened about their centres so that one unit is as many pixels on
/// both axes, for a plot area of `(w, h)` pixels (a path seen from above).
fn equal_axes(x: (f64, f64), y: (f64, f64), (w, h): (f64, f64)) -> ((f64, f64), (f64, f64)) {
    let per_px = ((x.1 - x.0) / w).max((y.1 - y.0) / h);
    let (cx, cy) = ((x.0 + x.1) / 2.0, (y.0 + y.1) / 2.0);
    ((cx - per_px * w / 2.0, cx + per_px * w / 2.0), (cy - per_px * h / 2.0, cy + per_px * h / 2.0))
}

fn draw<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, panels: &[Panel], cols: usize) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    area.fill(&WHITE).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let rows = panels.len().div_ceil(cols);
    let cells = area.split_evenly((rows, cols));
    for (panel, cell) in panels.iter().zip(cells.iter()) {
        let (x0, x1) = range(panel.curves.iter().flat_map(|c| c.points.iter().map(|p| p.0)));
        let bars = panel.curves.iter().any(|c| c.look == Look::Bars);
        let (x0, x1) = if bars { (x0 - 0.5, x1 + 0.5) } else { (x0, x1) };
        let zero = bars.then_some(0.0);
        let (y0, y1) = range(panel.curves.iter().flat_map(|c| c.points.iter().map(|p| p.1)).chain(zero));
        let labelled = panel.curves.iter().any(|c| !c.label.is_empty());
        let (y0, y1) = if labelled { legend_room(y0, y1) } else { (y0, y1) };
        let ((x0, x1), (y0, y1)) = if panel.equal_axes {
            let (w, h) = cell.dim_in_pixel();
            equal_axes((x0, x1), (y0, y1), ((w as f64 - 64.0).max(1.0), (h as f64 - 70.0).max(1.0)))
        } else {
            ((x0, x1), (y0, y1))
        };
        let mut chart = ChartBuilder::on(cell)
            .caption(&panel.title, ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(34)
            .y_label_area_size(48)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| anyhow::anyhow!("{e:?}"))?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(panel.x_label.as_str())
            .y_desc(panel.y_label.as_str())
            .label_style(("sans-serif", 12))
            .axis_desc_style(("sans-serif", 13))
            .draw()
            .map_err(|e| anyhow::anyhow!("{e:?}"))?;
        let gray = RGBColor(128, 128, 128);
        let light = RGBColor(185, 185, 185);
        let red = RGBColor(170, 20, 20);
        for c in &panel.curves {
            let style = match c.look {
                Look::Teacher => gray.stroke_width(2),
                Look::Control | Look::Data => light.stroke_width(2),
                Look::Model | Look::Marks => BLACK.stroke_width(1),
                Look::Bars => RGBColor(90, 90, 90).filled(),
                Look::Held => red.stroke_width(3),
            };
            let pts = c.points.iter().copied();
            let drawn = match c.look {
                Look::Teacher => chart.draw_series(DashedLineSeries::new(pts, 6, 4, style)),
                Look::Control => chart.draw_series(DashedLineSeries::new(pts, 5, 4, style)),
                Look::Model | Look::Data | Look::Held => chart.draw_series(LineSeries::new(pts, style)),
                Look::Bars => chart.draw_series(
                    c.points
                        .iter()
                        .map(|&(x, y)| Rectangle::new([(x - 0.4, 0.0), (x + 0.4, y)], style))
                        .collect::<Vec<_>>(),
                ),
                Look::Marks => {
                    chart.draw_series(c.points.iter().map(|&p| Circle::new(p, 3, BLACK.filled())).collect::<Vec<_>>())
                }
            }
            .map_err(|e| anyhow::anyhow!("{e:?}"))?;
            if !c.label.is_empty() {
                drawn.label(c.label.as_str()).legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
            }
        }
        if panel.curves.iter().any(|c| !c.label.is_empty()) {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(160, 160, 160))
                .label_font(("sans-serif", 12))
                .draw()
                .map_err(|e| anyhow::anyhow!("{e:?}"))?;
        }
    }
    area.present().map_err(|e| anyhow::anyhow!("{e:?}"))?;
    Ok(())
}

/// Draws `panels` in a grid of `cols` columns and writes `<stem>.png` and `<stem>.svg`.
pub fn save(stem: &Path, panels: &[Panel], cols: usize, size: (u32, u32)) -> anyhow::Result<()> {
    if panels.is_empty() || cols == 0 {
        bail!("a figure needs panels");
    }
    font()?;
    let png = stem.with_extension("png");
    let svg = stem.with_extension("svg");
    {
        let area = BitMapBackend::new(&png, size).into_drawing_area();
        draw(&area, panels, cols).with_context(|| format!("drawing {}", png.display()))?;
    }
    {
        let area = SVGBackend::new(&svg, size).into_drawing_area();
        draw(&area, panels, cols).with_context(|| format!("drawing {}", svg.display()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_axes_give_a_unit_the_same_length_on_both_axes() {
        // A path 100 mm wide and 3000 mm long in a 600 × 300 px plot: 10 mm per px on both.
        let ((x0, x1), (y0, y1)) = equal_axes((0.0, 100.0), (0.0, 3000.0), (600.0, 300.0));
        assert!(((x1 - x0) / 600.0 - (y1 - y0) / 300.0).abs() < 1e-12);
        assert!((x0 + x1 - 100.0).abs() < 1e-9 && y0 <= 0.0 && y1 >= 3000.0);
    }

    #[test]
    fn the_legend_has_room_above_the_curves() {
        let (lo, hi) = legend_room(-1.0, 1.0);
        assert_eq!(lo, -1.0);
        assert!(hi >= 1.0 + 0.2 * 2.0, "{hi}");
    }
}
