//! PNG plots of a run, laid out like the memo's graphs: command and force, strain, and the
//! force estimate against the true force.

use std::path::Path;
use std::sync::Once;

use plotters::prelude::*;

use crate::rig::TickRecord;

static FONT: Once = Once::new();

/// Makes the compiled-in font available to every plot.
pub fn register_font_once() {
    FONT.call_once(|| {
        // The font is compiled in, so plots render the same on a machine without fonts.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
    });
}

type Series<'a> = (&'a str, RGBColor, Vec<(f64, f64)>);

fn panel(
    area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    title: &str,
    y_label: &str,
    series: &[Series<'_>],
) -> Result<(), Box<dyn std::error::Error>> {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (_, _, pts) in series {
        for &(x, y) in pts.iter().filter(|p| p.1.is_finite()) {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
    }
    if x0 >= x1 {
        x1 = x0 + 1.0;
    }
    let pad = ((y1 - y0) * 0.05).max(0.1);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 20))
        .margin(8)
        .x_label_area_size(30)
        .y_label_area_size(50)
        .build_cartesian_2d(x0..x1, (y0 - pad)..(y1 + pad))?;
    chart
        .configure_mesh()
        .x_desc("time (s)")
        .y_desc(y_label)
        .label_style(("sans-serif", 13))
        .draw()?;
    for (name, color, pts) in series {
        let color = *color;
        chart
            .draw_series(LineSeries::new(
                pts.iter().copied().filter(|p| p.1.is_finite()),
                color.stroke_width(1),
            ))?
            .label(*name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 13))
        .draw()?;
    Ok(())
}

/// Writes `path` with three panels. Long runs are thinned to about 4000 points per series.
pub fn plot_run(
    path: &Path,
    title: &str,
    ticks: &[TickRecord],
) -> Result<(), Box<dyn std::error::Error>> {
    register_font_once();
    let every = (ticks.len() / 4000).max(1);
    let pick = |f: &dyn Fn(&TickRecord) -> f32| -> Vec<(f64, f64)> {
        ticks
            .iter()
            .step_by(every)
            .map(|r| (r.t_s, f64::from(f(r))))
            .collect()
    };
    let root = BitMapBackend::new(path, (1200, 1000)).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((3, 1));
    panel(
        &panels[0],
        &format!("{title}: command and force"),
        "force (g)",
        &[
            ("command", BLACK, pick(&|r| r.command_g)),
            ("gauge", BLUE, pick(&|r| r.sensed_g)),
            ("contact force", RED, pick(&|r| r.true_force_g)),
        ],
    )?;
    panel(
        &panels[1],
        "strain of the element under the probe",
        "strain (%)",
        &[("strain", BLUE, pick(&|r| r.strain_pct))],
    )?;
    panel(
        &panels[2],
        "force from strain (on-chip inverse second-order model)",
        "force (g)",
        &[
            ("contact force", RED, pick(&|r| r.true_force_g)),
            ("estimate", GREEN, pick(&|r| r.estimate_g)),
        ],
    )?;
    root.present()?;
    Ok(())
}

/// One frame of the array for the heat map: each taxel's force estimate, where the probe was,
/// where the chip located it and the centroid, mm from the centre of taxel r0c0.
pub struct ArraySnapshot {
    pub t_s: f64,
    pub forces_g: [[f32; 8]; 8],
    pub truth_mm: (f64, f64),
    pub located_mm: Option<(f64, f64)>,
    pub centroid_mm: Option<(f64, f64)>,
}

/// The array as heat maps at a few instants of a moving press (each taxel's estimate, the true
/// contact a black ring, the located one a blue cross, the centroid a grey square), over the
/// track's x and y against time: truth, located, centroid (`track`: t, then those six).
pub fn plot_array_track(
    path: &Path,
    pitch_mm: f64,
    snapshots: &[ArraySnapshot],
    track: &[(f64, [f64; 6])],
) -> Result<(), Box<dyn std::error::Error>> {
    register_font_once();
    let root = BitMapBackend::new(path, (1400, 1000)).into_drawing_area();
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(420);
    let peak = snapshots
        .iter()
        .flat_map(|s| s.forces_g.iter().flatten())
        .fold(1e-3f32, |m, f| if f.is_finite() { m.max(*f) } else { m });
    let cells = top.split_evenly((1, snapshots.len().max(1)));
    let half = 0.5 * pitch_mm;
    let edge = 7.0 * pitch_mm + half;
    for (area, s) in cells.iter().zip(snapshots) {
        let mut chart = ChartBuilder::on(area)
            .caption(format!("t = {:.2} s", s.t_s), ("sans-serif", 18))
            .margin(8)
            .x_label_area_size(25)
            .y_label_area_size(35)
            .build_cartesian_2d(-half..edge, edge..-half)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("x (mm)")
            .y_desc("y (mm)")
            .label_style(("sans-serif", 12))
            .draw()?;
        for (r, row) in s.forces_g.iter().enumerate() {
            for (c, f) in row.iter().enumerate() {
                let v = if f.is_finite() {
                    (f / peak).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let fade = (255.0 * (1.0 - v)) as u8;
                let (x, y) = (c as f64 * pitch_mm, r as f64 * pitch_mm);
                chart.draw_series(std::iter::once(Rectangle::new(
                    [(x - half, y - half), (x + half, y + half)],
                    RGBColor(255, fade, fade).filled(),
                )))?;
            }
        }
        chart.draw_series(std::iter::once(Circle::new(
            s.truth_mm,
            9,
            BLACK.stroke_width(2),
        )))?;
        if let Some(p) = s.centroid_mm {
            chart.draw_series(std::iter::once(Rectangle::new(
                [(p.0 - 0.4, p.1 - 0.4), (p.0 + 0.4, p.1 + 0.4)],
                RGBColor(110, 110, 110).filled(),
            )))?;
        }
        if let Some(p) = s.located_mm {
            chart.draw_series(std::iter::once(Cross::new(p, 7, BLUE.stroke_width(2))))?;
        }
    }
    let lower = bottom.split_evenly((2, 1));
    let series = |k: usize| -> Vec<(f64, f64)> { track.iter().map(|(t, v)| (*t, v[k])).collect() };
    for (area, (axis, k)) in lower.iter().zip([("x", 0usize), ("y", 1)]) {
        panel(
            area,
            &format!("the contact's {axis} over the press's track"),
            &format!("{axis} (mm)"),
            &[
                ("true", BLACK, series(k)),
                ("located (chip)", BLUE, series(k + 2)),
                ("centroid", RGBColor(150, 150, 150), series(k + 4)),
            ],
        )?;
    }
    root.present()?;
    Ok(())
}
