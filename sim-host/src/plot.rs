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
