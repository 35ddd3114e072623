//! Figures: drawn as SVG (plotters' SVG backend) in a journal's column width, and written as
//! SVG, PDF (fonts embedded) and PNG (300 dpi) as asked.

use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Why a figure could not be made.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The drawing library refused a step.
    #[error("cannot draw: {0}")]
    Drawing(String),
    /// No font, or a drawing that cannot be made a PDF or a PNG.
    #[error("{0}")]
    Render(String),
    /// The figure's file could not be written.
    #[error("{}: {source}", path.display())]
    Write { path: PathBuf, source: std::io::Error },
}

/// A drawing step's error.
fn drawing(e: impl std::fmt::Display) -> PlotError {
    PlotError::Drawing(e.to_string())
}

/// Region colours, in order: Okabe and Ito's colour-blind-safe palette.
pub const PALETTE: [RGBColor; 6] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(230, 159, 0),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
];

/// A figure's width: one journal column (3.5 in) or a page's two (7.17 in), at the SVG's 96
/// pixels an inch; fonts keep their size (7–10.5 pt) and the layout follows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FigureWidth {
    OneColumn,
    #[default]
    TwoColumn,
}

/// A file format a figure is written in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FigureFormat {
    Svg,
    /// Vector, its fonts embedded (subset).
    Pdf,
    /// 300 dots an inch, the resolution stored in the file.
    Png,
}

impl FigureFormat {
    pub fn extension(self) -> &'static str {
        match self {
            FigureFormat::Svg => "svg",
            FigureFormat::Pdf => "pdf",
            FigureFormat::Png => "png",
        }
    }
}

/// How the figures of a command are drawn and written.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FigureStyle {
    pub width: FigureWidth,
    /// Every figure is written once per format, the path's extension replaced.
    pub formats: Vec<FigureFormat>,
}

impl Default for FigureStyle {
    fn default() -> Self {
        FigureStyle { width: FigureWidth::TwoColumn, formats: vec![FigureFormat::Svg] }
    }
}

/// PNG resolution.
pub(crate) const PNG_DPI: f32 = 300.0;
/// The SVG's pixels an inch (CSS's, which viewers and converters assume).
const SVG_DPI: f32 = 96.0;

impl FigureStyle {
    /// Writes the drawing `svg` at `path` in each format (owner-only files).
    fn write(&self, path: &Path, svg: &str) -> Result<(), PlotError> {
        for format in &self.formats {
            let out = path.with_extension(format.extension());
            let bytes = match format {
                FigureFormat::Svg => svg.as_bytes().to_vec(),
                FigureFormat::Pdf => pdf(svg).map_err(|e| PlotError::Render(format!("{}: {e}", out.display())))?,
                FigureFormat::Png => {
                    png(svg, PNG_DPI).map_err(|e| PlotError::Render(format!("{}: {e}", out.display())))?.0
                }
            };
            crate::private_files::write_output(&out, &bytes)
                .map_err(|source| PlotError::Write { path: out, source })?;
        }
        Ok(())
    }

    /// The files a figure named `stem` is written as: "power.svg", "power.{svg,pdf}".
    pub fn file_names(&self, stem: &str) -> String {
        let ext: Vec<&str> = self.formats.iter().map(|f| f.extension()).collect();
        if ext.len() == 1 { format!("{stem}.{}", ext[0]) } else { format!("{stem}.{{{}}}", ext.join(",")) }
    }

    fn layout(&self) -> Layout {
        match self.width {
            FigureWidth::TwoColumn => Layout {
                width: 688,
                title: pt(10.0),
                caption: pt(9.0),
                label: pt(9.0),
                tick: pt(8.0),
                legend: pt(8.0),
                y_area: 68,
                max_cols: 2,
                narrow: false,
            },
            FigureWidth::OneColumn => Layout {
                width: 336,
                title: pt(8.5),
                caption: pt(8.0),
                label: pt(8.0),
                tick: pt(7.0),
                legend: pt(7.0),
                y_area: 60,
                max_cols: 1,
                narrow: true,
            },
        }
    }
}

/// Sizes (pixels at 96 an inch) a figure is laid out with.
#[derive(Clone, Copy, Debug)]
struct Layout {
    width: u32,
    /// Font sizes, in pixels.
    title: f64,
    caption: f64,
    label: f64,
    tick: f64,
    legend: f64,
    /// Room left of a chart for its tick labels and y description.
    y_area: u32,
    /// Panels side by side at most.
    max_cols: usize,
    /// Legends that would sit beside a chart go under it.
    narrow: bool,
}

impl Layout {
    /// Room under a chart for its tick labels and x description.
    fn x_area(&self) -> u32 {
        (self.tick + self.label + 14.0).ceil() as u32
    }

    /// The lines `text` takes at `font` pixels in `width` pixels (a sans-serif character is
    /// about 0.56 of its size wide).
    fn wrap(text: &str, width: u32, font: f64) -> Vec<String> {
        let per_line = ((width as f64 / (font * 0.56)) as usize).max(8);
        let mut lines = vec![String::new()];
        for word in text.split(' ') {
            let line = lines.last_mut().expect("one line");
            if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > per_line {
                lines.push(word.to_string());
            } else {
                if !line.is_empty() {
                    line.push(' ');
                }
                line.push_str(word);
            }
        }
        lines
    }

    /// A grid of `n` panels in at most `cols` columns (and the layout's most): its columns,
    /// rows and each panel's height, `aspect` × its width within `heights`, and no taller
    /// than lets the figure, with `fixed` pixels of title and legend, fit a page
    /// ([`PAGE_HEIGHT`]). Panels shrink to [`MIN_PANEL`] first; below it a column is added
    /// (one more than the layout's most), and past that they shrink further.
    fn grid(
        &self,
        n: usize,
        cols: usize,
        aspect: f64,
        heights: std::ops::RangeInclusive<f64>,
        fixed: u32,
    ) -> (usize, usize, u32) {
        let room = PAGE_HEIGHT.saturating_sub(fixed) as f64;
        let first = cols.clamp(1, self.max_cols);
        let widest = (self.max_cols + 1).min(n.max(1)).max(first);
        let mut best = (first, 1, MIN_PANEL as u32);
        for c in first..=widest {
            let rows = n.div_ceil(c).max(1);
            let ideal = (self.width as f64 / c as f64 * aspect).clamp(*heights.start(), *heights.end());
            let height = ideal.min(room / rows as f64);
            best = (c, rows, height.floor() as u32);
            if height >= MIN_PANEL.min(ideal) {
                break;
            }
        }
        best
    }

    /// The height of a title block of `lines`.
    fn title_height(&self, lines: usize) -> u32 {
        (lines as f64 * self.title * 1.3).ceil() as u32 + 10
    }

    /// The height of a chart's caption of `lines` (above the chart's own margin).
    fn caption_height(&self, lines: usize) -> u32 {
        (lines as f64 * self.caption * 1.3 + self.caption * 0.8).ceil() as u32
    }

    /// The height of an in-chart legend of `entries` one-line entries.
    fn legend_height(&self, entries: usize) -> u32 {
        (entries as f64 * self.legend * 1.3).ceil() as u32 + 14
    }
}

/// The tallest a figure is (pixels): 9 in, a journal page's text height less its caption.
const PAGE_HEIGHT: u32 = 864;
/// The height a panel keeps before a grid takes another column (pixels).
const MIN_PANEL: f64 = 170.0;

