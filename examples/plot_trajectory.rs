//! Plots a sample trajectory (position, velocity, acceleration, jerk of three synchronized axes)
//! to `docs/img/trajectory.svg`:
//!
//! ```sh
//! cargo run --example plot_trajectory [-- OUTPUT.svg]
//! ```

use plotters::prelude::*;
use rmd_rt::traj::{Input, calculate};

/// Reads one quantity of a sampled state.
type Getter = fn(&rmd_rt::traj::AxisState) -> f64;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| concat!(env!("CARGO_MANIFEST_DIR"), "/docs/img/trajectory.svg").into());

    // Three joints in deg, deg/s, deg/s², deg/s³: axis 0 starts moving away from its target,
    // axis 1 has a long way to go (it sets the duration), axis 2 must arrive moving.
    let mut input = Input::<3>::with_limits(
        [180.0, 120.0, 90.0],
        [720.0, 400.0, 300.0],
        [6000.0, 3000.0, 2000.0],
    );
    input.current_position = [0.0, -45.0, 30.0];
    input.current_velocity = [-60.0, 0.0, 0.0];
    input.current_acceleration = [200.0, 0.0, 0.0];
    input.target_position = [40.0, 120.0, -20.0];
    input.target_velocity = [0.0, 0.0, -20.0];
    let traj = calculate(&input)?;
    let duration = traj.duration();
    println!(
        "duration {duration:.4} s, limiting axis {:?}",
        traj.limiting_axis()
    );

    let samples = 1000;
    let times: Vec<f64> = (0..=samples)
        .map(|k| duration * k as f64 / samples as f64)
        .collect();
    let states: Vec<_> = times.iter().map(|&t| traj.state_at(t)).collect();

    let root = SVGBackend::new(&out, (900, 1000)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(
        &format!("rmd-traj: 3 synchronized axes, duration {duration:.3} s"),
        ("sans-serif", 22),
    )?;
    let panels = root.split_evenly((4, 1));
    let quantities: [(&str, Getter); 4] = [
        ("position [deg]", |s| s.position),
        ("velocity [deg/s]", |s| s.velocity),
        ("acceleration [deg/s²]", |s| s.acceleration),
        ("jerk [deg/s³]", |s| s.jerk),
    ];
    let colors = [
        RGBColor(200, 30, 30),
        RGBColor(30, 60, 200),
        RGBColor(0, 150, 0),
    ];
    for (k, (panel, (label, get))) in panels.iter().zip(quantities).enumerate() {
        let values = states.iter().flat_map(|s| s.iter().map(get));
        let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(v), h.max(v))
        });
        let pad = 0.08 * (hi - lo).max(1e-9);
        let mut chart = ChartBuilder::on(panel)
            .margin(8)
            .x_label_area_size(28)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..duration, (lo - pad)..(hi + pad))?;
        chart
            .configure_mesh()
            .x_desc("time [s]")
            .y_desc(label)
            .light_line_style(WHITE)
            .draw()?;
        for axis in 0..3 {
            let color = colors[axis];
            chart
                .draw_series(LineSeries::new(
                    times.iter().zip(&states).map(|(&t, s)| (t, get(&s[axis]))),
                    color.stroke_width(2),
                ))?
                .label(format!("axis {axis}"))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                });
        }
        if k == 0 {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperLeft)
                .border_style(BLACK)
                .background_style(WHITE.mix(0.8))
                .draw()?;
        }
    }
    root.present()?;
    println!("wrote {out}");
    Ok(())
}
