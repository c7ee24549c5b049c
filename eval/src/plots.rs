//! PNG figures with `plotters`, drawn into an RGB buffer and encoded by the
//! host's own PNG writer. Text uses DejaVu Sans embedded in the binary (the
//! `dejavu` crate through plotters' `ab_glyph` backend), so nothing depends
//! on system fonts or fontconfig.

use std::ops::Range;
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

use reynoldsflow_host::io::image_file;

/// Colour of each curve kind: eight distinguishable hues.
pub const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),  // blue
    RGBColor(255, 127, 14),  // orange
    RGBColor(214, 39, 40),   // red
    RGBColor(148, 103, 189), // purple
    RGBColor(44, 160, 44),   // green
    RGBColor(127, 127, 127), // gray
    RGBColor(140, 86, 75),   // brown
    RGBColor(23, 190, 207),  // cyan
];

/// One curve.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Line colour.
    pub color: RGBColor,
    /// Points, in drawing order.
    pub points: Vec<(f64, f64)>,
    /// Dashed rather than solid.
    pub dashed: bool,
}

/// One chart of a figure.
#[derive(Clone, Debug)]
pub struct Panel {
    /// Caption above the chart.
    pub title: String,
    /// x axis description.
    pub x_label: String,
    /// y axis description.
    pub y_label: String,
    /// Logarithmic y axis (non-positive values are left out).
    pub log_y: bool,
    /// The curves.
    pub series: Vec<Series>,
}

/// A figure: a title, panels on a `rows × cols` grid, one shared legend.
#[derive(Clone, Debug)]
pub struct Figure {
    /// Title at the top.
    pub title: String,
    /// `(rows, cols)`.
    pub grid: (usize, usize),
    /// Panels, row by row.
    pub panels: Vec<Panel>,
    /// Pixel size `(width, height)`.
    pub size: (u32, u32),
}

fn register_font() -> Result<(), String> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err("the embedded font failed to load".to_owned())
    }
}

impl Figure {
    /// The figure as PNG bytes.
    pub fn to_png(&self) -> Result<Vec<u8>, String> {
        register_font()?;
        let (w, h) = self.size;
        let mut rgb = vec![0u8; 3 * w as usize * h as usize];
        {
            let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| e.to_string())?;
            let (top, rest) = root.split_vertically(36);
            top.draw_text(
                &self.title,
                &("sans-serif", 22).into_font().color(&BLACK),
                (12, 8),
            )
            .map_err(|e| e.to_string())?;
            let (body, legend) = rest.split_vertically(h as i32 - 36 - 34);
            self.draw_legend(&legend)?;
            let areas = body.split_evenly(self.grid);
            for (panel, area) in self.panels.iter().zip(&areas) {
                draw_panel(area, panel)?;
            }
            root.present().map_err(|e| e.to_string())?;
        }
        image_file::encode_png(w as usize, h as usize, &rgb).map_err(|e| e.to_string())
    }

    /// Every distinct curve label once, with its colour and dash.
    fn draw_legend<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let mut seen: Vec<(&str, RGBColor, bool)> = Vec::new();
        for s in self.panels.iter().flat_map(|p| &p.series) {
            if !seen.iter().any(|(l, _, _)| *l == s.label) {
                seen.push((&s.label, s.color, s.dashed));
            }
        }
        let font = ("sans-serif", 15).into_font().color(&BLACK);
        let mut x = 16;
        for (label, color, dashed) in seen {
            let y = 14;
            let style = color.stroke_width(3);
            if dashed {
                for k in 0..3 {
                    area.draw(&PathElement::new(
                        vec![(x + 10 * k, y), (x + 10 * k + 6, y)],
                        style,
                    ))
                    .map_err(|e| e.to_string())?;
                }
            } else {
                area.draw(&PathElement::new(vec![(x, y), (x + 26, y)], style))
                    .map_err(|e| e.to_string())?;
            }
            area.draw_text(label, &font, (x + 32, y - 8))
                .map_err(|e| e.to_string())?;
            let text_width = area
                .estimate_text_size(label, &font)
                .map_err(|e| e.to_string())?
                .0 as i32;
            x += 32 + text_width + 24;
        }
        Ok(())
    }
}