/// `points` (1/72 in) in the SVG's pixels (1/96 in).
fn pt(points: f64) -> f64 {
    points * SVG_DPI as f64 / 72.0
}

/// A sans-serif font `px` pixels high. (plotters writes an SVG font size of its size / 1.24.)
fn sans(px: f64) -> (&'static str, f64) {
    ("sans-serif", (px * 1.24).ceil())
}

/// A rectangle in the figure's pixels: (left, top, right, bottom).
pub type PixelRect = (i32, i32, i32, i32);

/// Where a figure's parts are, in its pixels (what a test checks the drawing against).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Drawn {
    /// Each chart's plotting area, inside its axes.
    pub axes: Vec<PixelRect>,
    /// A legend drawn outside the charts (beside or under them).
    pub legend: Option<PixelRect>,
}

fn pixel_rect<DB: DrawingBackend, CT: CoordTranslate>(area: &DrawingArea<DB, CT>) -> PixelRect {
    let (x, y) = area.get_base_pixel();
    let (w, h) = area.dim_in_pixel();
    (x, y, x + w as i32, y + h as i32)
}

/// Whether PDF and PNG figures can be drawn here (a sans-serif font is found): asked before a
/// command's work, so that it never fails after writing its tables.
pub fn check_fonts() -> Result<(), PlotError> {
    fonts().map(|_| ())
}

/// Fonts for PDF and PNG: the system's, with a common sans-serif face for "sans-serif".
fn fonts() -> Result<Arc<resvg::usvg::fontdb::Database>, PlotError> {
    static FONTS: OnceLock<Result<Arc<resvg::usvg::fontdb::Database>, String>> = OnceLock::new();
    FONTS
        .get_or_init(|| {
            let mut db = resvg::usvg::fontdb::Database::new();
            db.load_system_fonts();
            let families: Vec<String> =
                db.faces().flat_map(|f| f.families.iter().map(|(name, _)| name.clone())).collect();
            let sans = ["DejaVu Sans", "Liberation Sans", "Arial", "Helvetica", "Noto Sans", "FreeSans"]
                .into_iter()
                .find(|want| families.iter().any(|f| f == want))
                .ok_or_else(|| {
                    "no sans-serif font found to draw text in PDF or PNG (DejaVu Sans, Liberation Sans, Arial, \
                     Helvetica, Noto Sans or FreeSans; on Debian: apt install fonts-dejavu-core)"
                        .to_string()
                })?;
            db.set_sans_serif_family(sans);
            Ok(Arc::new(db))
        })
        .clone()
        .map_err(PlotError::Render)
}

fn tree(svg: &str) -> Result<resvg::usvg::Tree, PlotError> {
    let options = resvg::usvg::Options { fontdb: fonts()?, ..Default::default() };
    resvg::usvg::Tree::from_str(svg, &options).map_err(|e| PlotError::Render(format!("cannot read the drawing: {e}")))
}

/// The drawing as a PDF page of its size (96 SVG pixels an inch), fonts embedded.
pub fn pdf(svg: &str) -> Result<Vec<u8>, PlotError> {
    let page = svg2pdf::PageOptions { dpi: SVG_DPI };
    svg2pdf::to_pdf(&tree(svg)?, svg2pdf::ConversionOptions::default(), page)
        .map_err(|e| PlotError::Render(format!("cannot make a PDF: {e}")))
}

/// The drawing as a PNG at `dpi` (its resolution stored in a pHYs chunk), and the pixels.
pub fn png(svg: &str, dpi: f32) -> Result<(Vec<u8>, resvg::tiny_skia::Pixmap), PlotError> {
    let tree = tree(svg)?;
    let scale = dpi / SVG_DPI;
    let size = tree.size().to_int_size().scale_by(scale).ok_or_else(|| PlotError::Render("empty drawing".into()))?;
    let mut pixmap = resvg::tiny_skia::Pixmap::new(size.width(), size.height())
        .ok_or_else(|| PlotError::Render("empty drawing".into()))?;
    pixmap.fill(resvg::tiny_skia::Color::WHITE);
    resvg::render(&tree, resvg::tiny_skia::Transform::from_scale(scale, scale), &mut pixmap.as_mut());
    let bytes = pixmap.encode_png().map_err(|e| PlotError::Render(format!("cannot encode the PNG: {e}")))?;
    Ok((with_resolution(bytes, dpi), pixmap))
}

/// `png` with a pHYs chunk (pixels a metre) after its header, so that a journal's checker
/// reads the resolution.
fn with_resolution(png: Vec<u8>, dpi: f32) -> Vec<u8> {
    // The 8-byte signature, then IHDR: 4 length, 4 type, 13 data, 4 CRC.
    let after_header = 8 + 4 + 4 + 13 + 4;
    let per_metre = (dpi as f64 / 0.0254).round() as u32;
    let mut body = b"pHYs".to_vec();
    body.extend(per_metre.to_be_bytes());
    body.extend(per_metre.to_be_bytes());
    body.push(1);
    let mut chunk = 9u32.to_be_bytes().to_vec();
    chunk.extend(&body);
    chunk.extend(crc32fast::hash(&body).to_be_bytes());
    let mut out = png[..after_header].to_vec();
    out.extend(chunk);
    out.extend(&png[after_header..]);
    out
}

/// Draws a figure of `size` with `draw` and writes it as `style` says.
fn figure(
    path: &Path,
    style: &FigureStyle,
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend, plotters::coord::Shift>) -> Result<Drawn, PlotError>,
) -> Result<Drawn, PlotError> {
    let mut svg = String::new();
    let drawn = {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(drawing)?;
        let drawn = draw(&root)?;
        root.present().map_err(drawing)?;
        drawn
    };
    style.write(path, &svg)?;
    Ok(drawn)
}

/// Draws `lines` centred at the top of `area` and returns the area under them.
fn title_block<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    lines: &[String],
    l: &Layout,
) -> Result<DrawingArea<DB, plotters::coord::Shift>, PlotError> {
    let font = sans(l.title).into_font().color(&BLACK).pos(Pos::new(HPos::Center, VPos::Top));
    let centre = area.dim_in_pixel().0 as i32 / 2;
    for (k, line) in lines.iter().enumerate() {
        let y = 5 + (k as f64 * l.title * 1.3) as i32;
        area.draw(&Text::new(line.clone(), (centre, y), font.clone())).map_err(drawing)?;
    }
    Ok(area.split_vertically(l.title_height(lines.len())).1)
}

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

/// The data's range with 5 % (at least 1) on each side.
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

/// The y axis' ends for data from `lo` to `hi` in a plotting area `plot_px` high with a
/// legend `legend_px` high at its top: the legend above the data, 5 % of the area under it.
fn y_ends(lo: f64, hi: f64, plot_px: f64, legend_px: f64) -> (f64, f64) {
    let span = (hi - lo).max(1e-9);
    // The legend starts a few pixels under the area's top.
    let legend_px = legend_px + 8.0;
    let data_px = (plot_px * 0.95 - legend_px).max(plot_px * 0.3);
    let per_px = span / data_px;
    (lo - 0.05 * plot_px * per_px, hi + legend_px * per_px)
}

