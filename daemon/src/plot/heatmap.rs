//! Heat maps (a value over a regular x–y grid, e.g. top-surface stress over x and time) as
//! PNG and SVG: several panels side by side on one shared colour scale, with a colour bar.

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use super::{PlotError, register_font};

/// One panel: `values[j][i]` at (`xs[i]`, `ys[j]`); both axes sorted ascending.
#[derive(Debug, Clone)]
pub struct Heatmap {
    pub title: String,
    pub xs: Vec<f64>,
    pub ys: Vec<f64>,
    pub values: Vec<Vec<f64>>,
}

/// Panels sharing axes labels and one colour scale.
#[derive(Debug, Clone)]
pub struct HeatmapFigure {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub value_label: String,
    pub panels: Vec<Heatmap>,
    /// Panels per row.
    pub columns: usize,
    pub size_px: (u32, u32),
}

// Viridis at nine stops (perceptually uniform, readable in grey).
const VIRIDIS: [(u8, u8, u8); 9] = [
    (68, 1, 84),
    (71, 44, 122),
    (59, 81, 139),
    (44, 113, 142),
    (33, 144, 141),
    (39, 173, 129),
    (92, 200, 99),
    (170, 220, 50),
    (253, 231, 37),
];

/// Colour of `t` in [0, 1] (clamped).
pub fn viridis(t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = t * (VIRIDIS.len() - 1) as f64;
    let i = (s.floor() as usize).min(VIRIDIS.len() - 2);
    let f = s - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let mix = |x: u8, y: u8| (f64::from(x) + f * (f64::from(y) - f64::from(x))).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// Cell edges around sorted sample positions (midpoints, half a spacing beyond the ends).
fn edges(v: &[f64]) -> Vec<f64> {
    let n = v.len();
    let mut e = Vec::with_capacity(n + 1);
    if n == 1 {
        return vec![v[0] - 0.5, v[0] + 0.5];
    }
    e.push(v[0] - 0.5 * (v[1] - v[0]));
    for w in v.windows(2) {
        e.push(0.5 * (w[0] + w[1]));
    }
    e.push(v[n - 1] + 0.5 * (v[n - 1] - v[n - 2]));
    e
}

fn check(fig: &HeatmapFigure) -> Result<(f64, f64), String> {
    if fig.panels.is_empty() || fig.columns == 0 {
        return Err(format!("heat map {:?} has no panels", fig.title));
    }
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for p in &fig.panels {
        let sorted = |v: &[f64]| !v.is_empty() && v.windows(2).all(|w| w[0] < w[1]);
        if !sorted(&p.xs) || !sorted(&p.ys) {
            return Err(format!(
                "panel {:?}: axes must be non-empty and increasing",
                p.title
            ));
        }
        if p.values.len() != p.ys.len() || p.values.iter().any(|r| r.len() != p.xs.len()) {
            return Err(format!("panel {:?}: values are not ys x xs", p.title));
        }
        for v in p.values.iter().flatten().filter(|v| v.is_finite()) {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
    }
    if lo > hi {
        return Err(PlotError::Empty(fig.title.clone()).to_string());
    }
    if hi - lo < 1e-12 * hi.abs().max(1e-300) {
        // A uniform field (the tissue alone): centre it in the scale.
        let pad = 0.05 * hi.abs().max(1e-12);
        return Ok((lo - pad, hi + pad));
    }
    Ok((lo, hi))
}

/// Write `fig` as `dir/stem.png` and `dir/stem.svg`.
pub fn write_heatmaps(
    fig: &HeatmapFigure,
    dir: &Path,
    stem: &str,
) -> Result<Vec<PathBuf>, PlotError> {
    register_font();
    std::fs::create_dir_all(dir).map_err(|source| PlotError::Dir {
        dir: dir.display().to_string(),
        source,
    })?;
    let png = dir.join(format!("{stem}.png"));
    let svg = dir.join(format!("{stem}.svg"));
    let fail = |file: &Path| {
        let file = file.display().to_string();
        move |message| PlotError::Draw { file, message }
    };
    draw(
        fig,
        BitMapBackend::new(&png, fig.size_px).into_drawing_area(),
    )
    .map_err(fail(&png))?;
    draw(fig, SVGBackend::new(&svg, fig.size_px).into_drawing_area()).map_err(fail(&svg))?;
    Ok(vec![png, svg])
}

fn draw<DB: DrawingBackend>(
    fig: &HeatmapFigure,
    root: DrawingArea<DB, plotters::coord::Shift>,
) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let (lo, hi) = check(fig)?;
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root
        .titled(&fig.title, ("sans-serif", 24))
        .map_err(|e| err(&e))?;
    let (w, _) = root.dim_in_pixel();
    let (main, bar) = root.split_horizontally(w.saturating_sub(150));
    let rows = fig.panels.len().div_ceil(fig.columns);
    let areas = main.split_evenly((rows, fig.columns));
    for (p, area) in fig.panels.iter().zip(&areas) {
        let (xe, ye) = (edges(&p.xs), edges(&p.ys));
        let mut ctx = ChartBuilder::on(area)
            .caption(&p.title, ("sans-serif", 18))
            .margin(8)
            .x_label_area_size(40)
            .y_label_area_size(55)
            .build_cartesian_2d(xe[0]..xe[xe.len() - 1], ye[0]..ye[ye.len() - 1])
            .map_err(|e| err(&e))?;
        ctx.configure_mesh()
            .disable_mesh()
            .x_desc(&fig.x_label)
            .y_desc(&fig.y_label)
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(|e| err(&e))?;
        let cells = p.values.iter().enumerate().flat_map(|(j, row)| {
            let (xe, ye) = (&xe, &ye);
            row.iter().enumerate().map(move |(i, v)| {
                let c = if v.is_finite() {
                    viridis((v - lo) / (hi - lo))
                } else {
                    RGBColor(255, 255, 255)
                };
                Rectangle::new([(xe[i], ye[j]), (xe[i + 1], ye[j + 1])], c.filled())
            })
        });
        ctx.draw_series(cells).map_err(|e| err(&e))?;
    }
    // Colour bar.
    let mut ctx = ChartBuilder::on(&bar)
        .margin_top(40)
        .margin_bottom(50)
        .margin_left(20)
        .margin_right(10)
        .y_label_area_size(75)
        .build_cartesian_2d(0.0..1.0, lo..hi)
        .map_err(|e| err(&e))?;
    ctx.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc(&fig.value_label)
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(|e| err(&e))?;
    let steps = 100;
    ctx.draw_series((0..steps).map(|k| {
        let a = lo + (hi - lo) * k as f64 / steps as f64;
        let b = lo + (hi - lo) * (k + 1) as f64 / steps as f64;
        Rectangle::new(
            [(0.0, a), (1.0, b)],
            viridis((k as f64 + 0.5) / steps as f64).filled(),
        )
    }))
    .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn figure(values: Vec<Vec<f64>>) -> HeatmapFigure {
        HeatmapFigure {
            title: "test".into(),
            x_label: "x (mm)".into(),
            y_label: "t (s)".into(),
            value_label: "von Mises (kPa)".into(),
            panels: vec![Heatmap {
                title: "a".into(),
                xs: vec![0.0, 1.0, 2.0],
                ys: vec![0.0, 0.5],
                values,
            }],
            columns: 2,
            size_px: (600, 400),
        }
    }

    #[test]
    fn colour_scale_ends_and_midpoint() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(0.5), RGBColor(33, 144, 141));
        assert_eq!(viridis(f64::NAN), viridis(0.0));
        assert_eq!(viridis(7.0), viridis(1.0));
    }

    #[test]
    fn cell_edges_bracket_the_samples() {
        assert_eq!(edges(&[0.0, 1.0, 3.0]), vec![-0.5, 0.5, 2.0, 4.0]);
    }

    #[test]
    fn writes_png_and_svg_and_refuses_bad_shapes() {
        let dir = std::env::temp_dir().join(format!("pulsetrack-heat-{}", std::process::id()));
        let ok = figure(vec![vec![1.0, 2.0, 3.0], vec![2.0, 3.0, f64::NAN]]);
        let files = write_heatmaps(&ok, &dir, "heat").unwrap();
        for f in &files {
            assert!(std::fs::metadata(f).unwrap().len() > 1000);
        }
        let svg = std::fs::read_to_string(&files[1]).unwrap();
        assert!(svg.contains("von Mises (kPa)"));
        // A uniform field still draws (the tissue alone is uniform).
        assert!(write_heatmaps(&figure(vec![vec![2.0; 3]; 2]), &dir, "uniform").is_ok());
        let ragged = figure(vec![vec![1.0, 2.0], vec![2.0, 3.0, 4.0]]);
        assert!(matches!(
            write_heatmaps(&ragged, &dir, "bad"),
            Err(PlotError::Draw { .. })
        ));
        let empty = figure(vec![vec![f64::NAN; 3]; 2]);
        assert!(write_heatmaps(&empty, &dir, "empty").is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
