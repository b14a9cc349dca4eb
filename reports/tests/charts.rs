//! Charts are drawn from the data: markers and vertices are counted and, where
//! it matters, placed.

mod common;

use common::{child_elements, parse, sel, text, vertices};
use reports::{Report, Stability};
use scraper::{ElementRef, Html};

fn render(report: &Report) -> Html {
    parse(&reports::render(report).expect("renders"))
}

fn chart<'a>(doc: &'a Html, id: &str) -> ElementRef<'a> {
    doc.select(&sel(&format!("figure#{id} svg")))
        .next()
        .unwrap_or_else(|| panic!("chart {id}"))
}

/// The elements drawn for a series with a role ("line", "markers",
/// "band", "rule").
fn group<'a>(svg: ElementRef<'a>, series: &str, role: &str) -> Option<ElementRef<'a>> {
    svg.select(&sel(&format!(
        "g.series[data-series=\"{series}\"][data-role=\"{role}\"]"
    )))
    .next()
}

fn markers<'a>(svg: ElementRef<'a>, series: &str) -> Vec<ElementRef<'a>> {
    group(svg, series, "markers")
        .map(child_elements)
        .unwrap_or_default()
}

fn points_attr(g: ElementRef<'_>) -> usize {
    g.value().attr("data-points").unwrap().parse().unwrap()
}

/// Centre (pixel) of a marker element.
fn centre(e: ElementRef<'_>) -> (f64, f64) {
    let a = |n: &str| e.value().attr(n).and_then(|v| v.parse::<f64>().ok());
    match e.value().name() {
        "circle" => (a("cx").unwrap(), a("cy").unwrap()),
        "rect" => (
            a("x").unwrap() + a("width").unwrap() / 2.0,
            a("y").unwrap() + a("height").unwrap() / 2.0,
        ),
        _ => {
            let v = vertices(e);
            let n = v.len() as f64;
            (
                v.iter().map(|p| p.0 as f64).sum::<f64>() / n,
                v.iter().map(|p| p.1 as f64).sum::<f64>() / n,
            )
        }
    }
}

/// The y axis as drawn: (pixel, value) of the numeric tick labels on the
/// left of the plot (right-anchored text).
fn y_ticks(svg: ElementRef<'_>) -> Vec<(f64, f64)> {
    svg.select(&sel("g.axes text[text-anchor=\"end\"]"))
        .filter_map(|t| {
            let y: f64 = t.value().attr("y")?.parse().ok()?;
            let v: f64 = text(t).replace('−', "-").parse().ok()?;
            Some((y, v))
        })
        .collect()
}

/// Pixel row of value `v` on a linear y axis, from its tick labels.
fn y_pixel(svg: ElementRef<'_>, v: f64) -> f64 {
    let t = y_ticks(svg);
    assert!(t.len() >= 2, "numeric y ticks");
    let ((y0, v0), (y1, v1)) = (t[0], t[t.len() - 1]);
    y0 + (v - v0) * (y1 - y0) / (v1 - v0)
}