/// The plotting area's height in a chart area `width` × `height` with `caption` over it
/// (margins, x labels, caption).
fn plot_height((width, height): (u32, u32), l: &Layout, caption: Option<&str>) -> f64 {
    let caption = caption.map_or(0, |c| l.caption_height(Layout::wrap(c, width, l.caption).len()));
    height as f64 - 2.0 * MARGIN as f64 - l.x_area() as f64 - caption as f64
}

/// How many y tick labels an axis `plot_px` high holds (at most `most`), each at least two
/// of its lines from the next.
fn y_ticks(plot_px: f64, most: usize, l: &Layout) -> usize {
    ((plot_px / (l.tick * 2.2)) as usize).clamp(2, most)
}

/// A chart's margin.
const MARGIN: u32 = 8;

/// A figure of scatter panels in a grid of at most `cols` columns.
pub fn scatter_grid(
    path: &Path,
    style: &FigureStyle,
    title: &str,
    panels: &[ScatterPanel],
    cols: usize,
) -> Result<Drawn, PlotError> {
    let l = style.layout();
    let lines = Layout::wrap(title, l.width, l.title);
    let (cols, rows, ph) = l.grid(panels.len(), cols, 0.85, 250.0..=f64::INFINITY, l.title_height(lines.len()));
    figure(path, style, (l.width, l.title_height(lines.len()) + ph * rows as u32), |root| {
        let body = title_block(root, &lines, &l)?;
        let mut drawn = Drawn::default();
        for (panel, area) in panels.iter().zip(body.split_evenly((rows, cols))) {
            let xs = range(panel.groups.iter().flat_map(|g| g.points.iter().map(|p| p.0)));
            let ys = range(panel.groups.iter().flat_map(|g| g.points.iter().map(|p| p.1)));
            let legend_px = l.legend_height(panel.groups.len()) as f64;
            let (bottom, top) = y_ends(ys.start, ys.end, plot_height((l.width, ph), &l, None), legend_px);
            let (x_span, y_span) = (xs.end - xs.start, top - bottom);
            let mut chart = chart_on(&area, &l, None, xs, bottom..top)?;
            mesh(&mut chart, &l, panel.x_label, panel.y_label)
                .x_label_formatter(&|x| tick_label(*x, x_span))
                .y_label_formatter(&|y| tick_label(*y, y_span))
                .draw()
                .map_err(drawing)?;
            for (k, g) in panel.groups.iter().enumerate() {
                let colour = PALETTE[k % PALETTE.len()];
                chart
                    .draw_series(g.points.iter().map(|&p| Circle::new(p, 2, colour.mix(0.6).filled())))
                    .map_err(drawing)?
                    .label(g.name)
                    .legend(move |(x, y)| Circle::new((x + 8, y), 3, colour.filled()));
            }
            legend(&mut chart, &l)?;
            drawn.axes.push(pixel_rect(chart.plotting_area()));
        }
        Ok(drawn)
    })
}

/// A chart of f64 axes on any backend.
type AnyChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A chart in `area` with the layout's margin and label areas, its caption above it (centred,
/// wrapped to the area's width).
fn chart_on<'a, DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    l: &Layout,
    caption: Option<&str>,
    x: std::ops::Range<f64>,
    y: std::ops::Range<f64>,
) -> Result<AnyChart<'a, DB>, PlotError> {
    let mut area = area.clone();
    if let Some(caption) = caption {
        let lines = Layout::wrap(caption, area.dim_in_pixel().0, l.caption);
        let font = sans(l.caption).into_font().color(&BLACK).pos(Pos::new(HPos::Center, VPos::Top));
        let centre = area.dim_in_pixel().0 as i32 / 2;
        for (k, line) in lines.iter().enumerate() {
            let y = MARGIN as i32 + (k as f64 * l.caption * 1.3) as i32;
            area.draw(&Text::new(line.clone(), (centre, y), font.clone())).map_err(drawing)?;
        }
        area = area.split_vertically(l.caption_height(lines.len())).1;
    }
    ChartBuilder::on(&area)
        .margin(MARGIN)
        .x_label_area_size(l.x_area())
        .y_label_area_size(l.y_area)
        .build_cartesian_2d(x, y)
        .map_err(drawing)
}

/// The axes' style every chart shares: faint major grid lines, no minor ones, the
/// layout's fonts, and the axes' descriptions.
fn mesh<'a, 'b, DB: DrawingBackend>(
    chart: &'b mut AnyChart<'a, DB>,
    l: &Layout,
    x_desc: &str,
    y_desc: &str,
) -> plotters::chart::MeshStyle<'a, 'b, RangedCoordf64, RangedCoordf64, DB> {
    let mut style = chart.configure_mesh();
    style
        .light_line_style(TRANSPARENT)
        .bold_line_style(BLACK.mix(0.08))
        .label_style(sans(l.tick))
        .axis_desc_style(sans(l.label))
        .x_desc(x_desc)
        .y_desc(y_desc);
    style
}

/// The legend inside a chart, at its top right: framed, on a translucent white background.
fn legend<'a, DB: DrawingBackend + 'a>(chart: &mut AnyChart<'a, DB>, l: &Layout) -> Result<(), PlotError> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .margin(6)
        .legend_area_size(24)
        .label_font(sans(l.legend))
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(drawing)
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
    /// Whether a band reaches below the floor (and is cut there).
    fn cut(&self) -> bool {
        let points = self.series.iter().flat_map(|s| &s.points).filter(|p| p.1.is_finite() && p.2.is_finite());
        self.floor.is_some_and(|f| points.clone().any(|p| p.1 - p.2 < f))
    }

    /// The band's legend entry, saying where it is cut when `cut`.
    fn band_entry(&self, cut: bool) -> String {
        match self.floor.filter(|_| cut) {
            Some(f) => format!("shaded: {}, cut at {f}, the least value", self.band),
            None => format!("shaded: {}", self.band),
        }
    }

    pub(crate) fn data_range(&self) -> Option<(f64, f64)> {
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
    // "-0" reads as a value below zero; a negative value takes a minus sign, not a hyphen.
    if text.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        text.trim_start_matches('-').into()
    } else {
        text.replacen('-', "\u{2212}", 1)
    }
}

/// Means with shaded bands against integer x, one line per series (as the paper's Fig. 2, 8
/// and 10): ticks at the integers, the legend above the data, the band named in it.
pub fn mean_se_plot(path: &Path, style: &FigureStyle, plot: &LinePlot) -> Result<Drawn, PlotError> {
    let l = style.layout();
    let lines = Layout::wrap(plot.title, l.width, l.title);
    // Tall enough that the y description (a character about 0.56 of its size) fits the axis.
    let label_px = plot.y_label.chars().count() as f64 * l.label * 0.56;
    let height =
        (l.width as f64 * 0.6).max(260.0).max(label_px + l.x_area() as f64 + 2.0 * MARGIN as f64 + 24.0) as u32;
    figure(path, style, (l.width, l.title_height(lines.len()) + height), |root| {
        let body = title_block(root, &lines, &l)?;
        let axes = draw_lines(&body, plot, plot.y_label, false, None, true, &l)?;
        Ok(Drawn { axes: vec![axes], legend: None })
    })
}

