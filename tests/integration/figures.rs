//! Every kind of figure, drawn at both widths from data that tempts it out of its axes
//! (bands below the least value, curves far under the support threshold, an interval wider
//! than the α grid), read back from its SVG and rendered to pixels: the axes where the
//! drawing says, the labels and legend entries present, every data mark inside the axes, the
//! plotting areas not empty in the PNG, and a PDF with its fonts embedded.

use std::path::{Path, PathBuf};

use handover::plot::{
    Drawn, FigureFormat, FigureStyle, FigureWidth, FrontPanel, LinePlot, PALETTE, PixelRect, PointGroup,
    PooledEvidence, PowerSeries, ScatterPanel, Series, alpha_plot, bar_chart, front_plot, line_grid, mean_se_plot, png,
    power_plot, scatter_grid,
};

/// One element of the SVG: its name and attributes, and its text for `<text>`.
struct Element {
    name: String,
    attrs: Vec<(String, String)>,
    text: String,
}

impl Element {
    fn attr(&self, key: &str) -> Option<&str> {
        self.attrs.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    fn num(&self, key: &str) -> f64 {
        self.attr(key).and_then(|v| v.parse().ok()).unwrap_or_else(|| panic!("<{}> without {key}", self.name))
    }

    /// Its colour (fill, else stroke) when it is one of the palette's.
    fn palette_colour(&self) -> Option<String> {
        let colours: Vec<String> = PALETTE.iter().map(|c| format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2)).collect();
        [self.attr("fill"), self.attr("stroke")]
            .into_iter()
            .flatten()
            .find(|c| colours.iter().any(|p| p == c))
            .map(String::from)
    }

    /// The points it covers (a circle's extreme points).
    fn points(&self) -> Vec<(f64, f64)> {
        match self.name.as_str() {
            "circle" => {
                let (x, y, r) = (self.num("cx"), self.num("cy"), self.num("r"));
                vec![(x - r, y - r), (x + r, y + r)]
            }
            "rect" => {
                let (x, y) = (self.num("x"), self.num("y"));
                vec![(x, y), (x + self.num("width"), y + self.num("height"))]
            }
            "polyline" | "polygon" => self
                .attr("points")
                .unwrap_or_default()
                .split_whitespace()
                .map(|p| {
                    let (x, y) = p.split_once(',').unwrap();
                    (x.parse().unwrap(), y.parse().unwrap())
                })
                .collect(),
            _ => Vec::new(),
        }
    }
}

/// The elements of an SVG as plotters writes it (one element a line, a text's content on
/// the lines up to its end tag).
fn elements(svg: &str) -> Vec<Element> {
    let mut out = Vec::new();
    let mut lines = svg.lines();
    while let Some(line) = lines.next() {
        let Some(rest) = line.trim().strip_prefix('<') else { continue };
        if rest.starts_with('/') || rest.starts_with('?') {
            continue;
        }
        let name: String = rest.chars().take_while(|c| c.is_ascii_alphabetic()).collect();
        let mut attrs = Vec::new();
        let mut s = &rest[name.len()..];
        while let Some(eq) = s.find("=\"") {
            let key = s[..eq].trim().to_string();
            let end = s[eq + 2..].find('"').unwrap() + eq + 2;
            attrs.push((key, s[eq + 2..end].to_string()));
            s = &s[end + 1..];
        }
        let mut text = String::new();
        if name == "text" {
            for l in lines.by_ref() {
                if l.trim() == "</text>" {
                    break;
                }
                text.push_str(l.trim());
                text.push(' ');
            }
        }
        out.push(Element { name, attrs, text: text.trim().replace("&apos;", "'").replace("&amp;", "&") });
    }
    out
}

fn inside(p: (f64, f64), r: PixelRect, slack: f64) -> bool {
    p.0 >= r.0 as f64 - slack && p.0 <= r.2 as f64 + slack && p.1 >= r.1 as f64 - slack && p.1 <= r.3 as f64 + slack
}

