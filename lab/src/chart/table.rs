//! The chart's equal-error table as Markdown (OUT/chart.md): per panel, the most accurate
//! setting of each method and of each peer, with its time, its errors and its speed-up at
//! equal error over Cycles and over Occlux's own Monte Carlo, most accurate first; then the
//! path tracers' curves. Made from the same measurements as the JSON, so the docs quote a
//! command's output rather than hand-copied numbers.

use super::measure::{CurvePoint, Panel};
use super::pareto::Reached;

/// One row of a panel's table.
struct Row {
    what: String,
    seconds: f64,
    rel_rmse: f64,
    rel_bias: f64,
    model_rel_rmse: Option<f64>,
    front: bool,
    vs_cycles: Option<(f64, Option<Reached>)>,
    vs_monte_carlo: Option<f64>,
}

/// The least-error item of each group of `items` (grouped by `key`, in first-seen order).
fn best_of<T>(items: &[T], key: impl Fn(&T) -> &str, error: impl Fn(&T) -> f64) -> Vec<&T> {
    let mut best: Vec<&T> = vec![];
    for item in items {
        match best.iter_mut().find(|b| key(b) == key(item)) {
            Some(b) if error(item) < error(b) => *b = item,
            Some(_) => {}
            None => best.push(item),
        }
    }
    best
}

fn rows(panel: &Panel) -> Vec<Row> {
    let mut rows: Vec<Row> = best_of(&panel.points, |p| p.method, |p| p.rel_rmse)
        .into_iter()
        .map(|p| Row {
            what: if p.setting.is_empty() {
                p.method.to_owned()
            } else {
                format!("{} ({})", p.method, p.setting)
            },
            seconds: p.seconds,
            rel_rmse: p.rel_rmse,
            rel_bias: p.rel_bias,
            model_rel_rmse: p.model_rel_rmse,
            front: p.pareto,
            vs_cycles: p.speedup_vs_cycles.map(|s| (s, p.cycles_reached)),
            vs_monte_carlo: p.speedup_vs_monte_carlo,
        })
        .collect();
    for series in &panel.peers {
        let best = series
            .points
            .iter()
            .min_by(|a, b| a.rel_rmse.total_cmp(&b.rel_rmse));
        if let Some(p) = best {
            rows.push(Row {
                what: format!("{} ({})", series.peer, p.setting),
                seconds: p.seconds,
                rel_rmse: p.rel_rmse,
                rel_bias: p.rel_bias,
                model_rel_rmse: None,
                front: false,
                vs_cycles: p.speedup_vs_cycles.map(|s| (s, None)),
                vs_monte_carlo: p.speedup_vs_monte_carlo,
            });
        }
    }
    rows.sort_by(|a, b| a.rel_rmse.total_cmp(&b.rel_rmse));
    rows
}

fn speedup(value: Option<f64>) -> String {
    value.map_or("-".to_owned(), |s| format!("{s:.2}x"))
}

fn curve_text(name: &str, curve: &[CurvePoint]) -> String {
    let points: Vec<String> = curve
        .iter()
        .map(|c| {
            format!(
                "{} spp {:.2} s, {:.3} ({:+.1} %)",
                c.spp,
                c.seconds,
                c.rel_rmse,
                100.0 * c.rel_bias
            )
        })
        .collect();
    format!("- {name}: {}\n", points.join("; "))
}

/// The Markdown of every panel.
pub fn markdown(panels: &[Panel]) -> String {
    let mut text = String::from(
        "Per scene and lighting, the most accurate setting of each method and peer, most \
         accurate first. Error: relative RMSE and bias over the volume's pixels against the \
         path-traced truth; \"own model\": against the reference of the method's own model. \
         Speed-ups at equal error: the path tracer's time to the same error over the point's \
         time (\"at 1 spp\": the first sample is already as accurate, so it is a bias floor). \
         Front: on the Pareto front of time against error among the panel's methods.\n",
    );
    for panel in panels {
        text += &format!(
            "\n### {}, {} (truth: {} spp, noise {:.3})\n\n",
            panel.scene, panel.lighting, panel.reference_spp, panel.reference_noise
        );
        text += "| method (setting) | time | rel. RMSE | bias | own model | front | vs Cycles | vs Occlux MC |\n";
        text += "|---|---|---|---|---|---|---|---|\n";
        for row in rows(panel) {
            let vs_cycles = match row.vs_cycles {
                Some((s, Some(Reached::FirstSample))) => format!("{s:.2}x at 1 spp"),
                other => speedup(other.map(|(s, _)| s)),
            };
            text += &format!(
                "| {} | {:.3} s | {:.3} | {:+.1} % | {} | {} | {} | {} |\n",
                row.what,
                row.seconds,
                row.rel_rmse,
                100.0 * row.rel_bias,
                row.model_rel_rmse
                    .map_or("-".to_owned(), |e| format!("{e:.3}")),
                if row.front { "yes" } else { "" },
                vs_cycles,
                speedup(row.vs_monte_carlo),
            );
        }
        text += "\n";
        text += &curve_text("Occlux Monte Carlo", &panel.monte_carlo);
        if !panel.cycles.is_empty() {
            text += &curve_text("Cycles", &panel.cycles);
        }
        let mut said: Vec<&str> = vec![];
        for series in &panel.peers {
            if !said.contains(&series.timing.as_str()) {
                text += &format!("- {} times: {}\n", series.peer, series.timing);
                said.push(&series.timing);
            }
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_group_keeps_its_least_error_in_first_seen_order() {
        let items = [("a", 3.0), ("b", 2.0), ("a", 1.0), ("b", 5.0), ("c", 4.0)];
        let best = best_of(&items, |i| i.0, |i| i.1);
        assert_eq!(best, [&("a", 1.0), &("b", 2.0), &("c", 4.0)]);
    }
}
