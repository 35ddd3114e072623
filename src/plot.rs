//! SVG plots (plotters' SVG backend), shared by the commands that draw.

use std::path::Path;

use plotters::coord::types::RangedCoordf64;
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
        legend(&mut chart, SeriesLabelPosition::UpperRight).map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The legend every plot draws: framed, on a translucent white background.
fn legend<'a, 'b: 'a>(chart: &mut Chart<'a, 'b>, position: SeriesLabelPosition) -> Result<(), String> {
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())
}

/// One line of a line plot: (x, mean, standard error) points.
pub struct Series<'a> {
    pub name: &'a str,
    pub points: Vec<(f64, f64, f64)>,
}

/// Mean ± standard error against x, one line and shaded band per series (as the paper's
/// Fig. 2, 8 and 10).
pub fn mean_se_plot(path: &Path, title: &str, x_label: &str, y_label: &str, series: &[Series]) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let root = SVGBackend::new(path, (720, 480)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let x_min = series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).fold(f64::INFINITY, f64::min);
    let x_max = series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).fold(f64::NEG_INFINITY, f64::max);
    let xs = if x_min.is_finite() { (x_min - 0.2)..(x_max + 0.2) } else { 0.0..1.0 };
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in series.iter().flat_map(|s| &s.points).filter(|p| p.1.is_finite()) {
        lo = lo.min(p.1 - p.2);
        hi = hi.max(p.1 + p.2);
    }
    if !lo.is_finite() {
        (lo, hi) = (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.08).max(1e-9);
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(xs, (lo - pad)..(hi + pad))
        .map_err(|e| err(&e))?;
    chart.configure_mesh().x_desc(x_label).y_desc(y_label).draw().map_err(|e| err(&e))?;
    for (k, s) in series.iter().enumerate() {
        let colour = PALETTE[k % PALETTE.len()];
        let pts: Vec<_> = s.points.iter().filter(|p| p.1.is_finite()).copied().collect();
        let mut band: Vec<(f64, f64)> = pts.iter().map(|p| (p.0, p.1 + p.2)).collect();
        band.extend(pts.iter().rev().map(|p| (p.0, p.1 - p.2)));
        chart.draw_series(std::iter::once(Polygon::new(band, colour.mix(0.15).filled()))).map_err(|e| err(&e))?;
        chart
            .draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.1)), colour.stroke_width(2)))
            .map_err(|e| err(&e))?
            .label(s.name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], colour.stroke_width(2)));
        chart.draw_series(pts.iter().map(|p| Circle::new((p.0, p.1), 3, colour.filled()))).map_err(|e| err(&e))?;
    }
    // Keep the legend away from where the lines end.
    let ends_high = series.iter().filter_map(|s| s.points.last()).map(|p| p.1).sum::<f64>()
        / series.len().max(1) as f64
        > (lo + hi) / 2.0;
    legend(&mut chart, if ends_high { SeriesLabelPosition::LowerRight } else { SeriesLabelPosition::UpperRight })
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// Grouped bars: for each group (a legend entry), one bar per category.
pub fn bar_chart(
    path: &Path,
    title: &str,
    y_label: &str,
    categories: &[String],
    groups: &[(String, Vec<f64>)],
) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let root = SVGBackend::new(path, (720, 480)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let max = groups.iter().flat_map(|g| g.1.iter().copied()).fold(1.0f64, f64::max);
    let n = categories.len().max(1);
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..n as f64, 0.0..max * 1.15)
        .map_err(|e| err(&e))?;
    let cats = categories.to_vec();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(n * 2 + 1)
        .x_label_formatter(&|x| {
            let k = x.floor() as usize;
            if (x - k as f64 - 0.5).abs() < 0.01 { cats.get(k).cloned().unwrap_or_default() } else { String::new() }
        })
        .y_desc(y_label)
        .draw()
        .map_err(|e| err(&e))?;
    let width = 0.8 / groups.len().max(1) as f64;
    for (gi, (name, values)) in groups.iter().enumerate() {
        let colour = PALETTE[gi % PALETTE.len()];
        chart
            .draw_series(values.iter().enumerate().map(|(k, &v)| {
                let x0 = k as f64 + 0.1 + gi as f64 * width;
                Rectangle::new([(x0, 0.0), (x0 + width * 0.95, v)], colour.filled())
            }))
            .map_err(|e| err(&e))?
            .label(name.as_str())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], colour.filled()));
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight).map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}