/// Line plots of means with bands (as [`mean_se_plot`]) in a grid of at most `cols` columns
/// under a title. Panels with the same `y_groups` entry share one y axis spanning all their
/// data (panels of one measure compare at a glance); without groups each has its own. Panels
/// that show the same series share one legend, under the grid, and a row's panels of one y
/// axis one y description, at its left.
pub fn line_grid(
    path: &Path,
    style: &FigureStyle,
    title: &str,
    plots: &[LinePlot],
    cols: usize,
    y_groups: Option<&[usize]>,
) -> Result<Drawn, PlotError> {
    let l = style.layout();
    let lines = Layout::wrap(title, l.width, l.title);
    let same_series = |p: &LinePlot, q: &LinePlot| p.series.iter().map(|s| s.name).eq(q.series.iter().map(|s| s.name));
    let common = plots.len() > 1 && plots.iter().all(|p| same_series(p, &plots[0]) && p.band == plots[0].band);
    let entries: Vec<(Mark, String)> = match plots.first().filter(|_| common) {
        Some(first) => {
            let mut entries: Vec<(Mark, String)> = first
                .series
                .iter()
                .enumerate()
                .map(|(k, s)| (Mark::Line(PALETTE[k % PALETTE.len()]), s.name.to_string()))
                .collect();
            // The band's entry names the cut of the first panel cut; where panels' measures
            // differ in their least value, it says the cut is theirs alone.
            let band = match plots.iter().find(|p| p.cut()) {
                Some(cut) if plots.iter().all(|p| p.floor == cut.floor) => cut.band_entry(true),
                Some(cut) => format!(
                    "shaded: {}, cut at {} where a measure cannot be lower",
                    first.band,
                    cut.floor.unwrap_or_default()
                ),
                None => first.band_entry(false),
            };
            entries.push((Mark::Band(GREY), band));
            entries
        }
        None => Vec::new(),
    };
    let legend_h = if common { legend_block_height(&entries, l.width, &l) } else { 0 };
    let fixed = l.title_height(lines.len()) + legend_h;
    let (cols, rows, ph) = l.grid(plots.len(), cols, 0.8, 260.0..=f64::INFINITY, fixed);
    let group = |k: usize| y_groups.and_then(|g| g.get(k).copied());
    let shared = |k: usize| {
        let g = group(k)?;
        let ranges = plots.iter().enumerate().filter(|(j, _)| group(*j) == Some(g)).filter_map(|(_, p)| p.data_range());
        ranges.reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
    };
    // Panels stacked with one y description: written once, along the whole grid's left edge
    // (a panel's own would be longer than the panel and run into its neighbour's).
    let one_label = rows > 1 && plots.iter().all(|p| p.y_label == plots[0].y_label);
    // A panel right of one with its y axis and description needs neither described again.
    let described_left = |k: usize| {
        let first = k - k % cols;
        k != first && group(k).is_some() && group(k) == group(first) && plots[k].y_label == plots[first].y_label
    };
    figure(path, style, (l.width, fixed + ph * rows as u32), |root| {
        let body = title_block(root, &lines, &l)?;
        let (charts, under) = body.split_vertically(ph * rows as u32);
        let mut drawn = Drawn::default();
        for (k, (plot, area)) in plots.iter().zip(charts.split_evenly((rows, cols))).enumerate() {
            let y_desc = if one_label || described_left(k) { "" } else { plot.y_label };
            drawn.axes.push(draw_lines(&area, plot, y_desc, true, shared(k), !common, &l)?);
        }
        if one_label && let Some(first) = plots.first() {
            let mid = charts.dim_in_pixel().1 as i32 / 2;
            y_description(&charts, &[first.y_label.to_string()], mid, &l)?;
        }
        if common {
            drawn.legend = Some(legend_block(&under, &entries, &l)?);
        }
        Ok(drawn)
    })
}

/// A y description's `lines`, rotated, at the left edge of `area` and centred on `mid`.
fn y_description<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    lines: &[String],
    mid: i32,
    l: &Layout,
) -> Result<(), PlotError> {
    let font = sans(l.label)
        .into_font()
        .transform(plotters::style::FontTransform::Rotate270)
        .color(&BLACK)
        .pos(Pos::new(HPos::Center, VPos::Top));
    for (k, line) in lines.iter().enumerate() {
        let x = MARGIN as i32 + (k as f64 * l.label * DESC_LINE) as i32;
        area.draw(&Text::new(line.clone(), (x, mid), font.clone())).map_err(drawing)?;
    }
    Ok(())
}

/// `text` on two lines, split at the space nearest its middle (one line without a space).
fn two_lines(text: &str) -> Vec<String> {
    let middle = text.chars().count() / 2;
    let split = text
        .char_indices()
        .filter(|(_, c)| *c == ' ')
        .min_by_key(|(i, _)| text[..*i].chars().count().abs_diff(middle))
        .map(|(i, _)| i);
    match split {
        Some(i) => vec![text[..i].to_string(), text[i + 1..].to_string()],
        None => vec![text.to_string()],
    }
}

/// A y description's line spacing, in its font's size.
const DESC_LINE: f64 = 1.35;

/// Grey: bands' legend marks.
const GREY: RGBColor = RGBColor(120, 120, 120);

/// One line plot in `area` (its title as a caption when `caption`); its y axis spans
/// `y_range` (the data's own when none); its legend inside it when `in_legend` (else the
/// figure shows it). A y description longer than the axis takes two lines. Returns its
/// plotting area.
fn draw_lines<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    plot: &LinePlot,
    y_desc: &str,
    caption: bool,
    y_range: Option<(f64, f64)>,
    in_legend: bool,
    l: &Layout,
) -> Result<PixelRect, PlotError> {
    let finite = || plot.series.iter().flat_map(|s| &s.points).filter(|p| p.1.is_finite() && p.2.is_finite());
    let x_min = finite().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let x_max = finite().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
    let (x_min, x_max) = if x_min.is_finite() { (x_min.floor(), x_max.ceil()) } else { (0.0, 1.0) };
    let low = |p: &(f64, f64, f64)| plot.floor.map_or(p.1 - p.2, |f| (p.1 - p.2).max(f));
    let (lo, hi) = y_range.or_else(|| plot.data_range()).unwrap_or((0.0, 1.0));
    // The legend's width is what the chart leaves: the band's entry wraps onto more lines.
    let band =
        Layout::wrap(&plot.band_entry(plot.cut()), area.dim_in_pixel().0.saturating_sub(l.y_area + 60), l.legend);
    let entries = if in_legend { plot.series.len() + band.len() } else { 0 };
    let caption = caption.then_some(plot.title);
    let plot_px = plot_height(area.dim_in_pixel(), l, caption);
    let legend_px = if in_legend { l.legend_height(entries) as f64 } else { 0.0 };
    let (bottom, top) = y_ends(lo, hi, plot_px, legend_px);
    // A description longer than the axis is drawn here, on two lines, the y area widened for
    // the second; a shorter one by plotters.
    let desc_lines =
        if y_desc.chars().count() as f64 * l.label * 0.6 > plot_px { two_lines(y_desc) } else { Vec::new() };
    let widened =
        Layout { y_area: l.y_area + if desc_lines.len() > 1 { (l.label * DESC_LINE) as u32 } else { 0 }, ..*l };
    let mut chart = chart_on(area, &widened, caption, x_min - 0.3..x_max + 0.3, bottom..top)?;
    mesh(&mut chart, l, plot.x_label, if desc_lines.is_empty() { y_desc } else { "" })
        // At most one label per integer: plotters then steps by 1, 2 or 5, all integers.
        .x_labels(((x_max - x_min) as usize + 1).min(if l.narrow { 7 } else { 11 }))
        .x_label_formatter(&|x| {
            if (x - x.round()).abs() < 1e-6 { format!("{}", x.round() as i64) } else { String::new() }
        })
        .y_labels(y_ticks(plot_px, if l.narrow { 6 } else { 9 }, l))
        .y_label_formatter(&|y| tick_label(*y, top - bottom))
        .draw()
        .map_err(drawing)?;
    for (k, s) in plot.series.iter().enumerate() {
        let pts: Vec<_> = s
            .points
            .iter()
            .filter(|p| p.1.is_finite() && p.2.is_finite())
            .map(|p| (p.0, p.1, low(p), p.1 + p.2))
            .collect();
        draw_band_line(&mut chart, s.name, PALETTE[k % PALETTE.len()], &pts)?;
    }
    let axes = pixel_rect(chart.plotting_area());
    if !desc_lines.is_empty() {
        // Centred on the room from the axes' top to the panel's bottom (the x area has no
        // text at its left), which holds more than the axes' height.
        let bottom = area.get_base_pixel().1 + area.dim_in_pixel().1 as i32 - MARGIN as i32;
        let mid = (axes.1 + bottom) / 2 - area.get_base_pixel().1;
        y_description(area, &desc_lines, mid, l)?;
    }
    if in_legend {
        // One legend entry a line (plotters draws an entry on one line), the mark on the first.
        for (k, line) in band.into_iter().enumerate() {
            let entry = chart.draw_series(std::iter::empty::<Circle<(f64, f64), i32>>()).map_err(drawing)?.label(line);
            if k == 0 {
                entry.legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 16, y + 5)], GREY.mix(0.3).filled()));
            }
        }
        legend(&mut chart, l)?;
    }
    Ok(axes)
}