/// Checks one drawn figure: axes, words, marks inside, pixels, formats.
fn check(kind: &str, path: &Path, drawn: &Drawn, words: &[&str]) {
    let svg = std::fs::read_to_string(path).unwrap();
    let els = elements(&svg);
    assert!(!drawn.axes.is_empty(), "{kind}: no axes");
    // The axes plotters drew (black lines along the plotting area's left and bottom edges)
    // are where the drawing says.
    let black: Vec<Vec<(f64, f64)>> = els
        .iter()
        .filter(|e| e.name == "polyline" && e.attr("stroke") == Some("#000000"))
        .map(Element::points)
        .collect();
    for r in &drawn.axes {
        let near = |a: f64, b: i32| (a - b as f64).abs() <= 2.0;
        let y_axis = black
            .iter()
            .any(|p| p.len() == 2 && near(p[0].0, r.0) && near(p[1].0, r.0) && near(p[0].1, r.1) && near(p[1].1, r.3));
        let x_axis = black
            .iter()
            .any(|p| p.len() == 2 && near(p[0].1, r.3) && near(p[1].1, r.3) && near(p[0].0, r.0) && near(p[1].0, r.2));
        assert!(y_axis && x_axis, "{kind}: no axis lines along {r:?}");
        assert!(r.2 - r.0 > 100 && r.3 - r.1 > 80, "{kind}: a plotting area of {r:?}");
    }
    // Every label and legend entry asked for is written.
    let text: String = els.iter().filter(|e| e.name == "text").map(|e| e.text.as_str()).collect::<Vec<_>>().join(" ");
    for w in words {
        assert!(text.contains(w), "{kind}: no {w:?} in {text:?}");
    }
    // A negative number is written with a minus sign (U+2212), as print typesetting does.
    for e in els.iter().filter(|e| e.name == "text") {
        let hyphen = e.text.strip_prefix('-').is_some_and(|t| t.starts_with(|c: char| c.is_ascii_digit()));
        assert!(!hyphen, "{kind}: '{}' has a hyphen for a minus sign", e.text);
    }
    // Every mark in a data colour lies inside a plotting area or in the legend.
    let mut marks = 0;
    for e in els.iter().filter(|e| e.palette_colour().is_some()) {
        let pts = e.points();
        let ok = drawn.axes.iter().any(|r| pts.iter().all(|p| inside(*p, *r, 1.5)))
            || drawn.legend.is_some_and(|r| pts.iter().all(|p| inside(*p, r, 1.5)));
        assert!(
            ok,
            "{kind}: a <{}> at {pts:?} outside the axes {:?} and the legend {:?}",
            e.name, drawn.axes, drawn.legend
        );
        marks += 1;
    }
    assert!(marks >= 3, "{kind}: {marks} data marks");
    // Rendered (the PNG's pixels at 96 dpi, one a pixel): each plotting area shows data
    // colours, and the tick labels left of it are drawn (fonts found).
    let (bytes, pixmap) = png(&svg, 96.0).unwrap();
    assert!(bytes.starts_with(b"\x89PNG"));
    let pixel = |x: i32, y: i32| pixmap.pixel(x as u32, y as u32).map(|p| (p.red(), p.green(), p.blue()));
    for r in &drawn.axes {
        let coloured = (r.0..r.2)
            .flat_map(|x| (r.1..r.3).map(move |y| (x, y)))
            .filter_map(|(x, y)| pixel(x, y))
            .filter(|&(r, g, b)| r.max(g).max(b) - r.min(g).min(b) > 40)
            .count();
        assert!(coloured > 50, "{kind}: {coloured} coloured pixels in {r:?}");
        let dark = ((r.0 - 40).max(0)..r.0 - 6)
            .flat_map(|x| (r.1..r.3).map(move |y| (x, y)))
            .filter_map(|(x, y)| pixel(x, y))
            .filter(|&(r, g, b)| r.max(g).max(b) < 100)
            .count();
        assert!(dark > 30, "{kind}: no tick labels drawn left of {r:?} ({dark} dark pixels)");
    }
}

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("handover-figures-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn styles() -> [(FigureStyle, &'static str); 2] {
    let svg = vec![FigureFormat::Svg];
    [
        (FigureStyle { width: FigureWidth::TwoColumn, formats: svg.clone() }, "two"),
        (FigureStyle { width: FigureWidth::OneColumn, formats: svg }, "one"),
    ]
}

/// Means near zero with wide bands: cut at the floor.
fn series(name: &str, shift: f64) -> Series<'_> {
    Series { name, points: (0..8).map(|i| (i as f64, shift + 2.0 / (1.0 + i as f64), 1.5)).collect() }
}

