//! SVG plots (plotters' SVG backend), shared by the commands that draw.

use std::path::Path;

use plotters::prelude::*;

/// Region colours, in order.
pub const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

/// One named group of 2-D points.
pub struct PointGroup<'a> {
    pub name: &'a str,
    pub points: Vec<(f64, f64)>,
}

/// One panel of a scatter figure.
pub struct ScatterPanel<'a> {
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub groups: Vec<PointGroup<'a>>,
}

fn range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return 0.0..1.0;
    }
    let pad = ((hi - lo) * 0.05).max(1.0);
    (lo - pad)..(hi + pad)
}

/// A figure of scatter panels side by side in a grid of `cols` columns.
pub fn scatter_grid(path: &Path, title: &str, panels: &[ScatterPanel], cols: usize) -> Result<(), String> {
    let rows = panels.len().div_ceil(cols);
    let root = SVGBackend::new(path, (420 * cols as u32, 380 * rows as u32 + 40)).into_drawing_area();
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root.titled(title, ("sans-serif", 22)).map_err(|e| err(&e))?;
    let areas = root.split_evenly((rows, cols));
    for (panel, area) in panels.iter().zip(areas) {
        let xs = range(panel.groups.iter().flat_map(|g| g.points.iter().map(|p| p.0)));
        let ys = range(panel.groups.iter().flat_map(|g| g.points.iter().map(|p| p.1)));
        let mut chart = ChartBuilder::on(&area)
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(xs, ys)
            .map_err(|e| err(&e))?;
        chart.configure_mesh().x_desc(panel.x_label).y_desc(panel.y_label).draw().map_err(|e| err(&e))?;
        for (k, g) in panel.groups.iter().enumerate() {
            let colour = PALETTE[k % PALETTE.len()];
            chart
                .draw_series(g.points.iter().map(|&p| Circle::new(p, 2, colour.mix(0.6).filled())))
                .map_err(|e| err(&e))?
                .label(g.name)
                .legend(move |(x, y)| Circle::new((x + 5, y), 4, colour.filled()));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}