/// One series as a shaded band from low to high, a line and its points, named in the
/// legend; `pts` are (x, y, low, high).
fn draw_band_line<DB: DrawingBackend>(
    chart: &mut AnyChart<'_, DB>,
    name: &str,
    colour: RGBColor,
    pts: &[(f64, f64, f64, f64)],
) -> Result<(), PlotError> {
    let mut band: Vec<(f64, f64)> = pts.iter().map(|p| (p.0, p.3)).collect();
    band.extend(pts.iter().rev().map(|p| (p.0, p.2)));
    chart.draw_series(std::iter::once(Polygon::new(band, colour.mix(0.15).filled()))).map_err(drawing)?;
    chart
        .draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.1)), colour.stroke_width(2)))
        .map_err(drawing)?
        .label(name)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], colour.stroke_width(2)));
    chart.draw_series(pts.iter().map(|p| Circle::new((p.0, p.1), 3, colour.filled()))).map_err(drawing)?;
    Ok(())
}

/// One line of a power curve: (participants, power, interval low, interval high) points.
pub struct PowerSeries<'a> {
    pub name: &'a str,
    pub points: Vec<(f64, f64, f64, f64)>,
}

/// A legend entry's mark.
enum Mark {
    Line(RGBColor),
    Dashed(RGBColor),
    Band(RGBColor),
    Bar(RGBColor),
    Triangle(RGBColor),
}

/// The width of a legend beside a chart.
const SIDE_LEGEND: u32 = 200;

/// A figure of one chart under `title`, its legend `entries` beside it (two columns) or
/// under it (one column); `draw` draws the chart in its area and returns its plotting area.
fn chart_with_legend(
    path: &Path,
    style: &FigureStyle,
    title: &str,
    entries: &[(Mark, String)],
    draw: impl FnOnce(&DrawingArea<SVGBackend, plotters::coord::Shift>, &Layout) -> Result<PixelRect, PlotError>,
) -> Result<Drawn, PlotError> {
    let l = style.layout();
    let lines = Layout::wrap(title, l.width, l.title);
    let chart_height = if l.narrow { 260 } else { 370 };
    let under = if l.narrow { legend_block_height(entries, l.width, &l) } else { 0 };
    figure(path, style, (l.width, l.title_height(lines.len()) + chart_height + under), |root| {
        let body = title_block(root, &lines, &l)?;
        let (area, legend) = if l.narrow {
            body.split_vertically(chart_height)
        } else {
            // Beside the chart, the legend starts level with the plotting area's top.
            let (area, beside) = body.split_horizontally(l.width - SIDE_LEGEND);
            (area, beside.split_vertically(MARGIN + 14).1)
        };
        let axes = draw(&area, &l)?;
        Ok(Drawn { axes: vec![axes], legend: Some(legend_block(&legend, entries, &l)?) })
    })
}

/// One legend entry placed: its mark's left end, its first line's centre, its lines.
struct LegendPlace {
    x: i32,
    y: i32,
    lines: Vec<String>,
}

/// A legend's mark is this wide, and its text starts this far right of the mark's left end.
const LEGEND_MARK: i32 = 24;
const LEGEND_TEXT: i32 = 32;

/// Where a legend block `width` pixels wide puts each of `entries`, and its height. Entries
/// that fit sit in aligned columns, as many as the width holds (each as wide as the widest of
/// them), filled in reading order; a longer entry takes a row of its own, wrapped.
fn legend_places(entries: &[(Mark, String)], width: u32, l: &Layout) -> (Vec<LegendPlace>, u32) {
    let line = l.legend * 1.45;
    let gap = l.legend * 0.6;
    let (left, room) = (8.0, width as f64 - 16.0);
    let one_line = |text: &str| LEGEND_TEXT as f64 + text_width(text, l.legend);
    let short = |text: &str| one_line(text) <= room / 2.0;
    let cell = entries.iter().filter(|e| short(&e.1)).map(|e| one_line(&e.1) + 3.0 * gap).fold(0.0, f64::max);
    let cols = if cell > 0.0 { ((room + 3.0 * gap) / cell).floor().max(1.0) as usize } else { 1 };
    let (mut y, mut col, mut row_lines) = (8.0 + l.legend / 2.0, 0usize, 0usize);
    let mut places = Vec::new();
    for (_, text) in entries {
        let alone = !short(text);
        if col > 0 && (alone || col == cols) {
            y += row_lines as f64 * line + gap;
            (col, row_lines) = (0, 0);
        }
        let lines = if one_line(text) <= room {
            vec![text.clone()]
        } else {
            Layout::wrap(text, (room as u32).saturating_sub(LEGEND_TEXT as u32), l.legend)
        };
        row_lines = row_lines.max(lines.len());
        places.push(LegendPlace { x: (left + col as f64 * cell) as i32, y: y as i32, lines });
        col = if alone { cols } else { col + 1 };
    }
    let bottom = y + (row_lines.max(1) - 1) as f64 * line + l.legend / 2.0 + 8.0;
    (places, bottom.ceil() as u32)
}

/// The height of a legend block of `entries` in `width` pixels.
fn legend_block_height(entries: &[(Mark, String)], width: u32, l: &Layout) -> u32 {
    legend_places(entries, width, l).1
}