#[test]
fn line_plots_keep_their_bands_and_legends_inside_the_axes() {
    let d = dir();
    for (style, w) in styles() {
        let plot = LinePlot {
            title: "distance to truth — a title long enough to wrap onto a second line at one column",
            x_label: "iteration",
            y_label: "distance (rad)",
            band: "95 % CI over seeds",
            floor: Some(0.0),
            series: vec![series("active", 0.0), series("passive", 0.3)],
        };
        let path = d.join(format!("line-{w}.svg"));
        let drawn = mean_se_plot(&path, &style, &plot).unwrap();
        check(
            "mean_se_plot",
            &path,
            &drawn,
            &["iteration", "distance (rad)", "active", "passive", "cut at 0", "title long"],
        );
        assert_eq!(drawn.axes.len(), 1);
        let plots: Vec<LinePlot> = (0..3)
            .map(|k| LinePlot {
                title: ["first panel", "second panel", "third panel"][k],
                x_label: "queries",
                y_label: "log-likelihood",
                band: "95 % interval over seeds",
                floor: None,
                series: vec![series("region", -5.0 * k as f64), series("measured σ = 5°", 1.0)],
            })
            .collect();
        let path = d.join(format!("grid-{w}.svg"));
        let drawn = line_grid(&path, &style, "Small multiples", &plots, 3, Some(&[0, 0, 1])).unwrap();
        check(
            "line_grid",
            &path,
            &drawn,
            &["third panel", "queries", "log-likelihood", "measured σ = 5°", "Small multiples"],
        );
        assert_eq!(drawn.axes.len(), 3);
        // Two columns at most side by side (one at one column), however many asked for.
        let columns = drawn.axes.iter().map(|r| r.0).collect::<std::collections::BTreeSet<_>>().len();
        assert_eq!(columns, if w == "two" { 2 } else { 1 });
    }
}

#[test]
fn charts_with_their_legend_beside_or_under_them() {
    let d = dir();
    for (style, w) in styles() {
        let series = [
            PowerSeries {
                name: "test log-likelihood",
                points: vec![(8.0, 0.2, 0.05, 0.5), (16.0, 0.6, 0.4, 0.8), (32.0, 0.95, 0.85, 1.0)],
            },
            PowerSeries {
                name: "distance",
                points: vec![(8.0, 0.0, 0.0, 0.3), (16.0, 0.1, 0.0, 0.4), (32.0, 1.0, 0.9, 1.0)],
            },
        ];
        let path = d.join(format!("power-{w}.svg"));
        let drawn = power_plot(&path, &style, "Power of a protocol", "95 % Wilson interval", &series).unwrap();
        check("power_plot", &path, &drawn, &["participants in the study", "80 %", "Wilson", "distance", "32"]);
        let legend = drawn.legend.unwrap();
        let axes = drawn.axes[0];
        // Beside the chart at two columns, under it at one.
        if w == "two" {
            assert!(legend.0 >= axes.2, "{legend:?} {axes:?}")
        } else {
            assert!(legend.1 >= axes.3)
        }

        let groups = vec![("active".to_string(), vec![0.7, 0.3]), ("passive".to_string(), vec![0.4, 0.6])];
        let path = d.join(format!("bars-{w}.svg"));
        let drawn =
            bar_chart(&path, &style, "Objects", "share of offers", &["handlebars".into(), "u-lock".into()], &groups)
                .unwrap();
        check("bar_chart", &path, &drawn, &["share of offers", "handlebars", "u-lock", "active", "passive"]);

        // Curves down to −60 (under the axis' floor), an interval past both ends of the grid,
        // a protocol α off the grid.
        let curve = |c: f64| {
            (0..40)
                .map(|k| 2f64.powf(-2.0 + k as f64 * 0.25))
                .map(|a| (a, -((a.ln() - c).powi(2)) * 6.0))
                .collect::<Vec<_>>()
        };
        let sessions = vec![curve(0.5), curve(2.0), curve(3.0)];
        let pooled = PooledEvidence { curve: curve(1.5), alpha: 4.5, low: 0.01, high: 1e4 };
        let path = d.join(format!("alpha-{w}.svg"));
        let drawn =
            alpha_plot(&path, &style, "α by maximum marginal likelihood", &sessions, Some(&pooled), &[5.0, 1e6], 1.92)
                .unwrap();
        check(
            "alpha_plot",
            &path,
            &drawn,
            &["α (log scale)", "log evidence", "pooled", "one session", "protocol α = 5"],
        );
    }
}

