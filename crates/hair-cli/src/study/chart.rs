//! `study.png`: error against cost above, overlap against cost below, one numbered point per
//! configuration in both, and the numbers listed beside them with each configuration's figures
//! (names written at the points overlap where several configurations cost about the same).

use super::{PolicyResult, Study};
use anyhow::Result;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

fn err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow::anyhow!("drawing the study chart: {e:?}")
}

/// `v` with two decimals, or two significant digits below 0.1 (the chaos floor can be a
/// fraction of a micrometre).
fn mm(v: f64) -> String {
    if v == 0.0 || !v.is_finite() || v.abs() >= 0.1 {
        format!("{v:.2}")
    } else {
        let decimals = (1.0 - v.abs().log10().floor()).clamp(2.0, 12.0) as usize;
        format!("{v:.decimals$}")
    }
}

/// The reference's colour.
const REFERENCE: RGBColor = RGBColor(200, 30, 30);
/// The colour of `fine`, the scene's own models at the finest level.
const SCENE_FINE: RGBColor = RGBColor(20, 150, 40);
/// Every other configuration's.
const OTHER: RGBColor = RGBColor(40, 70, 200);

/// How a configuration is drawn: the reference as a red triangle, `fine` as a green square
/// (the two hair-hair models side by side), the others as blue dots.
fn colour(study: &Study, p: &PolicyResult) -> RGBColor {
    if p.name == study.reference {
        REFERENCE
    } else if p.name == "fine" {
        SCENE_FINE
    } else {
        OTHER
    }
}

/// One panel: `value` of every configuration against its milliseconds per frame, with
/// `floor` (a label and a value) as a dashed line. Both axes are logarithmic: the errors span
/// from the chaos floor to whole strand lengths and the costs a factor of forty, and on linear
/// axes the configurations near the reference would sit on one another. A value at or below
/// zero (the reference's own error) is drawn at the foot of the axis.
fn panel(
    area: &DrawingArea<BitMapBackend, Shift>,
    study: &Study,
    caption: &str,
    y_desc: &str,
    value: impl Fn(&PolicyResult) -> f64,
    floor: Option<(String, f64)>,
) -> Result<()> {
    let positive = |v: f64| (v > 0.0 && v.is_finite()).then_some(v);
    let ms = study
        .policies
        .iter()
        .filter_map(|p| positive(p.ms_per_frame));
    let (min_ms, max_ms) = ms.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    let ys = study.policies.iter().map(&value);
    let ys = ys.chain(floor.iter().map(|f| f.1)).filter_map(positive);
    let (min_y, max_y) = ys.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    let (min_ms, max_ms) = if max_ms > 0.0 {
        (min_ms, max_ms)
    } else {
        (1.0, 1.0)
    };
    let (min_y, max_y) = if max_y > 0.0 {
        (min_y, max_y)
    } else {
        (1e-3, 1e-3)
    };
    let (x_start, x_end) = (min_ms * 0.8, max_ms * 1.25);
    let y_start = min_y * 0.4;
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 19))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (x_start..x_end).log_scale(),
            (y_start..max_y * 2.5).log_scale(),
        )
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("ms per frame (log)")
        .x_labels(8)
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_desc(y_desc)
        .y_labels(8)
        // Plotters' own labels for log ticks print the float as it is (0.6000000000000001),
        // and the long ones overran the axis.
        .y_label_formatter(&|y| mm(*y))
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(err)?;
    if let Some((label, y)) = floor {
        chart
            .draw_series(DashedLineSeries::new(
                [(x_start, y), (x_end, y)],
                6,
                4,
                REFERENCE.stroke_width(1),
            ))
            .map_err(err)?;
        chart
            .draw_series(std::iter::once(Text::new(
                label,
                (x_start * 1.02, y),
                ("sans-serif", 14).into_font().color(&REFERENCE),
            )))
            .map_err(err)?;
    }
    // The others first, so that the two models' marks lie on top.
    let mut order: Vec<usize> = (0..study.policies.len()).collect();
    order.sort_by_key(|&k| colour(study, &study.policies[k]) != OTHER);
    for k in order {
        let p = &study.policies[k];
        let xy = (p.ms_per_frame.max(x_start), value(p).max(y_start));
        let c = colour(study, p);
        let number = Text::new(
            format!("{}", k + 1),
            (7, -19),
            ("sans-serif", 15).into_font().color(&c),
        );
        // The number above and to the right of its point, clear of the mark.
        let drawn = if c == REFERENCE {
            chart.draw_series(std::iter::once(
                EmptyElement::at(xy) + TriangleMarker::new((0, 0), 8, c.filled()) + number,
            ))
        } else if c == SCENE_FINE {
            chart.draw_series(std::iter::once(
                EmptyElement::at(xy) + Rectangle::new([(-6, -6), (6, 6)], c.filled()) + number,
            ))
        } else {
            chart.draw_series(std::iter::once(
                EmptyElement::at(xy) + Circle::new((0, 0), 5, c.filled()) + number,
            ))
        };
        drawn.map_err(err)?;
    }
    Ok(())
}