/// A legend in an area of its own beside or under a chart: each entry its mark and its text,
/// laid out by [`legend_places`]. Returns where it is.
fn legend_block<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    entries: &[(Mark, String)],
    l: &Layout,
) -> Result<PixelRect, PlotError> {
    let font = sans(l.legend).into_font().color(&BLACK).pos(Pos::new(HPos::Left, VPos::Center));
    let (places, _) = legend_places(entries, area.dim_in_pixel().0, l);
    let line = l.legend * 1.45;
    for ((mark, _), place) in entries.iter().zip(places) {
        let (x0, x1, y) = (place.x, place.x + LEGEND_MARK, place.y);
        match mark {
            Mark::Line(c) => area.draw(&PathElement::new(vec![(x0, y), (x1, y)], c.stroke_width(2))),
            Mark::Dashed(c) => area
                .draw(&PathElement::new(vec![(x0, y), (x0 + 9, y)], c.stroke_width(1)))
                .and_then(|_| area.draw(&PathElement::new(vec![(x0 + 15, y), (x1, y)], c.stroke_width(1)))),
            Mark::Band(c) => area.draw(&Rectangle::new([(x0, y - 5), (x1, y + 5)], c.mix(0.3).filled())),
            Mark::Bar(c) => area.draw(&Rectangle::new([(x0 + 6, y - 6), (x1 - 6, y + 6)], c.filled())),
            Mark::Triangle(c) => area.draw(&TriangleMarker::new(((x0 + x1) / 2, y), 6, c.filled())),
        }
        .map_err(drawing)?;
        for (k, text) in place.lines.into_iter().enumerate() {
            let at = (x0 + LEGEND_TEXT, y + (k as f64 * line) as i32);
            area.draw(&Text::new(text, at, font.clone())).map_err(drawing)?;
        }
    }
    Ok(pixel_rect(area))
}

/// Power (a share of studies, 0–1) against the number of participants, one line per series
/// with its interval shaded (`band` names it), the conventional 80 % target and the 5 %
/// significance level dashed; ticks at the sizes planned.
pub fn power_plot(
    path: &Path,
    style: &FigureStyle,
    title: &str,
    band: &str,
    series: &[PowerSeries],
) -> Result<Drawn, PlotError> {
    let grey = GREY;
    let mut entries = vec![
        (Mark::Dashed(grey), "80 % (a common target)".into()),
        (Mark::Dashed(grey), "5 % (the significance level)".into()),
    ];
    for (k, s) in series.iter().enumerate() {
        entries.push((Mark::Line(PALETTE[k % PALETTE.len()]), s.name.to_string()));
    }
    entries.push((Mark::Band(grey), format!("shaded: {band}")));
    chart_with_legend(path, style, title, &entries, |area, l| {
        // The sizes planned, equally spaced (they usually double), labelled with their values.
        let mut sizes: Vec<f64> = series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).collect();
        sizes.sort_by(f64::total_cmp);
        sizes.dedup();
        let at = |n: f64| sizes.iter().position(|&s| s == n).unwrap_or(0) as f64;
        let last = sizes.len().saturating_sub(1) as f64;
        // A little room past 0 and 100 % (no tick there) so that points on them show whole.
        let mut chart = chart_on(area, l, None, -0.4..last + 0.4, -0.03..1.03)?;
        mesh(&mut chart, l, "participants in the study", "power (share of studies with p < .05)")
            .x_labels(sizes.len().clamp(2, 13))
            .x_label_formatter(&|x| {
                let i = x.round();
                if (x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < sizes.len() {
                    format!("{}", sizes[i as usize])
                } else {
                    String::new()
                }
            })
            .y_labels(if l.narrow { 6 } else { 11 })
            .y_label_formatter(&|y| format!("{:.0} %", y * 100.0))
            .draw()
            .map_err(drawing)?;
        for level in [0.8, 0.05] {
            chart
                .draw_series(DashedLineSeries::new([(-0.4, level), (last + 0.4, level)], 6, 4, grey.stroke_width(1)))
                .map_err(drawing)?;
        }
        for (k, s) in series.iter().enumerate() {
            let pts: Vec<_> = s
                .points
                .iter()
                .filter(|p| p.1.is_finite() && p.2.is_finite() && p.3.is_finite())
                .map(|p| (at(p.0), p.1, p.2, p.3))
                .collect();
            draw_band_line(&mut chart, s.name, PALETTE[k % PALETTE.len()], &pts)?;
        }
        Ok(pixel_rect(chart.plotting_area()))
    })
}