#[test]
fn scatter_and_front_panels_keep_their_points_inside() {
    let d = dir();
    for (style, w) in styles() {
        let groups = |s: f64| {
            vec![
                PointGroup {
                    name: "left grip",
                    points: (0..50).map(|k| (k as f64, s * (k as f64).sin() * 40.0)).collect(),
                },
                PointGroup { name: "right grip", points: (0..50).map(|k| (-(k as f64), s * 30.0)).collect() },
            ]
        };
        let panels = vec![
            ScatterPanel { x_label: "shoulder flexion (deg)", y_label: "abduction (deg)", groups: groups(1.0) },
            ScatterPanel { x_label: "elbow flexion (deg)", y_label: "pronation (deg)", groups: groups(-2.0) },
        ];
        let path = d.join(format!("scatter-{w}.svg"));
        let drawn = scatter_grid(&path, &style, "lock-low-upright", &panels, 2).unwrap();
        check("scatter_grid", &path, &drawn, &["elbow flexion (deg)", "pronation (deg)", "left grip", "right grip"]);
        assert_eq!(drawn.axes.len(), 2);

        let panel = |name: &str, stretch: f64| FrontPanel {
            title: name.to_string(),
            lines: vec![
                ("hybrid (β)".into(), vec![(1.1, 0.3, "0.1".into()), (1.6 * stretch, 0.9, "1".into())]),
                ("budgeted (ε)".into(), vec![(1.0, -0.4, "0".into()), (1.3, 1.3, "0.5".into())]),
            ],
            active: Some((2.5 * stretch, 1.0)),
            passive: Some((1.0, 0.0)),
            target: (1.25, 0.8),
        };
        let path = d.join(format!("front-{w}.svg"));
        let drawn =
            front_plot(&path, &style, "Comfort–accuracy front", &[panel("planar2", 1.0), panel("arm7", 2.0)]).unwrap();
        check(
            "front_plot",
            &path,
            &drawn,
            &["true cost / passive's", "fraction of active's gain", "arm7", "hybrid (β)", "target"],
        );
    }
}

#[test]
fn every_format_is_written_png_at_300_dpi_and_pdf_with_its_fonts() {
    let d = dir();
    let style = FigureStyle {
        width: FigureWidth::OneColumn,
        formats: vec![FigureFormat::Svg, FigureFormat::Pdf, FigureFormat::Png],
    };
    let plot = LinePlot {
        title: "t",
        x_label: "iteration",
        y_label: "y",
        band: "band",
        floor: None,
        series: vec![series("a", 0.0)],
    };
    mean_se_plot(&d.join("formats.svg"), &style, &plot).unwrap();
    let svg = std::fs::read_to_string(d.join("formats.svg")).unwrap();
    assert!(svg.contains("width=\"336\""), "one column is 3.5 in at 96 px/in");
    let png = std::fs::read(d.join("formats.png")).unwrap();
    // 3.5 in at 300 dpi, and the resolution stored (11811 pixels a metre).
    assert_eq!(u32::from_be_bytes(png[16..20].try_into().unwrap()), 1050);
    let phys = png.windows(4).position(|w| w == b"pHYs").expect("a pHYs chunk");
    assert_eq!(u32::from_be_bytes(png[phys + 4..phys + 8].try_into().unwrap()), 11811);
    let pdf = std::fs::read(d.join("formats.pdf")).unwrap();
    assert!(pdf.starts_with(b"%PDF-"));
    let text = String::from_utf8_lossy(&pdf);
    assert!(text.contains("/FontFile"), "the PDF embeds its fonts");
    assert!(text.contains("/MediaBox [0 0 252 "), "one column is 252 pt wide");
}

