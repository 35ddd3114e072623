//! The flags every command that draws figures takes: their formats and their width.

use clap::{Args, ValueEnum};
use handover::plot::{FigureFormat, FigureStyle, FigureWidth};

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Format {
    Svg,
    /// Vector, fonts embedded.
    Pdf,
    /// 300 dpi.
    Png,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Width {
    /// 3.5 in (89 mm), a journal's single column.
    OneColumn,
    /// 7.17 in (182 mm), a page's two columns.
    TwoColumn,
}

#[derive(Args, Clone, Debug)]
pub struct FigureArgs {
    /// Formats every figure is written in, comma-separated: svg, pdf (fonts embedded), png
    /// (300 dpi); each file named as the SVG, its extension replaced.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "svg", value_name = "FORMATS")]
    figure_formats: Vec<Format>,
    /// The figures' width; text keeps its size (7–10.5 pt) and the layout follows.
    #[arg(long, value_enum, default_value = "two-column", value_name = "WIDTH")]
    figure_width: Width,
}

impl FigureArgs {
    /// What drawing the asked formats needs, checked before a command's work: PDF and PNG
    /// need a sans-serif font (bad input, exit 2, naming the package that brings one).
    pub fn check(&self) -> anyhow::Result<()> {
        let formats = self.style().formats;
        if formats.iter().any(|f| *f != FigureFormat::Svg) {
            let named: Vec<&str> = formats.iter().map(|f| f.extension()).collect();
            handover::plot::check_fonts()
                .map_err(|e| super::input::bad(format!("--figure-formats {}: {e}", named.join(","))))?;
        }
        Ok(())
    }

    pub fn style(&self) -> FigureStyle {
        let formats = super::input::first_occurrences(&self.figure_formats)
            .into_iter()
            .map(|f| match f {
                Format::Svg => FigureFormat::Svg,
                Format::Pdf => FigureFormat::Pdf,
                Format::Png => FigureFormat::Png,
            })
            .collect();
        let width = match self.figure_width {
            Width::OneColumn => FigureWidth::OneColumn,
            Width::TwoColumn => FigureWidth::TwoColumn,
        };
        FigureStyle { width, formats }
    }
}