/// Grouped bars: for each group (a legend entry), one bar per category.
pub fn bar_chart(
    path: &Path,
    style: &FigureStyle,
    title: &str,
    y_label: &str,
    categories: &[String],
    groups: &[(String, Vec<f64>)],
) -> Result<Drawn, PlotError> {
    let entries: Vec<(Mark, String)> =
        groups.iter().enumerate().map(|(k, (name, _))| (Mark::Bar(PALETTE[k % PALETTE.len()]), name.clone())).collect();
    chart_with_legend(path, style, title, &entries, |area, l| {
        // The axis ends at the data's range (1 for shares).
        let max = groups.iter().flat_map(|g| g.1.iter().copied()).fold(1.0f64, f64::max);
        let n = categories.len().max(1);
        let top = if max <= 1.0 { 1.0 } else { max * 1.05 };
        let mut chart = chart_on(area, l, None, 0.0..n as f64, 0.0..top)?;
        let cats = categories.to_vec();
        mesh(&mut chart, l, "", y_label)
            .disable_x_mesh()
            .x_labels(n * 2 + 1)
            .x_label_formatter(&|x| {
                let k = x.floor() as usize;
                if (x - k as f64 - 0.5).abs() < 0.01 { cats.get(k).cloned().unwrap_or_default() } else { String::new() }
            })
            .y_label_formatter(&|y| tick_label(*y, top))
            .draw()
            .map_err(drawing)?;
        let width = 0.8 / groups.len().max(1) as f64;
        for (gi, (_, values)) in groups.iter().enumerate() {
            let colour = PALETTE[gi % PALETTE.len()];
            chart
                .draw_series(values.iter().enumerate().map(|(k, &v)| {
                    let x0 = k as f64 + 0.1 + gi as f64 * width;
                    Rectangle::new([(x0, 0.0), (x0 + width * 0.95, v)], colour.filled())
                }))
                .map_err(drawing)?;
        }
        Ok(pixel_rect(chart.plotting_area()))
    })
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
    style: &FigureStyle,
    title: &str,
    sessions: &[Vec<(f64, f64)>],
    pooled: Option<&PooledEvidence>,
    protocol: &[f64],
    drop: f64,
) -> Result<Drawn, PlotError> {
    let grey = RGBColor(150, 150, 150);
    // One session: its curve is the bold one, named for what it is.
    let single = sessions.len() == 1;
    let mut entries = Vec::new();
    if !single && !sessions.is_empty() {
        entries.push((Mark::Line(grey), "one session".to_string()));
    }
    entries.push((Mark::Dashed(BLACK), format!("−{drop:.2}: 95 % support")));
    if let Some(p) = pooled {
        let name = if single { "this session" } else { "pooled" };
        entries.push((Mark::Line(PALETTE[0]), format!("{name}: α = {:.2} (shaded: interval)", p.alpha)));
    }
    if let Some(a) = protocol.first() {
        entries.push((Mark::Line(PALETTE[1]), format!("protocol α = {a}")));
    }
    chart_with_legend(path, style, title, &entries, |area, l| {
        let xs: Vec<f64> =
            sessions.iter().flatten().chain(pooled.iter().flat_map(|p| &p.curve)).map(|p| p.0.log2()).collect();
        let (x0, x1) =
            (xs.iter().copied().fold(f64::INFINITY, f64::min), xs.iter().copied().fold(f64::NEG_INFINITY, f64::max));
        let (x0, x1) = if x0 < x1 { (x0, x1) } else { (-2.0, 8.0) };
        let floor = -4.0 * drop.max(1.0) - 2.0;
        // A curve is drawn where it is above the axis' floor.
        let clip = |pts: &[(f64, f64)]| -> Vec<(f64, f64)> {
            pts.iter().filter(|(_, y)| *y >= floor).map(|(x, y)| (x.log2(), *y)).collect()
        };
        let top = 0.5;
        let mut chart = chart_on(area, l, None, x0..x1, floor..top)?;
        mesh(&mut chart, l, "α (log scale)", "log evidence − its maximum")
            .y_label_formatter(&|y| tick_label(*y, 0.5 - floor))
            .x_labels(((x1 - x0).round() as usize + 1).min(if l.narrow { 6 } else { 12 }))
            .x_label_formatter(&|x| {
                let a = 2f64.powf(*x);
                if a < 1.0 { format!("{a:.2}") } else { format!("{a:.0}") }
            })
            .draw()
            .map_err(drawing)?;
        if let Some(p) = pooled {
            let (lo, hi) = (p.low.log2().max(x0), p.high.log2().min(x1));
            chart
                .draw_series(std::iter::once(Rectangle::new([(lo, floor), (hi, 0.0)], PALETTE[0].mix(0.12).filled())))
                .map_err(drawing)?;
        }
        for s in sessions.iter().filter(|_| !single) {
            chart.draw_series(LineSeries::new(clip(s), grey.mix(0.6).stroke_width(1))).map_err(drawing)?;
        }
        let dashes: Vec<(f64, f64)> = (0..=60).map(|k| x0 + (x1 - x0) * k as f64 / 60.0).map(|x| (x, -drop)).collect();
        chart
            .draw_series(dashes.chunks(2).map(|c| PathElement::new(c.to_vec(), BLACK.stroke_width(1))))
            .map_err(drawing)?;
        if let Some(p) = pooled {
            chart.draw_series(LineSeries::new(clip(&p.curve), PALETTE[0].stroke_width(3))).map_err(drawing)?;
        }
        for a in protocol.iter().map(|a| a.log2()).filter(|x| (x0..=x1).contains(x)) {
            chart
                .draw_series(std::iter::once(PathElement::new(vec![(a, floor), (a, 0.3)], PALETTE[1].stroke_width(2))))
                .map_err(drawing)?;
        }
        Ok(pixel_rect(chart.plotting_area()))
    })
}

/// (x, y, label) points of one line.
pub(crate) type LabelledPoints = Vec<(f64, f64, String)>;

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
/// and passive marked, the random mix of the two as a dashed line, the target shaded. The
/// panels share their axes and one legend, under them.
pub fn front_plot(path: &Path, style: &FigureStyle, title: &str, panels: &[FrontPanel]) -> Result<Drawn, PlotError> {
    let l = style.layout();
    let lines = Layout::wrap(title, l.width, l.title);
    // One x and one y range over every panel.
    let xs =
        panels.iter().flat_map(|p| p.lines.iter().flat_map(|l| l.1.iter().map(|p| p.0)).chain(p.active.map(|a| a.0)));
    let x_max = xs.fold(1.5f64, f64::max) * 1.08;
    let ys: Vec<f64> = panels.iter().flat_map(|p| p.lines.iter().flat_map(|l| l.1.iter().map(|p| p.1))).collect();
    let y_min = ys.iter().copied().fold(-0.1f64, f64::min) - 0.05;
    let y_max = ys.iter().copied().fold(1.1f64, f64::max) + 0.05;
    let (active, passive) = (PALETTE[3], PALETTE[4]);
    let mut entries = Vec::new();
    if let Some(p) = panels.first() {
        let (tx, ty) = p.target;
        entries.push((
            Mark::Band(PALETTE[2]),
            format!("target: ≥ {:.0} % of active's gain at ≤ {tx} × passive's cost", 100.0 * ty),
        ));
        entries.push((Mark::Dashed(BLACK), "random mix of passive and active".to_string()));
        for (k, (name, _)) in p.lines.iter().enumerate() {
            entries.push((Mark::Line(PALETTE[k % 2]), format!("{name}, each point labelled with its value")));
        }
        entries.push((Mark::Triangle(active), "active".to_string()));
        entries.push((Mark::Triangle(passive), "passive".to_string()));
    }
    let legend_h = legend_block_height(&entries, l.width, &l);
    let (cols, rows, ph) =
        l.grid(panels.len(), panels.len(), 0.75, 240.0..=420.0, l.title_height(lines.len()) + legend_h);
    figure(path, style, (l.width, l.title_height(lines.len()) + ph * rows as u32 + legend_h), |root| {
        let body = title_block(root, &lines, &l)?;
        let (charts, under) = body.split_vertically(ph * rows as u32);
        let mut drawn = Drawn::default();
        for (panel, area) in panels.iter().zip(charts.split_evenly((rows, cols))) {
            let mut chart = chart_on(&area, &l, Some(&panel.title), 0.8..x_max, y_min..y_max)?;
            // A tick label (at most "10.0") every 40 pixels at most.
            let x_px = area.dim_in_pixel().0.saturating_sub(l.y_area + 2 * MARGIN) as usize;
            mesh(&mut chart, &l, "true cost / passive's", "fraction of active's gain")
                .x_labels((x_px / 40).clamp(2, 10))
                .y_labels(if l.narrow { 6 } else { 8 })
                .y_label_formatter(&|y| tick_label(100.0 * y, 100.0) + " %")
                .draw()
                .map_err(drawing)?;
            let (tx, ty) = panel.target;
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(0.8, ty.clamp(y_min, y_max)), (tx.min(x_max), y_max)],
                    PALETTE[2].mix(0.15).filled(),
                )))
                .map_err(drawing)?;
            if let (Some(a), Some(p)) = (panel.active, panel.passive) {
                let dashes: Vec<(f64, f64)> =
                    (0..=40).map(|k| k as f64 / 40.0).map(|t| (p.0 + t * (a.0 - p.0), p.1 + t * (a.1 - p.1))).collect();
                chart
                    .draw_series(dashes.chunks(2).map(|c| PathElement::new(c.to_vec(), BLACK.stroke_width(1))))
                    .map_err(drawing)?;
            }
            for (k, (_, pts)) in panel.lines.iter().enumerate() {
                let colour = PALETTE[k % 2];
                chart
                    .draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.1)), colour.stroke_width(2)))
                    .map_err(drawing)?;
                chart.draw_series(pts.iter().map(|p| Circle::new((p.0, p.1), 3, colour.filled()))).map_err(drawing)?;
            }
            for (point, colour) in [(panel.active, active), (panel.passive, passive)] {
                if let Some(pt) = point {
                    chart.draw_series(std::iter::once(TriangleMarker::new(pt, 7, colour.filled()))).map_err(drawing)?;
                }
            }
            // Each point's label where it covers no mark and no other label.
            let px = |p: (f64, f64)| chart.backend_coord(&p);
            let marks: Vec<PixelRect> = panel
                .lines
                .iter()
                .flat_map(|(_, pts)| pts.iter().map(|p| around(px((p.0, p.1)), 4)))
                .chain([panel.active, panel.passive].into_iter().flatten().map(|p| around(px(p), 8)))
                .collect();
            let labels: Vec<((i32, i32), String, RGBColor)> = panel
                .lines
                .iter()
                .enumerate()
                .flat_map(|(k, (_, pts))| pts.iter().map(move |p| (px((p.0, p.1)), p.2.clone(), PALETTE[k % 2])))
                .collect();
            let plotting = pixel_rect(chart.plotting_area());
            let font = sans(l.tick);
            let sizes: Vec<(i32, i32)> = labels
                .iter()
                .map(|(_, t, _)| (text_width(t, l.tick).ceil() as i32, (l.tick * 1.25).ceil() as i32))
                .collect();
            let anchors: Vec<(i32, i32)> = labels.iter().map(|(at, _, _)| *at).collect();
            let base = area.get_base_pixel();
            for ((text, colour), (x, y)) in
                labels.iter().map(|(_, t, c)| (t, c)).zip(place_labels(&anchors, &sizes, &marks, plotting))
            {
                let style = font.into_font().color(colour).pos(Pos::new(HPos::Left, VPos::Top));
                area.draw(&Text::new(text.clone(), (x - base.0, y - base.1), style)).map_err(drawing)?;
            }
            drawn.axes.push(plotting);
        }
        drawn.legend = Some(legend_block(&under, &entries, &l)?);
        Ok(drawn)
    })
}