/// Without a sans-serif font, a command asked for PDF or PNG figures says so before it does
/// any work (exit 2, the package named) and writes nothing; SVG needs none. The fonts are
/// hidden by an empty file system over every folder the font loader searches, in a mount
/// namespace of the command's own (`unshare --mount`, root).
#[test]
fn a_missing_font_is_found_before_any_work() {
    use std::process::Command;
    let hide = "for d in /usr/share/fonts /usr/local/share/fonts \"$HOME/.fonts\" \"$HOME/.local/share/fonts\"; do \
                [ -d \"$d\" ] && mount -t tmpfs none \"$d\"; done; exec \"$@\"";
    let can = Command::new("unshare")
        .args(["--mount", "--propagation", "private", "sh", "-c", "mount -t tmpfs none /mnt"])
        .status()
        .is_ok_and(|s| s.success());
    if !can {
        return crate::support::missing("a mount namespace (unshare --mount needs root and util-linux)");
    }
    let dir = crate::support::tmpdir("no-font");
    let logs = dir.join("logs");
    let (code, out, err) = crate::support::handover(&["dry-run", "--logs", logs.to_str().unwrap()]);
    assert_eq!(code, 0, "{out}{err}");
    let run = |formats: &str, out: &Path| {
        Command::new("unshare")
            .args(["--mount", "--propagation", "private", "sh", "-c", hide, "sh"])
            .arg(env!("CARGO_BIN_EXE_handover"))
            .args(["analyze", logs.to_str().unwrap(), "--fit-population", "--alpha-particles", "50"])
            .args(["--figure-formats", formats, "--out", out.to_str().unwrap()])
            .output()
            .unwrap()
    };
    for formats in ["pdf", "svg,png"] {
        let out = dir.join(format!("out-{formats}"));
        let o = run(formats, &out);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains("no sans-serif font") && err.contains("fonts-dejavu-core"), "{err}");
        assert!(!out.exists(), "nothing is written: {err}");
    }
    let out = dir.join("out-svg");
    let o = run("svg", &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("pilot/fig10.svg").exists());
}

/// A text and its box (left, top, right, bottom) in a figure's pixels.
type TextBox = (String, (f64, f64, f64, f64));

/// Every text of an SVG with its box as rendered (usvg lays the text out in DejaVu Sans, the
/// face PDF and PNG figures are drawn in).
fn text_boxes(svg: &str) -> Vec<TextBox> {
    use resvg::usvg;
    fn walk(group: &usvg::Group, out: &mut Vec<TextBox>) {
        for node in group.children() {
            match node {
                usvg::Node::Group(g) => walk(g, out),
                usvg::Node::Text(t) => {
                    let text: String = t.chunks().iter().map(|c| c.text()).collect();
                    let b = t.abs_bounding_box();
                    out.push((text, (b.left() as f64, b.top() as f64, b.right() as f64, b.bottom() as f64)));
                }
                _ => {}
            }
        }
    }
    let mut options = usvg::Options::default();
    options.fontdb_mut().load_system_fonts();
    options.fontdb_mut().set_sans_serif_family("DejaVu Sans");
    let tree = usvg::Tree::from_str(svg, &options).unwrap();
    let mut out = Vec::new();
    walk(tree.root(), &mut out);
    out
}

/// What a figure must be on a page, read from its SVG: at most 9 in (864 px at 96 an inch)
/// tall; every text inside the canvas and apart from every other; no in-chart legend box
/// over a data point; negative tick values with a minus sign (U+2212), not a hyphen.
fn page_problems(path: &Path) -> Vec<String> {
    let svg = std::fs::read_to_string(path).unwrap();
    let els = elements(&svg);
    let canvas = els.iter().find(|e| e.name == "svg").unwrap();
    let (w, h) = (canvas.num("width"), canvas.num("height"));
    let mut problems = Vec::new();
    if h > 864.0 {
        problems.push(format!("{:.1} in tall (at most 9)", h / 96.0));
    }
    let texts = text_boxes(&svg);
    for (text, b) in &texts {
        if b.0 < -0.5 || b.1 < -0.5 || b.2 > w + 0.5 || b.3 > h + 0.5 {
            problems.push(format!("'{text}' reaches outside the canvas ({b:.0?} in {w}×{h})"));
        }
        if text.starts_with('-') && text[1..].starts_with(|c: char| c.is_ascii_digit()) {
            problems.push(format!("'{text}' has a hyphen for a minus sign"));
        }
    }
    for (i, (a, ba)) in texts.iter().enumerate() {
        for (b, bb) in &texts[i + 1..] {
            let overlap_x = ba.2.min(bb.2) - ba.0.max(bb.0);
            let overlap_y = ba.3.min(bb.3) - ba.1.max(bb.1);
            if overlap_x > 0.5 && overlap_y > 0.5 {
                problems.push(format!("'{a}' and '{b}' overlap"));
            }
        }
    }
    // plotters' in-chart legend: a translucent white box with a black frame, drawn after the
    // data and before its own marks: a data point drawn before it and inside it is hidden.
    for (i, l) in els.iter().enumerate() {
        if !(l.name == "rect" && l.attr("fill") == Some("#FFFFFF") && l.attr("opacity") != Some("1")) {
            continue;
        }
        let r = (l.num("x"), l.num("y"), l.num("x") + l.num("width"), l.num("y") + l.num("height"));
        for e in els[..i].iter().filter(|e| e.name == "circle" && e.palette_colour().is_some()) {
            let (x, y) = (e.num("cx"), e.num("cy"));
            if x > r.0 && x < r.2 && y > r.1 && y < r.3 {
                problems.push(format!("a data point at ({x}, {y}) is under the legend {r:?}"));
            }
        }
    }
    problems
}