#[test]
fn accuracy_charts_have_one_marker_per_noise_level_in_order() {
    let report = common::report();
    let doc = render(&report);
    let mut checked = 0;
    for (i, study) in report.studies.iter().enumerate() {
        for (pj, panel) in study.accuracy.panels.iter().enumerate() {
            let n = panel.noise_levels.len();
            for q in &panel.quantities {
                let Some(fig) = doc
                    .select(&sel(&format!(
                        "article#study-{} figure[data-chart=\"quantity\"][data-quantity=\"{}\"][data-panel=\"{}\"]",
                        i + 1,
                        q.key,
                        pj + 1
                    )))
                    .next()
                else {
                    // The two damping estimates are drawn together (below).
                    assert!(q.key.starts_with("damping_"), "chart for {}", q.key);
                    continue;
                };
                let svg = fig.select(&sel("svg")).next().unwrap();
                let m = markers(svg, "median");
                assert_eq!(m.len(), n, "{}: one median marker per noise level", q.key);
                assert_eq!(points_attr(group(svg, "band", "band").unwrap()), n);
                // Noise levels increase to the right, and the medians (which
                // grow with noise in this data) go up.
                let c: Vec<(f64, f64)> = m.iter().map(|e| centre(*e)).collect();
                assert!(c.windows(2).all(|w| w[1].0 > w[0].0), "{}: x order", q.key);
                let rising = q.median.windows(2).all(|w| w[1] > w[0]);
                if rising {
                    assert!(c.windows(2).all(|w| w[1].1 < w[0].1), "{}: y order", q.key);
                }
                // The median line leaves out the 0 % point (it sits left of the
                // log axis break) and joins the others.
                let line = group(svg, "median", "line").unwrap();
                let drawn: usize = child_elements(line)
                    .iter()
                    .map(|p| vertices(*p).len())
                    .sum();
                let positive = panel.noise_levels.iter().filter(|l| **l > 0.0).count();
                assert_eq!(drawn, positive, "{}: polyline vertices", q.key);
                // The bound: a dashed line exactly when given.
                match (&q.bound, group(svg, "bound", "line")) {
                    (Some(_), Some(g)) => {
                        assert_eq!(g.value().attr("stroke-dasharray"), Some("6 4"));
                        assert_eq!(points_attr(g), n);
                    }
                    (None, None) => {}
                    (b, g) => panic!(
                        "{}: bound {:?} but group {:?}",
                        q.key,
                        b.is_some(),
                        g.is_some()
                    ),
                }
                checked += 1;
            }
        }
    }
    assert!(checked >= 30, "{checked} quantity charts checked");
}

#[test]
fn both_damping_estimates_share_one_chart_per_panel() {
    let report = common::report();
    let doc = render(&report);
    for (i, study) in report.studies.iter().enumerate() {
        for (pj, panel) in study.accuracy.panels.iter().enumerate() {
            let svg = chart(&doc, &format!("study-{}-damping-p{}", i + 1, pj + 1));
            let n = panel.noise_levels.len();
            assert_eq!(markers(svg, "mkr-median").len(), n);
            assert_eq!(markers(svg, "rayleigh-median").len(), n);
            // MKR damping is far worse than Rayleigh in this data: its
            // markers sit higher at every noise level.
            for (a, b) in markers(svg, "mkr-median")
                .iter()
                .zip(markers(svg, "rayleigh-median").iter())
            {
                assert!(centre(*a).1 < centre(*b).1);
            }
            let rayleigh = panel
                .quantities
                .iter()
                .find(|q| q.key == "damping_rayleigh_err")
                .unwrap();
            assert_eq!(
                group(svg, "rayleigh-bound", "line").is_some(),
                rayleigh.bound.is_some()
            );
        }
    }
}

#[test]
fn failure_rate_chart_has_a_marker_per_level_and_the_table_has_the_reasons() {
    let report = common::report();
    let doc = render(&report);
    let study = &report.studies[0];
    let panel = &study.accuracy.panels[0];
    let svg = chart(&doc, "study-1-failure-p1");
    let m = markers(svg, "failure-rate");
    assert_eq!(m.len(), panel.noise_levels.len());
    // 0 % failures are drawn on the 0 tick.
    let zero = y_pixel(svg, 0.0);
    for (e, r) in m.iter().zip(&panel.failure_rate) {
        let y = centre(*e).1;
        assert!(
            (y - y_pixel(svg, r * 100.0)).abs() <= 1.5,
            "rate {r} at {y}, 0 at {zero}"
        );
    }
    let table = doc
        .select(&sel("article#study-1 table.failures"))
        .next()
        .unwrap();
    let reasons: Vec<String> = table.select(&sel("tr.reason th")).map(text).collect();
    let mut expected: Vec<String> = vec![];
    for f in &panel.failure_reasons {
        if !expected.contains(&f.reason) {
            expected.push(f.reason.clone());
        }
    }
    assert_eq!(reasons, expected);
    for tr in table.select(&sel("tr.reason")) {
        let reason = text(tr.select(&sel("th")).next().unwrap());
        let counts: Vec<usize> = tr
            .select(&sel("td"))
            .map(|td| text(td).parse().unwrap())
            .collect();
        for (l, c) in panel.noise_levels.iter().zip(counts) {
            let want: usize = panel
                .failure_reasons
                .iter()
                .filter(|f| f.reason == reason && f.noise_level == *l)
                .map(|f| f.count)
                .sum();
            assert_eq!(c, want);
        }
    }
}

