//! Charts written as PNG and SVG with a shipped font (no system font libraries).
//!
//! Every plot pulsetrack draws (top views of tracks, error against distance, tactile traces,
//! FEM stress curves, speed-against-error fronts) is a [`Chart`] of line and point series;
//! fields over two axes (the FEM's tactile image) are heat maps ([`HeatmapFigure`]).

use std::path::{Path, PathBuf};
use std::sync::Once;

mod heatmap;
pub use heatmap::{Heatmap, HeatmapFigure, viridis, write_heatmaps};

use plotters::prelude::*;
use plotters::style::FontStyle;

const FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mark {
    Line,
    Points,
    LinePoints,
    /// Large red crosses whatever the series' place: points that must stand out (false
    /// points, reported where the tracker felt nothing).
    Crosses,
}

/// A series' colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Hue {
    /// The palette colour of the series' place in its chart.
    Auto,
    /// Palette colour `i` (modulo its ten): the same trial in the same colour on every chart.
    Index(usize),
    /// Black: what the simulator knows to be true, never a measurement.
    Truth,
}

/// The spread about one point: its x and y ranges, drawn as capped bars.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    pub x: (f64, f64),
    pub y: (f64, f64),
}

#[derive(Debug, Clone)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub mark: Mark,
    pub hue: Hue,
    /// One per point (or none).
    pub bars: Vec<Spread>,
    /// A short text beside each point (or none).
    pub labels: Vec<String>,
}

impl Series {
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>, mark: Mark) -> Self {
        Self {
            name: name.into(),
            points,
            mark,
            hue: Hue::Auto,
            bars: Vec::new(),
            labels: Vec::new(),
        }
    }

    /// Error bars, one per point.
    pub fn bars(mut self, bars: Vec<Spread>) -> Self {
        self.bars = bars;
        self
    }

    /// A text beside each point.
    pub fn labels(mut self, labels: Vec<String>) -> Self {
        self.labels = labels;
        self
    }

    pub fn hue(mut self, hue: Hue) -> Self {
        self.hue = hue;
        self
    }
}

#[derive(Debug, Clone)]
pub struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Same scale on both axes (top views of a path).
    pub equal_aspect: bool,
    pub size_px: (u32, u32),
}

impl Chart {
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            equal_aspect: false,
            size_px: (1000, 700),
        }
    }

    pub fn with(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }
}

#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("cannot create plot directory {dir}: {source}")]
    Dir { dir: String, source: std::io::Error },
    #[error("cannot draw {file}: {message}")]
    Draw { file: String, message: String },
    #[error("chart {0:?} has no finite points to draw")]
    Empty(String),
}

