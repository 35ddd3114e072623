//! SVG plots (plotters' SVG backend), shared by the commands that draw.

use std::path::Path;

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// Region colours, in order.
pub const PALETTE: [RGBColor; 6] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(230, 159, 0),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
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

/// An SVG drawing written to `path`, owner-only whatever the umask (the file is made 0600
/// before the backend truncates and fills it, which keeps its mode).
fn svg(path: &Path, size: (u32, u32)) -> Result<SVGBackend<'_>, String> {
    crate::private_files::create_output(path).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(SVGBackend::new(path, size))
}

/// A figure of scatter panels side by side in a grid of `cols` columns.
pub fn scatter_grid(path: &Path, title: &str, panels: &[ScatterPanel], cols: usize) -> Result<(), String> {
    let rows = panels.len().div_ceil(cols);
    let root = svg(path, (420 * cols as u32, 380 * rows as u32 + 40))?.into_drawing_area();
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root.titled(title, ("sans-serif", 22)).map_err(|e| err(&e))?;
    let areas = root.split_evenly((rows, cols));
    for (panel, area) in panels.iter().zip(areas) {
        let xs = range(panel.groups.iter().flat_map(|g| g.points.iter().map(|p| p.0)));
        let ys = range(panel.groups.iter().flat_map(|g| g.points.iter().map(|p| p.1)));
        let ys = ys.start..ys.end + (ys.end - ys.start) * legend_headroom(panel.groups.len());
        let (x_span, y_span) = (xs.end - xs.start, ys.end - ys.start);
        let mut chart = ChartBuilder::on(&area)
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(xs, ys)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc(panel.x_label)
            .y_desc(panel.y_label)
            .x_label_formatter(&|x| tick_label(*x, x_span))
            .y_label_formatter(&|y| tick_label(*y, y_span))
            .draw()
            .map_err(|e| err(&e))?;
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

/// One line of a line plot: (x, mean, half-width of its band) points.
pub struct Series<'a> {
    pub name: &'a str,
    pub points: Vec<(f64, f64, f64)>,
}

/// A line plot of means with bands against an integer x (iterations).
pub struct LinePlot<'a> {
    /// Names the measure and the data (pilot or real sessions, simulated trials).
    pub title: &'a str,
    pub x_label: &'a str,
    /// With its unit.
    pub y_label: &'a str,
    /// What the shaded band is (a legend entry): "± 1 s.e. over sessions".
    pub band: &'a str,
    /// The measure's least possible value (0 for a distance, a cost or a density): a band
    /// reaching below it is cut there, and the legend says so.
    pub floor: Option<f64>,
    pub series: Vec<Series<'a>>,
}

impl LinePlot<'_> {
    /// The lowest band end (cut at the floor) and the highest, over every series; none
    /// without a finite point.
    pub fn data_range(&self) -> Option<(f64, f64)> {
        let points = self.series.iter().flat_map(|s| &s.points).filter(|p| p.1.is_finite() && p.2.is_finite());
        let low = |p: &(f64, f64, f64)| self.floor.map_or(p.1 - p.2, |f| (p.1 - p.2).max(f));
        let lo = points.clone().map(low).fold(f64::INFINITY, f64::min);
        let hi = points.map(|p| p.1 + p.2).fold(f64::NEG_INFINITY, f64::max);
        lo.is_finite().then_some((lo, hi))
    }
}

/// Tick labels with as many decimals as the ticks' spacing (about a tenth of the axis'
/// span) needs: no "-14000.0", no "2.0" where "2" is meant.
fn tick_label(v: f64, span: f64) -> String {
    let step = (span / 10.0).max(1e-12);
    let decimals = (-step.log10()).ceil().clamp(0.0, 6.0) as usize;
    let text = format!("{v:.decimals$}");
    // "-0" reads as a value below zero.
    if text.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        text.trim_start_matches('-').into()
    } else {
        text
    }
}

/// Room above the data for a legend of `entries` lines (a fraction of the data's span), so
/// that the legend never covers a point.
fn legend_headroom(entries: usize) -> f64 {
    0.09 * (entries as f64 + 1.0)
}