/// Every kind of figure the commands draw, from the commands themselves at small sizes, at
/// both widths: each fits a page as `page_problems` reads it.
#[test]
fn every_figure_kind_at_both_widths_fits_a_page_with_its_text_apart() {
    use crate::support::handover;
    let d = crate::support::tmpdir("figure-pages");
    let small = ["--trials", "2", "--menu", "4", "--iterations", "3", "--test-size", "20", "--particles", "100"];
    let logs = d.join("logs");
    let logs = logs.to_str().unwrap();
    let (code, _, err) = handover(&["dry-run", "--participants", "3", "--seed", "2", "--logs", logs]);
    assert_eq!(code, 0, "{err}");
    let mut figures = Vec::new();
    for width in ["one-column", "two-column"] {
        let out = |name: &str| d.join(format!("{name}-{width}")).to_str().unwrap().to_string();
        let runs: Vec<Vec<String>> = vec![
            [&["research", "simulate", "arm7", "--seeds", "2"][..], &small]
                .concat()
                .iter()
                .map(|s| s.to_string())
                .collect(),
            [&["research", "simulate", "planar2", "--learn", "both", "--seeds", "1"][..], &small]
                .concat()
                .iter()
                .map(|s| s.to_string())
                .collect(),
            [&["research", "observations", "--seeds", "2", "--sigma-deg", "2,5,10,20"][..], &small]
                .concat()
                .iter()
                .map(|s| s.to_string())
                .collect(),
            [&["research", "front", "--seeds", "2", "--betas", "0.1,1", "--epsilons", "0,0.5"][..], &small]
                .concat()
                .iter()
                .map(|s| s.to_string())
                .collect(),
            // A three-digit size at the axis' right end.
            ["plan", "--sizes", "4,8,128", "--studies", "2"].iter().map(|s| s.to_string()).collect(),
            ["analyze", logs, "--alpha-particles", "500"].iter().map(|s| s.to_string()).collect(),
        ];
        for (k, run) in runs.iter().enumerate() {
            let dir = out(&format!("run{k}"));
            let mut args: Vec<&str> = run.iter().map(String::as_str).collect();
            args.extend(["--out", &dir, "--figure-width", width]);
            let (code, _, err) = handover(&args);
            assert_eq!(code, 0, "{args:?}: {err}");
            figures.extend(
                std::fs::read_dir(&dir)
                    .unwrap()
                    .map(|e| e.unwrap().path())
                    .filter(|p| p.extension().is_some_and(|e| e == "svg")),
            );
        }
        let plot = out("feasible");
        let (code, _, err) =
            handover(&["feasible", "--query", "bars-low-level", "--plot", &plot, "--figure-width", width]);
        assert_eq!(code, 0, "{err}");
        figures.extend(std::fs::read_dir(&plot).unwrap().map(|e| e.unwrap().path()));
    }
    let mut failures = Vec::new();
    for f in &figures {
        for p in page_problems(f) {
            failures.push(format!("{}: {p}", f.strip_prefix(&*d).unwrap().display()));
        }
    }
    println!("{} figures checked (every kind the commands draw, at both widths)", figures.len());
    assert!(failures.is_empty(), "{} problems:\n{}", failures.len(), failures.join("\n"));
}