fn register_font() {
    REGISTER.call_once(|| {
        // The font is compiled in; failing to parse it is a build defect caught by tests.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// Write `chart` as `dir/stem.png` and `dir/stem.svg`; returns both paths.
pub fn write_chart(chart: &Chart, dir: &Path, stem: &str) -> Result<Vec<PathBuf>, PlotError> {
    register_font();
    std::fs::create_dir_all(dir).map_err(|source| PlotError::Dir {
        dir: dir.display().to_string(),
        source,
    })?;
    let png = dir.join(format!("{stem}.png"));
    let svg = dir.join(format!("{stem}.svg"));
    {
        let root = BitMapBackend::new(&png, chart.size_px).into_drawing_area();
        draw(chart, root).map_err(|message| PlotError::Draw {
            file: png.display().to_string(),
            message,
        })?;
    }
    {
        let root = SVGBackend::new(&svg, chart.size_px).into_drawing_area();
        draw(chart, root).map_err(|message| PlotError::Draw {
            file: svg.display().to_string(),
            message,
        })?;
    }
    Ok(vec![png, svg])
}

// Ten distinct colours (Tableau 10): one per tactile element without repeats.
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
];

fn bounds(chart: &Chart) -> Option<((f64, f64), (f64, f64))> {
    let bar_corners = chart
        .series
        .iter()
        .flat_map(|s| s.bars.iter().flat_map(|b| [(b.x.0, b.y.0), (b.x.1, b.y.1)]));
    let pts = chart
        .series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .chain(bar_corners)
        .filter(|(x, y)| x.is_finite() && y.is_finite());
    let mut b: Option<(f64, f64, f64, f64)> = None;
    for (x, y) in pts {
        b = Some(match b {
            None => (x, x, y, y),
            Some((x0, x1, y0, y1)) => (x0.min(x), x1.max(x), y0.min(y), y1.max(y)),
        });
    }
    let (mut x0, mut x1, mut y0, mut y1) = b?;
    let pad = |lo: &mut f64, hi: &mut f64| {
        let span = (*hi - *lo).abs().max(1e-12);
        *lo -= 0.05 * span;
        *hi += 0.05 * span;
    };
    pad(&mut x0, &mut x1);
    pad(&mut y0, &mut y1);
    if chart.equal_aspect {
        let (w, h) = (chart.size_px.0 as f64, chart.size_px.1 as f64);
        let scale = ((x1 - x0) / w).max((y1 - y0) / h);
        let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
        x0 = cx - scale * w / 2.0;
        x1 = cx + scale * w / 2.0;
        y0 = cy - scale * h / 2.0;
        y1 = cy + scale * h / 2.0;
    }
    Some(((x0, x1), (y0, y1)))
}

/// Width of the legend's column, right of the data, px.
const LEGEND_W: u32 = 260;

fn color_of(hue: Hue, place: usize) -> RGBColor {
    match hue {
        Hue::Auto => PALETTE[place % PALETTE.len()],
        Hue::Index(i) => PALETTE[i % PALETTE.len()],
        Hue::Truth => RGBColor(0, 0, 0),
    }
}

fn draw<DB: DrawingBackend>(
    chart: &Chart,
    root: DrawingArea<DB, plotters::coord::Shift>,
) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let data_w = chart.size_px.0.saturating_sub(LEGEND_W).max(1);
    let data_chart = Chart {
        size_px: (data_w, chart.size_px.1),
        ..chart.clone()
    };
    let ((x0, x1), (y0, y1)) =
        bounds(&data_chart).ok_or_else(|| PlotError::Empty(chart.title.clone()).to_string())?;
    root.fill(&WHITE).map_err(|e| err(&e))?;
    // The title spans the figure; the legend has its own column, outside the data.
    let root = root
        .titled(&chart.title, ("sans-serif", 22))
        .map_err(|e| err(&e))?;
    let (data, legend) = root.split_horizontally(data_w);
    let mut ctx = ChartBuilder::on(&data)
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| err(&e))?;
    ctx.configure_mesh()
        .x_desc(&chart.x_label)
        .y_desc(&chart.y_label)
        .label_style(("sans-serif", 15))
        .draw()
        .map_err(|e| err(&e))?;
    for (i, s) in chart.series.iter().enumerate() {
        let color = color_of(s.hue, i);
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .collect();
        if matches!(s.mark, Mark::Line | Mark::LinePoints) {
            ctx.draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                .map_err(|e| err(&e))?;
        }
        if s.mark == Mark::Crosses {
            ctx.draw_series(pts.iter().map(|&p| Cross::new(p, 8, CROSS.stroke_width(3))))
                .map_err(|e| err(&e))?;
        }
        if matches!(s.mark, Mark::Points | Mark::LinePoints) {
            ctx.draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))
                .map_err(|e| err(&e))?;
        }
        for (&(x, y), b) in s.points.iter().zip(&s.bars) {
            if [x, y, b.x.0, b.x.1, b.y.0, b.y.1]
                .iter()
                .all(|v| v.is_finite())
            {
                // Plain segments: plotters' own error bars need a feature for two lines.
                let style = color.stroke_width(1);
                ctx.draw_series([
                    PathElement::new(vec![(x, b.y.0), (x, b.y.1)], style),
                    PathElement::new(vec![(b.x.0, y), (b.x.1, y)], style),
                ])
                .map_err(|e| err(&e))?;
            }
        }
        let font = ("sans-serif", 13).into_font().color(&color);
        for (&p, label) in s.points.iter().zip(&s.labels) {
            if p.0.is_finite() && p.1.is_finite() {
                ctx.draw_series([
                    EmptyElement::at(p) + Text::new(label.clone(), (6, -16), font.clone())
                ])
                .map_err(|e| err(&e))?;
            }
        }
    }
    draw_legend(chart, &legend).map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// The colour of points that must stand out (false points).
const CROSS: RGBColor = RGBColor(220, 0, 0);