/// Means with shaded bands against integer x, one line per series (as the paper's Fig. 2, 8
/// and 10): ticks at the integers, the legend above the data, the band named in it.
pub fn mean_se_plot(path: &Path, plot: &LinePlot) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let root = svg(path, (760, 500))?.into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    draw_lines(&root, plot, 17, None).map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// Line plots of means with bands (as [`mean_se_plot`]) in a grid of `cols` columns under a
/// title; with `shared_y` (panels of one measure) every panel's y axis spans all their data,
/// so that panels compare at a glance.
pub fn line_grid(path: &Path, title: &str, plots: &[LinePlot], cols: usize, shared_y: bool) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let rows = plots.len().div_ceil(cols);
    let root = svg(path, (560 * cols as u32, 400 * rows as u32 + 40))?.into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root.titled(title, ("sans-serif", 22)).map_err(|e| err(&e))?;
    let ranges = plots.iter().filter_map(LinePlot::data_range);
    let shared = ranges.reduce(|a, b| (a.0.min(b.0), a.1.max(b.1))).filter(|_| shared_y);
    for (plot, area) in plots.iter().zip(root.split_evenly((rows, cols))) {
        draw_lines(&area, plot, 15, shared).map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// One line plot in `area`; its y axis spans `y_range` (the data's own when none).
fn draw_lines<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    plot: &LinePlot,
    caption: u32,
    y_range: Option<(f64, f64)>,
) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let finite = || plot.series.iter().flat_map(|s| &s.points).filter(|p| p.1.is_finite() && p.2.is_finite());
    let x_min = finite().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let x_max = finite().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
    let (x_min, x_max) = if x_min.is_finite() { (x_min.floor(), x_max.ceil()) } else { (0.0, 1.0) };
    let low = |p: &(f64, f64, f64)| plot.floor.map_or(p.1 - p.2, |f| (p.1 - p.2).max(f));
    let cut = plot.floor.is_some_and(|f| finite().any(|p| p.1 - p.2 < f));
    let (lo, hi) = y_range.or_else(|| plot.data_range()).unwrap_or((0.0, 1.0));
    let span = (hi - lo).max(1e-9);
    let top = hi + span * legend_headroom(plot.series.len() + 1);
    let bottom = lo - span * 0.05;
    let mut chart = ChartBuilder::on(area)
        .caption(plot.title, ("sans-serif", caption))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(72)
        .build_cartesian_2d(x_min - 0.3..x_max + 0.3, bottom..top)
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .x_desc(plot.x_label)
        .y_desc(plot.y_label)
        // At most one label per integer: plotters then steps by 1, 2 or 5, all integers.
        .x_labels(((x_max - x_min) as usize + 1).min(13))
        .x_label_formatter(&|x| {
            if (x - x.round()).abs() < 1e-6 { format!("{}", x.round() as i64) } else { String::new() }
        })
        .y_label_formatter(&|y| tick_label(*y, top - bottom))
        .draw()
        .map_err(|e| err(&e))?;
    for (k, s) in plot.series.iter().enumerate() {
        let pts: Vec<_> = s
            .points
            .iter()
            .filter(|p| p.1.is_finite() && p.2.is_finite())
            .map(|p| (p.0, p.1, low(p), p.1 + p.2))
            .collect();
        draw_band_line(&mut chart, s.name, PALETTE[k % PALETTE.len()], &pts)?;
    }
    let band = match plot.floor.filter(|_| cut) {
        Some(f) => format!("{}, cut at {f}, the least value", plot.band),
        None => plot.band.to_string(),
    };
    draw_legend(&mut chart, &band, SeriesLabelPosition::UpperRight)
}

/// A chart of f64 axes on any backend.
type AnyChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// One series as a shaded band from low to high, a line and its points, named in the
/// legend; `pts` are (x, y, low, high).
fn draw_band_line<DB: DrawingBackend>(
    chart: &mut AnyChart<'_, DB>,
    name: &str,
    colour: RGBColor,
    pts: &[(f64, f64, f64, f64)],
) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let mut band: Vec<(f64, f64)> = pts.iter().map(|p| (p.0, p.3)).collect();
    band.extend(pts.iter().rev().map(|p| (p.0, p.2)));
    chart.draw_series(std::iter::once(Polygon::new(band, colour.mix(0.15).filled()))).map_err(|e| err(&e))?;
    chart
        .draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.1)), colour.stroke_width(2)))
        .map_err(|e| err(&e))?
        .label(name)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], colour.stroke_width(2)));
    chart.draw_series(pts.iter().map(|p| Circle::new((p.0, p.1), 3, colour.filled()))).map_err(|e| err(&e))?;
    Ok(())
}