#[test]
fn stabilization_diagram_has_one_marker_per_pole() {
    let report = common::report();
    let doc = render(&report);
    for (i, study) in report.studies.iter().enumerate() {
        let rep = study.representative.as_ref().unwrap();
        let svg = chart(&doc, &format!("study-{}-stabilization", i + 1));
        let mut total = 0;
        for (status, key) in [
            (Stability::New, "new"),
            (Stability::Frequency, "frequency"),
            (Stability::Damping, "damping"),
            (Stability::Stable, "stable"),
        ] {
            let want = rep
                .stabilization
                .iter()
                .filter(|p| p.status == status)
                .count();
            assert_eq!(markers(svg, key).len(), want, "{key}");
            total += want;
        }
        assert_eq!(total, rep.stabilization.len());
        // Identified modes and the chosen order are marked.
        for k in 1..=rep.modes.len() {
            assert!(group(svg, &format!("mode-{k}"), "rule").is_some());
        }
        assert!(group(svg, "order", "rule").is_some());
        // Higher orders are drawn higher.
        let stable: Vec<(f64, f64)> = markers(svg, "stable").iter().map(|e| centre(*e)).collect();
        let orders: Vec<usize> = rep
            .stabilization
            .iter()
            .filter(|p| p.status == Stability::Stable)
            .map(|p| p.order)
            .collect();
        for (a, b) in stable
            .iter()
            .zip(&orders)
            .zip(stable.iter().zip(&orders).skip(1))
        {
            if b.1 > a.1 {
                assert!(b.0.1 < a.0.1);
            }
        }
    }
}

#[test]
fn hankel_singular_values_split_at_the_chosen_order() {
    let report = common::report();
    let doc = render(&report);
    let rep = report.studies[0].representative.as_ref().unwrap();
    let svg = chart(&doc, "study-1-hankel");
    assert_eq!(markers(svg, "retained").len(), rep.order);
    assert_eq!(
        markers(svg, "discarded").len(),
        rep.hankel_singular_values.len() - rep.order
    );
    let rule = group(svg, "order", "rule").unwrap();
    assert_eq!(text(rule), format!("n = {}", rep.order));
    // Log axis: each decade down is the same distance.
    let c: Vec<f64> = markers(svg, "discarded")
        .iter()
        .map(|e| centre(*e).1)
        .collect();
    let steps: Vec<f64> = c.windows(2).map(|w| w[1] - w[0]).collect();
    let (lo, hi) = steps
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), s| (a.min(*s), b.max(*s)));
    assert!(
        hi - lo <= 1.5,
        "geometric series on a log axis: equal steps {lo}..{hi}"
    );
}

#[test]
fn short_records_are_drawn_sample_by_sample() {
    let samples = 300;
    let report = common::report_with_samples(samples);
    let doc = render(&report);
    let rep = report.studies[0].representative.as_ref().unwrap();
    let force = group(chart(&doc, "study-1-force"), "force", "line").unwrap();
    assert_eq!(points_attr(force), samples);
    let v: Vec<(i32, i32)> = child_elements(force)
        .iter()
        .flat_map(|p| vertices(*p))
        .collect();
    assert_eq!(v.len(), samples, "one vertex per sample");
    assert!(v.windows(2).all(|w| w[1].0 > w[0].0), "time increases");
    for (j, rec) in rep.accelerations.iter().enumerate() {
        let g = group(
            chart(&doc, &format!("study-1-acceleration-{}", j + 1)),
            "acceleration",
            "line",
        )
        .unwrap();
        assert_eq!(points_attr(g), rec.len());
        let n: usize = child_elements(g).iter().map(|p| vertices(*p).len()).sum();
        assert_eq!(n, rec.len());
    }
}