/// One entry per series, top down, each with its mark in its colour; names wrap to the
/// column's width.
fn draw_legend<DB: DrawingBackend>(
    chart: &Chart,
    area: &DrawingArea<DB, plotters::coord::Shift>,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let font = ("sans-serif", 14).into_font();
    let mut y = 30;
    for (i, s) in chart.series.iter().enumerate() {
        let color = color_of(s.hue, i);
        let mid = y + 8;
        match s.mark {
            Mark::Line => area.draw(&PathElement::new(
                vec![(8, mid), (32, mid)],
                color.stroke_width(2),
            ))?,
            Mark::LinePoints => {
                area.draw(&PathElement::new(
                    vec![(8, mid), (32, mid)],
                    color.stroke_width(2),
                ))?;
                area.draw(&Circle::new((20, mid), 4, color.filled()))?;
            }
            Mark::Points => area.draw(&Circle::new((20, mid), 4, color.filled()))?,
            Mark::Crosses => area.draw(&Cross::new((20, mid), 6, CROSS.stroke_width(3)))?,
        }
        for line in wrap(&s.name, 30) {
            area.draw(&Text::new(line, (40, y), font.clone()))?;
            y += 18;
        }
        y += 6;
    }
    Ok(())
}

/// `text` in lines of at most about `width` characters, broken at spaces.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in text.split_whitespace() {
        match lines.last_mut() {
            Some(l) if l.len() + 1 + word.len() <= width => {
                l.push(' ');
                l.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    if lines.is_empty() {
        lines.push(String::new());
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_png_and_svg_with_the_shipped_font() {
        let dir = std::env::temp_dir().join(format!("pulsetrack-plot-{}", std::process::id()));
        let chart = Chart::new("test", "x (m)", "z (m)")
            .with(Series::new(
                "line",
                vec![(0.0, 0.0), (1.0, 1.0)],
                Mark::Line,
            ))
            .with(Series::new(
                "points",
                vec![(0.5, 0.4), (f64::NAN, 1.0)],
                Mark::Points,
            ))
            .with(Series::new("false points", vec![(0.2, 0.9)], Mark::Crosses));
        let files = write_chart(&chart, &dir, "demo").unwrap();
        for f in &files {
            let len = std::fs::metadata(f).unwrap().len();
            assert!(len > 1000, "{} is {len} bytes", f.display());
        }
        let svg = std::fs::read_to_string(&files[1]).unwrap();
        assert!(svg.contains("x (m)"), "axis label drawn as text");
        assert!(
            svg.contains("false points"),
            "the crosses have a legend entry"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_hue_is_kept_whatever_the_series_place_and_truth_is_black() {
        assert_eq!(color_of(Hue::Index(1), 0), color_of(Hue::Auto, 1));
        assert_eq!(color_of(Hue::Index(1), 7), PALETTE[1]);
        assert_eq!(color_of(Hue::Index(11), 0), PALETTE[1]);
        assert_eq!(color_of(Hue::Truth, 3), RGBColor(0, 0, 0));
    }

    #[test]
    fn bars_and_point_labels_are_drawn_and_widen_the_axes() {
        let dir = std::env::temp_dir().join(format!("pulsetrack-plot-bars-{}", std::process::id()));
        let chart = Chart::new("front", "t (s)", "sd (mm)").with(
            Series::new("beatslide", vec![(20.0, 0.25)], Mark::LinePoints)
                .bars(vec![Spread {
                    x: (15.0, 25.0),
                    y: (0.2, 0.4),
                }])
                .labels(vec!["16 mm/s".into()]),
        );
        let ((x0, x1), (y0, y1)) = bounds(&chart).unwrap();
        assert!(x0 < 15.0 && x1 > 25.0 && y0 < 0.2 && y1 > 0.4);
        let files = write_chart(&chart, &dir, "front").unwrap();
        let svg = std::fs::read_to_string(&files[1]).unwrap();
        assert!(
            svg.contains("16 mm/s") && svg.contains("beatslide"),
            "{svg}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn legend_names_wrap_at_spaces() {
        assert_eq!(
            wrap(
                "trial 1 (seed 1): never seeded (not_seeded), nothing located",
                30
            ),
            [
                "trial 1 (seed 1): never seeded",
                "(not_seeded), nothing located"
            ]
        );
        assert_eq!(wrap("", 30), [""]);
    }

    #[test]
    fn empty_chart_is_an_error_not_a_panic() {
        let dir =
            std::env::temp_dir().join(format!("pulsetrack-plot-empty-{}", std::process::id()));
        let chart = Chart::new("nothing", "x", "y").with(Series::new(
            "nan",
            vec![(f64::NAN, 0.0)],
            Mark::Line,
        ));
        assert!(matches!(
            write_chart(&chart, &dir, "e"),
            Err(PlotError::Draw { .. })
        ));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