/// The legend, with an entry saying what the shaded bands are.
fn draw_legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut AnyChart<'a, DB>,
    band: &str,
    position: SeriesLabelPosition,
) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let grey = RGBColor(120, 120, 120);
    chart
        .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
        .map_err(|e| err(&e))?
        .label(format!("shaded: {band}"))
        .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 16, y + 5)], grey.mix(0.3).filled()));
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| err(&e))?;
    Ok(())
}

/// One line of a power curve: (participants, power, interval low, interval high) points.
pub struct PowerSeries<'a> {
    pub name: &'a str,
    pub points: Vec<(f64, f64, f64, f64)>,
}

/// Power (a share of studies, 0–1) against the number of participants, one line per series
/// with its interval shaded (`band` names it), the conventional 80 % target and the 5 %
/// significance level dashed; ticks at the sizes planned.
pub fn power_plot(path: &Path, title: &str, band: &str, series: &[PowerSeries]) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let root = svg(path, (1000, 500))?.into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root.titled(title, ("sans-serif", 17)).map_err(|e| err(&e))?;
    // The legend beside the chart, so that the axis ends at 100 %.
    let (root, beside) = root.split_horizontally(640);
    // The sizes planned, equally spaced (they usually double), labelled with their values.
    let mut sizes: Vec<f64> = series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).collect();
    sizes.sort_by(f64::total_cmp);
    sizes.dedup();
    let at = |n: f64| sizes.iter().position(|&s| s == n).unwrap_or(0) as f64;
    let last = sizes.len().saturating_sub(1) as f64;
    let top = 1.0;
    let mut chart = ChartBuilder::on(&root)
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(60)
        .build_cartesian_2d(-0.4..last + 0.4, 0.0..top)
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .x_desc("participants in the study")
        .y_desc("power (share of studies with p < .05)")
        .x_labels(sizes.len().clamp(2, 13))
        .x_label_formatter(&|x| {
            let i = x.round();
            if (x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < sizes.len() {
                format!("{}", sizes[i as usize])
            } else {
                String::new()
            }
        })
        .y_labels(11)
        .y_label_formatter(&|y| format!("{:.0} %", y * 100.0))
        .draw()
        .map_err(|e| err(&e))?;
    let mut entries = Vec::new();
    let (x_min, x_max, pad) = (0.0, last, 0.4);
    let grey = RGBColor(120, 120, 120);
    for (level, name) in [(0.8, "80 % (a common target)"), (0.05, "5 % (the significance level)")] {
        chart
            .draw_series(DashedLineSeries::new(
                [(x_min - pad, level), (x_max + pad, level)],
                6,
                4,
                grey.stroke_width(1),
            ))
            .map_err(|e| err(&e))?;
        entries.push((Mark::Dashed(grey), name.to_string()));
    }
    for (k, s) in series.iter().enumerate() {
        let pts: Vec<_> = s
            .points
            .iter()
            .filter(|p| p.1.is_finite() && p.2.is_finite() && p.3.is_finite())
            .map(|p| (at(p.0), p.1, p.2, p.3))
            .collect();
        draw_band_line(&mut chart, s.name, PALETTE[k % PALETTE.len()], &pts).map_err(|e| err(&e))?;
        entries.push((Mark::Line(PALETTE[k % PALETTE.len()]), s.name.to_string()));
    }
    entries.push((Mark::Band(RGBColor(120, 120, 120)), format!("shaded: {band}")));
    side_legend(&beside, &entries).map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// A legend entry's mark.
enum Mark {
    Line(RGBColor),
    Dashed(RGBColor),
    Band(RGBColor),
    Bar(RGBColor),
}

/// A legend in an area of its own beside a chart: one entry per line, its mark and its text
/// (long texts wrap at the area's width).
fn side_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    entries: &[(Mark, String)],
) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let font = ("sans-serif", 13).into_font().color(&BLACK);
    let width = area.dim_in_pixel().0 as usize;
    // About 7 pixels a character at 13 px.
    let per_line = width.saturating_sub(50) / 7;
    let mut y = 40;
    for (mark, text) in entries {
        let (x0, x1) = (8, 32);
        match mark {
            Mark::Line(c) => area.draw(&PathElement::new(vec![(x0, y), (x1, y)], c.stroke_width(2))),
            Mark::Dashed(c) => area
                .draw(&PathElement::new(vec![(x0, y), (x0 + 9, y)], c.stroke_width(1)))
                .and_then(|_| area.draw(&PathElement::new(vec![(x0 + 15, y), (x1, y)], c.stroke_width(1)))),
            Mark::Band(c) => area.draw(&Rectangle::new([(x0, y - 5), (x1, y + 5)], c.mix(0.3).filled())),
            Mark::Bar(c) => area.draw(&Rectangle::new([(x0 + 6, y - 6), (x1 - 6, y + 6)], c.filled())),
        }
        .map_err(|e| err(&e))?;
        let mut line = String::new();
        for word in text.split(' ') {
            if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > per_line {
                area.draw(&Text::new(line.clone(), (x1 + 8, y - 7), font.clone())).map_err(|e| err(&e))?;
                line.clear();
                y += 17;
            }
            if !line.is_empty() {
                line.push(' ');
            }
            line += word;
        }
        area.draw(&Text::new(line, (x1 + 8, y - 7), font.clone())).map_err(|e| err(&e))?;
        y += 24;
    }
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
    let root = svg(path, (860, 480))?.into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root.titled(title, ("sans-serif", 20)).map_err(|e| err(&e))?;
    // The legend beside the chart: the axis ends at the data's range (1 for shares).
    let (root, beside) = root.split_horizontally(700);
    let max = groups.iter().flat_map(|g| g.1.iter().copied()).fold(1.0f64, f64::max);
    let n = categories.len().max(1);
    let top = if max <= 1.0 { 1.0 } else { max * 1.05 };
    let mut chart = ChartBuilder::on(&root)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..n as f64, 0.0..top)
        .map_err(|e| err(&e))?;
    let cats = categories.to_vec();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .light_line_style(TRANSPARENT)
        .x_labels(n * 2 + 1)
        .x_label_formatter(&|x| {
            let k = x.floor() as usize;
            if (x - k as f64 - 0.5).abs() < 0.01 { cats.get(k).cloned().unwrap_or_default() } else { String::new() }
        })
        .y_desc(y_label)
        .y_label_formatter(&|y| tick_label(*y, top))
        .draw()
        .map_err(|e| err(&e))?;
    let width = 0.8 / groups.len().max(1) as f64;
    let mut entries = Vec::new();
    for (gi, (name, values)) in groups.iter().enumerate() {
        let colour = PALETTE[gi % PALETTE.len()];
        chart
            .draw_series(values.iter().enumerate().map(|(k, &v)| {
                let x0 = k as f64 + 0.1 + gi as f64 * width;
                Rectangle::new([(x0, 0.0), (x0 + width * 0.95, v)], colour.filled())
            }))
            .map_err(|e| err(&e))?;
        entries.push((Mark::Bar(colour), name.clone()));
    }
    side_legend(&beside, &entries).map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// The pooled α evidence curve (relative to its maximum), the estimate and its interval.