/// The span of `values` padded by 5 %, never empty.
fn padded(values: impl Iterator<Item = f64>) -> Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(v), h.max(v))
        });
    if !lo.is_finite() {
        return 0.0..1.0;
    }
    let span = (hi - lo).max(1e-9 * hi.abs().max(1.0));
    (lo - 0.05 * span)..(hi + 0.05 * span)
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
) -> Result<(), String> {
    let points = || panel.series.iter().flat_map(|s| s.points.iter().copied());
    let x = padded(points().map(|p| p.0));
    if panel.log_y {
        let positive = || points().map(|p| p.1).filter(|v| *v > 0.0 && v.is_finite());
        let lo = positive().fold(f64::INFINITY, f64::min);
        let hi = positive().fold(0.0, f64::max);
        let (lo, hi) = if lo.is_finite() {
            (lo / 1.6, hi * 1.6)
        } else {
            (0.1, 1.0)
        };
        draw_chart(area, panel, x, (lo..hi).log_scale())
    } else {
        let y = padded(points().map(|p| p.1).chain([0.0]));
        draw_chart(area, panel, x, y)
    }
}

fn draw_chart<DB: DrawingBackend, Y>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
    x: Range<f64>,
    y: Y,
) -> Result<(), String>
where
    Y: AsRangedCoord<Value = f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", 17))
        .margin(8)
        .x_label_area_size(38)
        .y_label_area_size(58)
        .build_cartesian_2d(x, y)
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc(panel.x_label.as_str())
        .y_desc(panel.y_label.as_str())
        .x_labels(6)
        .x_label_formatter(&|v| {
            // Whole numbers without a trailing ".0" (frame indices, levels).
            if (v - v.round()).abs() < 1e-9 {
                format!("{v:.0}")
            } else {
                format!("{v}")
            }
        })
        .y_labels(6)
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 14))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| err(&e))?;
    for s in &panel.series {
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|p| p.1.is_finite() && (!panel.log_y || p.1 > 0.0))
            .collect();
        let style = s.color.stroke_width(2);
        if s.dashed {
            chart
                .draw_series(DashedLineSeries::new(pts.clone(), 6, 4, style))
                .map_err(|e| err(&e))?;
        } else {
            chart
                .draw_series(LineSeries::new(pts.clone(), style))
                .map_err(|e| err(&e))?;
        }
        chart
            .draw_series(pts.iter().map(|&p| Circle::new(p, 3, s.color.filled())))
            .map_err(|e| err(&e))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use reynoldsflow_host::limits::Limits;

    #[test]
    fn a_figure_renders_to_a_png_with_ink() {
        let panel = |log_y| Panel {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            log_y,
            series: vec![
                Series {
                    label: "a".into(),
                    color: PALETTE[0],
                    points: vec![(0.0, 1.0), (1.0, 10.0), (2.0, 0.0)],
                    dashed: false,
                },
                Series {
                    label: "b".into(),
                    color: PALETTE[2],
                    points: vec![(0.0, 2.0), (2.0, 3.0)],
                    dashed: true,
                },
            ],
        };
        let fig = Figure {
            title: "test".into(),
            grid: (1, 2),
            panels: vec![panel(false), panel(true)],
            size: (500, 300),
        };
        let png = fig.to_png().unwrap();
        let img = image_file::decode_gray(&png, Limits::default()).unwrap();
        assert_eq!(img.size(), (500, 300));
        let dark = img.pixels.iter().filter(|&&p| p < 128).count();
        assert!(dark > 1000, "{dark} dark pixels");
    }
}
