//! The diagnosis report: residual before and after, its autocorrelation with bounds, residual
//! against load, and the candidates' table.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use plotters::prelude::*;

use crate::chip_diagnosis::{Diagnosis, Report};
use tactile_ident::Series;

fn residual(prediction: &[f64], data: &Series) -> Vec<f64> {
    prediction
        .iter()
        .zip(&data.strain_pct)
        .zip(&data.excluded)
        .map(|((a, b), x)| if *x { 0.0 } else { a - b })
        .collect()
}

/// Writes `report.md`, `residual.png` and `diagnosis.json` into `dir`.
pub fn diagnosis_report(
    dir: &Path,
    source: &Path,
    data: &Series,
    report: &Report,
) -> Result<PathBuf, Box<dyn std::error::Error>> {
    std::fs::create_dir_all(dir)?;
    crate::plot::register_font_once();
    let d = &report.diagnosis;
    let r0 = residual(&d.model.baseline_prediction, data);
    let r1 = residual(&d.model.prediction, data);
    residual_figure(&dir.join("residual.png"), data, d, &r0, &r1)?;
    let md = markdown(source, d);
    std::fs::write(
        dir.join("diagnosis.json"),
        serde_json::to_string_pretty(report)?,
    )?;
    let path = dir.join("report.md");
    std::fs::write(&path, md)?;
    Ok(path)
}

/// The figure: the residual against time before and after, their autocorrelations with the
/// whiteness bounds, and the residual against load.
/// The least to the greatest of `values` (at least 1e-6 wide): a chart's axis.
fn span<'v>(values: impl IntoIterator<Item = &'v f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .into_iter()
        .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
    lo..hi.max(lo + 1e-6)
}

/// One of the figure's charts on `area`, with its caption and room for the axes' labels.
fn panel<'a, 'b, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, plotters::coord::Shift>,
    caption: &str,
) -> ChartBuilder<'a, 'b, DB> {
    let mut builder = ChartBuilder::on(area);
    builder
        .caption(caption, ("sans-serif", 20))
        .margin(8)
        .x_label_area_size(30)
        .y_label_area_size(60);
    builder
}

fn residual_figure(
    png: &Path,
    data: &Series,
    d: &Diagnosis,
    r0: &[f64],
    r1: &[f64],
) -> Result<(), Box<dyn std::error::Error>> {
    let root = BitMapBackend::new(png, (1200, 1100)).into_drawing_area();
    root.fill(&WHITE)?;
    let areas = root.split_evenly((3, 1));
    // 1. Residual against time, before and after.
    let every = (r0.len() / 4000).max(1);
    let t = |i: usize| i as f64 * data.dt_s;
    let residuals = span(r0.iter().chain(r1));
    let mut c = panel(&areas[0], "residual (model − measured strain)")
        .build_cartesian_2d(0.0..t(r0.len()), residuals.clone())?;
    c.configure_mesh()
        .x_desc("time (s)")
        .y_desc("strain (%)")
        .draw()?;
    for (r, color, name) in [(r0, RED, "before"), (r1, BLUE, "after")] {
        c.draw_series(LineSeries::new(
            r.iter().enumerate().step_by(every).map(|(i, v)| (t(i), *v)),
            color,
        ))?
        .label(name)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
    }
    c.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    // 2. Autocorrelation with bounds.
    let b = d.residual_before.acf_bound;
    // The whiteness tests run at most at 200 Hz (tactile_ident::residual::on_common_scale).
    let lag_s = data
        .dt_s
        .max(1.0 / tactile_ident::residual::WHITENESS_RATE_HZ);
    let mut c = panel(&areas[1], "residual autocorrelation (95 % bounds dashed)")
        .build_cartesian_2d(0.0..50.0 * lag_s, -0.2..1.0)?;
    c.configure_mesh().x_desc("lag (s)").y_desc("rho").draw()?;
    for (acf, color, name) in [
        (&d.residual_before.acf, RED, "before"),
        (&d.residual_after.acf, BLUE, "after"),
    ] {
        c.draw_series(LineSeries::new(
            acf.iter()
                .enumerate()
                .map(|(k, v)| ((k + 1) as f64 * lag_s, *v)),
            color,
        ))?
        .label(name)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
    }
    for s in [b, -b] {
        c.draw_series(DashedLineSeries::new(
            vec![(0.0, s), (50.0 * lag_s, s)],
            5,
            5,
            BLACK.into(),
        ))?;
    }
    c.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    // 3. Residual against load.
    let mut c = panel(&areas[2], "residual against load")
        .build_cartesian_2d(span(&data.force_g), residuals)?;
    c.configure_mesh()
        .x_desc("force (g)")
        .y_desc("strain (%)")
        .draw()?;
    c.draw_series(
        data.force_g
            .iter()
            .zip(r0)
            .step_by(every * 2)
            .map(|(f, r)| Circle::new((*f, *r), 1, RED.filled())),
    )?;
    c.draw_series(
        data.force_g
            .iter()
            .zip(r1)
            .step_by(every * 2)
            .map(|(f, r)| Circle::new((*f, *r), 1, BLUE.filled())),
    )?;
    root.present()?;
    Ok(())
}

/// The report's text: the verdict, the summary and the candidates' table, and the figure.
fn markdown(source: &Path, d: &Diagnosis) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "# Diagnosis of `{}`\n", source.display());
    let _ = writeln!(
        md,
        "Verdict: **{}** (accepted, in order: {}).\n",
        d.effect,
        if d.effects.is_empty() {
            "none".to_string()
        } else {
            d.effects
                .iter()
                .map(|e| e.name())
                .collect::<Vec<_>>()
                .join(", ")
        }
    );
    let _ = writeln!(md, "```text\n{}```\n", d.summary);
    let _ = writeln!(md, "| candidate | round | variant | held-out (% strain) | held-out (g) | p (paired, folds) | Ljung–Box / 5 % level | accepted |\n|---|---|---|---|---|---|---|---|");
    for c in &d.candidates {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.4} | {:.3} | {:.1e} | {:.1} | {} |",
            c.effect,
            c.round,
            c.variant,
            c.held_out_rms_pct,
            c.held_out_rms_g,
            c.p_value,
            c.ljung_box_ratio,
            if c.accepted { "yes" } else { "" }
        );
    }
    let _ = writeln!(
        md,
        "\n![residual, autocorrelation, residual against load](residual.png)\n"
    );
    md
}