pub struct PooledEvidence {
    pub curve: Vec<(f64, f64)>,
    pub alpha: f64,
    pub low: f64,
    pub high: f64,
}

/// The α evidence curves (log evidence relative to each maximum, against α on a log axis):
/// one thin grey line per session, the pooled curve bold with its support interval shaded,
/// the support threshold −`drop` dashed, and each protocol α as a vertical line.
pub fn alpha_plot(
    path: &Path,
    title: &str,
    sessions: &[Vec<(f64, f64)>],
    pooled: Option<&PooledEvidence>,
    protocol: &[f64],
    drop: f64,
) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let root = svg(path, (960, 480))?.into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root.titled(title, ("sans-serif", 17)).map_err(|e| err(&e))?;
    // The legend beside the chart, so that the axis ends at the curves' maximum.
    let (root, beside) = root.split_horizontally(700);
    let mut entries = Vec::new();
    let xs: Vec<f64> =
        sessions.iter().flatten().chain(pooled.iter().flat_map(|p| &p.curve)).map(|p| p.0.log2()).collect();
    let (x0, x1) =
        (xs.iter().copied().fold(f64::INFINITY, f64::min), xs.iter().copied().fold(f64::NEG_INFINITY, f64::max));
    let (x0, x1) = if x0 < x1 { (x0, x1) } else { (-2.0, 8.0) };
    let floor = -4.0 * drop.max(1.0) - 2.0;
    let clip = |pts: &[(f64, f64)]| -> Vec<(f64, f64)> {
        pts.iter().filter(|(_, y)| *y >= floor).map(|(x, y)| (x.log2(), *y)).collect()
    };
    let top = 0.5;
    let mut chart = ChartBuilder::on(&root)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, floor..top)
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .x_desc("α (log scale)")
        .y_desc("log evidence − its maximum")
        .y_label_formatter(&|y| tick_label(*y, 0.5 - floor))
        .x_labels((x1 - x0).round() as usize + 1)
        .x_label_formatter(&|x| {
            let a = 2f64.powf(*x);
            if a < 1.0 { format!("{a:.2}") } else { format!("{a:.0}") }
        })
        .draw()
        .map_err(|e| err(&e))?;
    let grey = RGBColor(150, 150, 150);
    if let Some(p) = pooled {
        let (l, h) = (p.low.log2(), p.high.log2());
        chart
            .draw_series(std::iter::once(Rectangle::new([(l, floor), (h, 0.0)], PALETTE[0].mix(0.12).filled())))
            .map_err(|e| err(&e))?;
    }
    // One session: its curve is the bold one, named for what it is.
    let single = sessions.len() == 1;
    for s in sessions.iter().filter(|_| !single) {
        chart.draw_series(LineSeries::new(clip(s), grey.mix(0.6).stroke_width(1))).map_err(|e| err(&e))?;
    }
    if !single && !sessions.is_empty() {
        entries.push((Mark::Line(grey), "one session".to_string()));
    }
    let dashes: Vec<(f64, f64)> = (0..=60).map(|k| x0 + (x1 - x0) * k as f64 / 60.0).map(|x| (x, -drop)).collect();
    chart
        .draw_series(dashes.chunks(2).map(|c| PathElement::new(c.to_vec(), BLACK.stroke_width(1))))
        .map_err(|e| err(&e))?;
    entries.push((Mark::Dashed(BLACK), format!("−{drop:.2}: 95 % support")));
    if let Some(p) = pooled {
        chart.draw_series(LineSeries::new(clip(&p.curve), PALETTE[0].stroke_width(3))).map_err(|e| err(&e))?;
        let name = if single { "this session" } else { "pooled" };
        entries.push((Mark::Line(PALETTE[0]), format!("{name}: α = {:.2} (shaded: interval)", p.alpha)));
    }
    for (k, a) in protocol.iter().enumerate() {
        let x = a.log2();
        chart
            .draw_series(std::iter::once(PathElement::new(vec![(x, floor), (x, 0.3)], PALETTE[1].stroke_width(2))))
            .map_err(|e| err(&e))?;
        if k == 0 {
            entries.push((Mark::Line(PALETTE[1]), format!("protocol α = {a}")));
        }
    }
    side_legend(&beside, &entries).map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// (x, y, label) points of one line.