#[test]
fn long_records_keep_their_peaks() {
    let report = common::report();
    let doc = render(&report);
    let rep = report.studies[0].representative.as_ref().unwrap();
    assert_eq!(rep.force.len(), common::SAMPLES);
    let svg = chart(&doc, "study-1-force");
    let force = group(svg, "force", "line").unwrap();
    assert_eq!(
        points_attr(force),
        rep.force.len(),
        "every sample is represented"
    );
    let v: Vec<(i32, i32)> = child_elements(force)
        .iter()
        .flat_map(|p| vertices(*p))
        .collect();
    assert!(
        v.len() < rep.force.len() / 2,
        "{} vertices: reduced to an envelope",
        v.len()
    );
    let top = v.iter().map(|p| p.1).min().unwrap() as f64;
    let bottom = v.iter().map(|p| p.1).max().unwrap() as f64;
    let (fmin, fmax) = rep
        .force
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), f| (a.min(*f), b.max(*f)));
    assert!((top - y_pixel(svg, fmax)).abs() <= 1.5, "peak {fmax} kept");
    assert!(
        (bottom - y_pixel(svg, fmin)).abs() <= 1.5,
        "trough {fmin} kept"
    );
    // The same for the floor accelerations.
    for (j, rec) in rep.accelerations.iter().enumerate() {
        let svg = chart(&doc, &format!("study-1-acceleration-{}", j + 1));
        let g = group(svg, "acceleration", "line").unwrap();
        let v: Vec<(i32, i32)> = child_elements(g)
            .iter()
            .flat_map(|p| vertices(*p))
            .collect();
        let (amin, amax) = rec
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), f| (a.min(*f), b.max(*f)));
        let top = v.iter().map(|p| p.1).min().unwrap() as f64;
        let bottom = v.iter().map(|p| p.1).max().unwrap() as f64;
        assert!((top - y_pixel(svg, amax)).abs() <= 1.5);
        assert!((bottom - y_pixel(svg, amin)).abs() <= 1.5);
    }
}

#[test]
fn mode_shapes_and_frfs_are_drawn_from_their_vectors() {
    let report = common::report();
    let doc = render(&report);
    for (i, study) in report.studies.iter().enumerate() {
        let rep = study.representative.as_ref().unwrap();
        for (k, m) in rep.modes.iter().enumerate() {
            for part in ["magnitude", "phase"] {
                let svg = chart(&doc, &format!("study-{}-mode-{}-{part}", i + 1, k + 1));
                assert_eq!(markers(svg, "identified").len(), m.shape.len());
                assert_eq!(
                    markers(svg, "truth").len(),
                    m.truth.as_ref().map_or(0, Vec::len)
                );
            }
            // Magnitude 1 (the normalising component) sits on the 1.0 tick.
            let svg = chart(&doc, &format!("study-{}-mode-{}-magnitude", i + 1, k + 1));
            let top = markers(svg, "identified")
                .iter()
                .map(|e| centre(*e).1)
                .fold(f64::MAX, f64::min);
            assert!((top - y_pixel(svg, 1.0)).abs() <= 1.5);
        }
        for (j, f) in rep.frf.iter().enumerate() {
            let svg = chart(&doc, &format!("study-{}-frf-{}-magnitude", i + 1, j + 1));
            let finite = |h: &[[f64; 2]]| h.iter().filter(|c| c[0].hypot(c[1]) > 0.0).count();
            assert_eq!(
                points_attr(group(svg, "measured", "line").unwrap()),
                finite(&f.measured)
            );
            assert_eq!(
                points_attr(group(svg, "identified", "line").unwrap()),
                finite(&f.identified)
            );
            assert_eq!(
                group(svg, "truth", "line").map(points_attr),
                f.truth.as_ref().map(|t| finite(t))
            );
        }
    }
}