/// The box `r` pixels around `p`.
fn around(p: (i32, i32), r: i32) -> PixelRect {
    (p.0 - r, p.1 - r, p.0 + r, p.1 + r)
}

/// A text's width at `px` pixels, erring wide (a sans-serif character is at most about 0.6
/// of its size wide).
fn text_width(text: &str, px: f64) -> f64 {
    text.chars().count() as f64 * px * 0.6
}

/// The area two boxes share (0 if apart).
fn shared_area(a: PixelRect, b: PixelRect) -> i64 {
    let w = (a.2.min(b.2) - a.0.max(b.0)).max(0) as i64;
    let h = (a.3.min(b.3) - a.1.max(b.1)).max(0) as i64;
    w * h
}

/// Top-left corners for labels of `sizes` (width, height) next to `anchors`, placed one after
/// another: each at the first of 26 spots around its point, nearest first, that covers least
/// of `marks` and of the labels placed before it (nothing, where a spot can) inside `inside`.
fn place_labels(
    anchors: &[(i32, i32)],
    sizes: &[(i32, i32)],
    marks: &[PixelRect],
    inside: PixelRect,
) -> Vec<(i32, i32)> {
    let mut taken: Vec<PixelRect> = Vec::new();
    let mut corners = Vec::new();
    for (&(x, y), &(w, h)) in anchors.iter().zip(sizes) {
        // Beside the point, level with it, then stacked a label's height further at a time.
        let mut spots = vec![(x + 5, y - h / 2), (x - w - 5, y - h / 2)];
        for k in 0..4 {
            spots.extend([
                (x + 5, y + 1 + k * h),
                (x + 5, y - h - 1 - k * h),
                (x - w - 5, y + 1 + k * h),
                (x - w - 5, y - h - 1 - k * h),
                (x - w / 2, y + 6 + k * h),
                (x - w / 2, y - h - 6 - k * h),
            ]);
        }
        let cost = |(cx, cy): (i32, i32)| {
            let b = (cx, cy, cx + w, cy + h);
            let outside = (b.0 < inside.0 || b.1 < inside.1 || b.2 > inside.2 || b.3 > inside.3) as i64;
            let covered: i64 = marks.iter().chain(&taken).map(|&m| shared_area(b, m)).sum();
            outside * i64::from(w * h) + covered
        };
        // The first spot of least cost: the first that covers nothing, where one does.
        let best = spots.iter().copied().min_by_key(|&c| cost(c)).unwrap_or((x + 5, y - h / 2));
        taken.push((best.0, best.1, best.0 + w, best.1 + h));
        corners.push(best);
    }
    corners
}

#[cfg(test)]
mod tests {
    use super::{place_labels, tick_label, with_resolution};

    #[test]
    fn tick_labels_carry_the_decimals_their_spacing_needs() {
        assert_eq!(tick_label(-14000.0, 20000.0), "\u{2212}14000");
        assert_eq!(tick_label(14.0, 18.0), "14");
        assert_eq!(tick_label(1.5, 5.0), "1.5");
        assert_eq!(tick_label(0.25, 0.5), "0.25");
        assert_eq!(tick_label(-0.0001, 10.0), "0");
    }

    /// Labels of points that coincide, or nearly, never cover one another or the points:
    /// every pair of 1–4 anchors within 6 pixels of each other (648 layouts).
    #[test]
    fn labels_of_points_close_together_stand_apart() {
        let inside = (0, 0, 300, 200);
        let offsets = [(0, 0), (3, 0), (0, 3), (-6, 2), (5, -5), (2, 6)];
        let mut layouts = 0;
        for n in 1..=4usize {
            for a in 0..offsets.len() {
                for b in 0..offsets.len() {
                    for &w in &[8, 20, 36] {
                        let anchors: Vec<(i32, i32)> = (0..n)
                            .map(|k| if k % 2 == 0 { offsets[a] } else { offsets[b] })
                            .map(|(dx, dy)| (150 + dx, 100 + dy))
                            .collect();
                        let sizes = vec![(w, 12); n];
                        let marks: Vec<_> = anchors.iter().map(|&p| super::around(p, 4)).collect();
                        let corners = place_labels(&anchors, &sizes, &marks, inside);
                        let boxes: Vec<_> = corners.iter().map(|&(x, y)| (x, y, x + w, y + 12)).collect();
                        for (i, bi) in boxes.iter().enumerate() {
                            assert!(bi.0 >= 0 && bi.1 >= 0 && bi.2 <= 300 && bi.3 <= 200, "{bi:?} outside");
                            for m in &marks {
                                assert_eq!(super::shared_area(*bi, *m), 0, "{bi:?} covers a point {m:?}");
                            }
                            for bj in &boxes[i + 1..] {
                                assert_eq!(super::shared_area(*bi, *bj), 0, "{bi:?} and {bj:?} overlap");
                            }
                        }
                        layouts += 1;
                    }
                }
            }
        }
        assert_eq!(layouts, 4 * 6 * 6 * 3);
    }

    #[test]
    fn the_png_resolution_chunk_follows_the_header() {
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        png.extend([0u8; 25]);
        png.extend(b"rest");
        let out = with_resolution(png, 300.0);
        assert_eq!(&out[33..37], &9u32.to_be_bytes());
        assert_eq!(&out[37..41], b"pHYs");
        // 300 dpi is 11811 pixels a metre.
        assert_eq!(&out[41..45], &11811u32.to_be_bytes());
        assert_eq!(out[49], 1);
        assert!(out.ends_with(b"rest"));
    }
}
