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

#[derive(Debug, Clone)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub mark: Mark,
}

impl Series {
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>, mark: Mark) -> Self {
        Self {
            name: name.into(),
            points,
            mark,
        }
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
    let pts = chart
        .series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|(x, y)| x.is_finite() && y.is_finite());
    let mut b: Option<(f64, f64, f64, f64)> = None;
    for &(x, y) in pts {
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

fn draw<DB: DrawingBackend>(
    chart: &Chart,
    root: DrawingArea<DB, plotters::coord::Shift>,
) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let ((x0, x1), (y0, y1)) =
        bounds(chart).ok_or_else(|| PlotError::Empty(chart.title.clone()).to_string())?;
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut ctx = ChartBuilder::on(&root)
        .caption(&chart.title, ("sans-serif", 24))
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
        let color = PALETTE[i % PALETTE.len()];
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .collect();
        if matches!(s.mark, Mark::Line | Mark::LinePoints) {
            ctx.draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(s.name.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
        }
        if s.mark == Mark::Crosses {
            let red = RGBColor(220, 0, 0);
            ctx.draw_series(pts.iter().map(|&p| Cross::new(p, 8, red.stroke_width(3))))
                .map_err(|e| err(&e))?
                .label(s.name.clone())
                .legend(move |(x, y)| Cross::new((x + 10, y), 6, red.stroke_width(3)));
        }
        if matches!(s.mark, Mark::Points | Mark::LinePoints) {
            let drawn = ctx
                .draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))
                .map_err(|e| err(&e))?;
            if s.mark == Mark::Points {
                drawn
                    .label(s.name.clone())
                    .legend(move |(x, y)| Circle::new((x + 10, y), 4, color.filled()));
            }
        }
    }
    ctx.configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 15))
        .draw()
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
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