/// Draws the chart to `path`.
pub fn chart(path: &Path, study: &Study) -> Result<()> {
    crate::chart::register_font();
    let root = BitMapBackend::new(path, (1760, 960)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let (plots, legend) = root.split_horizontally(1000);
    let (upper, lower) = plots.split_vertically(490);
    let floor = study.chaos_floor_rms_mm;
    panel(
        &upper,
        study,
        &format!(
            "{}: RMS distance from {} vs cost ({} frames, {} threads)",
            study.scene, study.reference, study.frames, study.threads
        ),
        "RMS error of rendered strands (mm, log)",
        |p| p.rms_error_mm,
        Some((format!("chaos floor {} mm", mm(floor)), floor)),
    )?;
    panel(
        &lower,
        study,
        &format!(
            "overlap of crossing hair sections vs cost (every {}th frame)",
            study.sample_every
        ),
        "mean depth of overlapping pairs (mm, log)",
        |p| p.overlap_mm,
        None,
    )?;
    let font = ("sans-serif", 14).into_font();
    let lines = [
        format!(
            "{} (red triangle, at the foot of the error axis) is the reference;",
            study.reference
        ),
        "fine (green square) the scene's own models at the finest level".into(),
        "configuration: ms per frame, RMS (max) error; RMS where seen; mean overlap".into(),
        "depth (overlapping pairs per sample); layer thickness".into(),
    ];
    for (k, line) in lines.iter().enumerate() {
        legend
            .draw(&Text::new(
                line.clone(),
                (0, 30 + 20 * k as i32),
                font.clone(),
            ))
            .map_err(err)?;
    }
    for (k, p) in study.policies.iter().enumerate() {
        let y = 130 + 24 * k as i32;
        legend
            .draw(&Text::new(
                format!(
                    "{:>2} {}: {:.1} ms, {} ({:.1}) mm; {} mm; {} mm ({:.0}); {:.1} mm",
                    k + 1,
                    p.name,
                    p.ms_per_frame,
                    mm(p.rms_error_mm),
                    p.max_error_mm,
                    mm(p.visible_rms_error_mm),
                    mm(p.overlap_mm),
                    p.overlap_pairs,
                    p.thickness_mm
                ),
                (0, y),
                font.clone().color(&colour(study, p)),
            ))
            .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    /// Two decimals from 0.1 up, two significant digits below.
    #[test]
    fn small_figures_keep_two_significant_digits() {
        assert_eq!(super::mm(0.0), "0.00");
        assert_eq!(super::mm(92.367), "92.37");
        assert_eq!(super::mm(0.451), "0.45");
        assert_eq!(super::mm(0.0493), "0.049");
        assert_eq!(super::mm(0.000342), "0.00034");
    }
}