pub type LabelledPoints = Vec<(f64, f64, String)>;

/// One panel of the comfort–accuracy front.
pub struct FrontPanel {
    pub title: String,
    /// Named lines of (cost ratio, gain, point label) points.
    pub lines: Vec<(String, LabelledPoints)>,
    pub active: Option<(f64, f64)>,
    pub passive: Option<(f64, f64)>,
    /// (largest cost ratio, smallest gain) of the target region, shaded.
    pub target: (f64, f64),
}

/// The comfort–accuracy front: per panel, gain against cost ratio for each line, active
/// and passive marked, the random mix of the two as a dashed line, the target shaded.
pub fn front_plot(path: &Path, title: &str, panels: &[FrontPanel]) -> Result<(), String> {
    let cols = panels.len().clamp(1, 2);
    let rows = panels.len().div_ceil(cols).max(1);
    let root = svg(path, (520 * cols as u32, 420 * rows as u32 + 40))?.into_drawing_area();
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root.titled(title, ("sans-serif", 20)).map_err(|e| err(&e))?;
    for (panel, area) in panels.iter().zip(root.split_evenly((rows, cols))) {
        let xs = panel.lines.iter().flat_map(|l| l.1.iter().map(|p| p.0)).chain(panel.active.map(|a| a.0));
        let x_max = xs.fold(1.5f64, f64::max) * 1.08;
        let ys: Vec<f64> = panel.lines.iter().flat_map(|l| l.1.iter().map(|p| p.1)).collect();
        let y_min = ys.iter().copied().fold(-0.1f64, f64::min) - 0.05;
        let y_max = ys.iter().copied().fold(1.1f64, f64::max) + 0.05;
        // Room above the points for the legend (the lines, the target, the mix, active, passive).
        let y_max = y_max + (y_max - y_min) * legend_headroom(panel.lines.len() + 4);
        let mut chart = ChartBuilder::on(&area)
            .caption(&panel.title, ("sans-serif", 15))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(55)
            .build_cartesian_2d(0.8..x_max, y_min..y_max)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("true cost / passive's")
            .y_desc("fraction of active's gain")
            .y_label_formatter(&|y| format!("{:.0} %", 100.0 * y))
            .draw()
            .map_err(|e| err(&e))?;
        let (tx, ty) = panel.target;
        chart
            .draw_series(std::iter::once(Rectangle::new([(0.8, ty), (tx, y_max)], PALETTE[2].mix(0.15).filled())))
            .map_err(|e| err(&e))?
            .label(format!("target: ≥ {:.0} % at ≤ {tx} ×", 100.0 * ty))
            .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], PALETTE[2].mix(0.3).filled()));
        if let (Some(a), Some(p)) = (panel.active, panel.passive) {
            let dashes: Vec<(f64, f64)> =
                (0..=40).map(|k| k as f64 / 40.0).map(|t| (p.0 + t * (a.0 - p.0), p.1 + t * (a.1 - p.1))).collect();
            chart
                .draw_series(dashes.chunks(2).map(|c| PathElement::new(c.to_vec(), BLACK.stroke_width(1))))
                .map_err(|e| err(&e))?
                .label("random mix of passive and active")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 6, y)], BLACK.stroke_width(1)));
        }
        for (k, (name, pts)) in panel.lines.iter().enumerate() {
            let colour = PALETTE[k % 2];
            chart
                .draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.1)), colour.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(name.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], colour.stroke_width(2)));
            chart.draw_series(pts.iter().map(|p| Circle::new((p.0, p.1), 3, colour.filled()))).map_err(|e| err(&e))?;
            chart
                .draw_series(
                    pts.iter()
                        .map(|p| Text::new(p.2.clone(), (p.0, p.1), ("sans-serif", 11).into_font().color(&colour))),
                )
                .map_err(|e| err(&e))?;
        }
        for (name, point, colour) in [("active", panel.active, PALETTE[3]), ("passive", panel.passive, PALETTE[4])] {
            if let Some(pt) = point {
                chart
                    .draw_series(std::iter::once(TriangleMarker::new(pt, 7, colour.filled())))
                    .map_err(|e| err(&e))?
                    .label(name)
                    .legend(move |(x, y)| TriangleMarker::new((x + 6, y), 5, colour.filled()));
            }
        }
        legend(&mut chart, SeriesLabelPosition::UpperRight).map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::tick_label;

    #[test]
    fn tick_labels_carry_the_decimals_their_spacing_needs() {
        assert_eq!(tick_label(-14000.0, 20000.0), "-14000");
        assert_eq!(tick_label(14.0, 18.0), "14");
        assert_eq!(tick_label(1.5, 5.0), "1.5");
        assert_eq!(tick_label(0.25, 0.5), "0.25");
        assert_eq!(tick_label(-0.0001, 10.0), "0");
    }
}
