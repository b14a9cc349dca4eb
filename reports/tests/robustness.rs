//! Odd input: missing parts, empty vectors, a single noise level, NaN and
//! infinities, hostile text, and random reports. Rendering never panics; only
//! inconsistent lengths are refused.

mod common;

use common::{Rng, parse, sel, text};
use reports::{
    Accuracy, ComparisonRow, ComparisonTable, EfficiencyRow, FailureCount, Frf, ModeShape, Panel,
    Quantity, Report, ReportError, Representative, RouteErrors, RouteRow, Scale, SetupRow,
    Stability, StabilizationPoint, Study,
};

fn bare_study(name: &str) -> Study {
    Study {
        name: name.into(),
        description: String::new(),
        seed: 0,
        setup: vec![],
        representative: None,
        accuracy: Accuracy {
            axis_name: None,
            panels: vec![],
            efficiency: vec![],
            routes: vec![],
        },
    }
}

fn report_of(studies: Vec<Study>) -> Report {
    Report {
        title: "t".into(),
        frameid_version: "0".into(),
        command: "frameid".into(),
        studies,
    }
}

fn empty_representative() -> Representative {
    Representative {
        noise_fraction: f64::NAN,
        dt_s: 0.0,
        hit_floor: 0,
        force: vec![],
        accelerations: vec![vec![]],
        hankel_singular_values: vec![],
        order: 0,
        modes: vec![],
        stabilization: vec![],
        frf: vec![],
        tables: vec![],
        warnings: vec![],
        hit_quality: vec![],
    }
}

fn quantity(key: &str, median: Vec<f64>) -> Quantity {
    Quantity {
        key: key.into(),
        label: key.into(),
        unit: String::new(),
        group: "g".into(),
        p5: median.iter().map(|m| m * 0.5).collect(),
        p95: median.iter().map(|m| m * 2.0).collect(),
        median,
        bound: None,
        scale: None,
    }
}

fn panel(levels: Vec<f64>, quantities: Vec<Quantity>) -> Panel {
    Panel {
        axis_value: None,
        trials: vec![10; levels.len()],
        failure_rate: vec![0.0; levels.len()],
        noise_levels: levels,
        failure_reasons: vec![],
        quantities,
    }
}

#[test]
fn a_study_with_nothing_in_it_still_has_its_sections() {
    let html = reports::render(&report_of(vec![bare_study("empty")])).unwrap();
    let doc = parse(&html);
    assert!(doc.errors.is_empty(), "{:?}", doc.errors);
    for class in ["setup", "representative", "comparison", "accuracy"] {
        let s = doc.select(&sel(&format!("section.{class}"))).next();
        assert!(s.is_some(), "section.{class}");
    }
    assert_eq!(doc.select(&sel("svg")).count(), 0);
    assert!(
        doc.select(&sel("section.representative .missing"))
            .next()
            .is_some()
    );
    // And a report without any study.
    let html = reports::render(&report_of(vec![])).unwrap();
    assert!(parse(&html).errors.is_empty());
}

#[test]
fn empty_vectors_everywhere() {
    let mut s = bare_study("empty vectors");
    s.representative = Some(empty_representative());
    s.accuracy.panels = vec![panel(vec![], vec![quantity("q", vec![])])];
    s.accuracy.efficiency = vec![EfficiencyRow {
        noise_level: f64::NAN,
        estimator: String::new(),
        quantity: String::new(),
        efficiency: f64::NAN,
        se: Some(f64::NAN),
    }];
    let html = reports::render(&report_of(vec![s])).unwrap();
    let doc = parse(&html);
    assert!(doc.errors.is_empty(), "{:?}", doc.errors);
    for svg in doc.select(&sel("svg")) {
        assert!(svg.select(&sel("title")).next().is_some());
    }
}

#[test]
fn a_single_noise_level_draws_a_marker_and_a_range() {
    let mut s = bare_study("one level");
    let mut q = quantity("f1", vec![0.01]);
    q.bound = Some(vec![0.004]);
    s.accuracy.panels = vec![panel(vec![0.02], vec![q])];
    let doc = parse(&reports::render(&report_of(vec![s])).unwrap());
    let svg = doc
        .select(&sel("figure[data-quantity=\"f1\"] svg"))
        .next()
        .unwrap();
    let markers = svg
        .select(&sel(
            "g.series[data-series=\"median\"][data-role=\"markers\"] > *",
        ))
        .count();
    assert_eq!(markers, 1);
    let band = svg
        .select(&sel("g.series[data-series=\"band\"] > *"))
        .count();
    assert_eq!(band, 1, "the p5-p95 range is drawn as a bar");
    let ticks: Vec<String> = svg
        .select(&sel("g.axes text[text-anchor=\"middle\"]"))
        .map(text)
        .collect();
    assert_eq!(ticks, ["2"], "the only level is the only x tick");
}

#[test]
fn non_finite_values_are_skipped_and_said_so() {
    let mut s = bare_study("nan");
    let mut rep = empty_representative();
    rep.dt_s = 0.01;
    rep.force = vec![0.0, 1.0, f64::NAN, 2.0, f64::INFINITY, 0.5];
    rep.hankel_singular_values = vec![10.0, 1.0, 0.0, -1.0, f64::NAN, 1e-3];
    rep.order = 2;
    s.representative = Some(rep);
    let mut q = quantity("err", vec![1e-9, f64::NAN, 1e-4, 1e-3, 1e-2]);
    q.p5[0] = 0.0;
    // A negative value makes the automatic choice linear; ask for log.
    q.p5[2] = -1e-5;
    q.scale = Some(Scale::Log);
    s.accuracy.panels = vec![panel(vec![0.0, 0.001, 0.01, 0.03, 0.1], vec![q])];
    let doc = parse(&reports::render(&report_of(vec![s])).unwrap());

    let force = doc.select(&sel("figure#study-1-force")).next().unwrap();
    let points: usize = force
        .select(&sel("g.series[data-series=\"force\"]"))
        .next()
        .unwrap()
        .value()
        .attr("data-points")
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(points, 4);
    assert!(text(force.select(&sel("figcaption")).next().unwrap()).contains("2 non-finite"));

    let hankel = doc.select(&sel("figure#study-1-hankel")).next().unwrap();
    let caption = text(hankel.select(&sel("figcaption")).next().unwrap());
    assert!(caption.contains("≤ 0"), "{caption}");

    let fig = doc
        .select(&sel("figure[data-quantity=\"err\"]"))
        .next()
        .unwrap();
    let markers = fig
        .select(&sel(
            "g.series[data-series=\"median\"][data-role=\"markers\"] > *",
        ))
        .count();
    assert_eq!(markers, 4, "the NaN median is left out");
    let caption = text(fig.select(&sel("figcaption")).next().unwrap());
    assert!(caption.contains("No median at 0.1 %"), "{caption}");
    assert!(caption.contains("drawn at its bottom"), "{caption}");
}

#[test]
fn log_scale_requested_without_positive_values_falls_back_to_linear() {
    let mut s = bare_study("log");
    let mut q = quantity("neg", vec![-1.0, 0.0, -2.0]);
    q.scale = Some(Scale::Log);
    s.accuracy.panels = vec![panel(vec![0.0, 0.01, 0.1], vec![q])];
    let doc = parse(&reports::render(&report_of(vec![s])).unwrap());
    let fig = doc
        .select(&sel("figure[data-quantity=\"neg\"]"))
        .next()
        .unwrap();
    assert!(text(fig).contains("the axis is linear"));
    assert_eq!(
        fig.select(&sel(
            "g.series[data-series=\"median\"][data-role=\"markers\"] > *"
        ))
        .count(),
        3
    );
}

#[test]
fn inconsistent_lengths_are_refused_with_a_precise_message() {
    let mut s = bare_study("case 1");
    s.accuracy.panels = vec![panel(
        vec![0.0, 0.01, 0.1],
        vec![quantity("f1_rel", vec![1.0, 2.0])],
    )];
    let err = reports::render(&report_of(vec![s])).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, ReportError::Inconsistent { .. }));
    for part in [
        "case 1",
        "panel 1",
        "f1_rel",
        "median has 2 value(s)",
        "3 noise levels",
    ] {
        assert!(msg.contains(part), "{msg:?} mentions {part:?}");
    }

    let mut s = bare_study("frf");
    let mut rep = empty_representative();
    rep.frf = vec![Frf {
        output: "floor 2".into(),
        frequency_hz: vec![0.0, 1.0, 2.0],
        measured: vec![[1.0, 0.0]; 2],
        identified: vec![],
        truth: None,
        reference: None,
        coherence: None,
    }];
    s.representative = Some(rep);
    let msg = reports::render(&report_of(vec![s]))
        .unwrap_err()
        .to_string();
    assert!(msg.contains("floor 2") && msg.contains("measured"), "{msg}");
}

const HOSTILE: &str = "<script>alert(\"x\")</script> & 'q' </svg></figure> <!-- ]]> \u{0}\u{7}";

#[test]
fn text_from_the_data_is_escaped() {
    let mut report = common::report();
    report.title = HOSTILE.into();
    report.command = HOSTILE.into();
    let study = &mut report.studies[1];
    study.name = HOSTILE.into();
    study.description = HOSTILE.into();
    study.setup.push(SetupRow {
        label: HOSTILE.into(),
        value: HOSTILE.into(),
    });
    study.accuracy.axis_name = Some(HOSTILE.into());
    for p in &mut study.accuracy.panels {
        p.axis_value = Some(HOSTILE.into());
        p.failure_reasons.push(FailureCount {
            noise_level: 0.1,
            reason: HOSTILE.into(),
            count: 1,
        });
        p.quantities[0].label = HOSTILE.into();
        p.quantities[0].unit = HOSTILE.into();
        p.quantities[0].group = HOSTILE.into();
        p.quantities[0].key = HOSTILE.into();
    }
    let rep = study.representative.as_mut().unwrap();
    rep.warnings.push(HOSTILE.into());
    rep.frf[0].output = HOSTILE.into();
    rep.tables[0].title = HOSTILE.into();
    rep.tables[0].unit = HOSTILE.into();
    rep.tables[0].rows[0].label = HOSTILE.into();
    let html = reports::render(&report).unwrap();
    let doc = parse(&html);
    assert!(doc.errors.is_empty(), "{:?}", doc.errors);
    assert_eq!(doc.select(&sel("script")).count(), 0);
    assert_eq!(
        doc.select(&sel("h1")).map(text).next().unwrap(),
        HOSTILE.replace(['\u{0}', '\u{7}'], "").trim()
    );
    assert!(!html.contains("<script"));
    // Charts still all have their groups: nothing closed them early.
    for svg in doc.select(&sel("svg")) {
        assert!(svg.select(&sel("g.axes")).next().is_some());
    }
}

// ---- random reports ----

fn value(rng: &mut Rng) -> f64 {
    match rng.below(12) {
        0 => f64::NAN,
        1 => f64::INFINITY,
        2 => f64::NEG_INFINITY,
        3 => 0.0,
        4 => -0.0,
        5 => 1e300 * rng.normal(),
        6 => 1e-300 * rng.uniform(),
        7 => f64::MIN_POSITIVE / 4.0,
        8 => -rng.uniform(),
        _ => rng.normal() * 10f64.powi(rng.below(20) as i32 - 10),
    }
}

fn values(rng: &mut Rng, n: usize) -> Vec<f64> {
    (0..n).map(|_| value(rng)).collect()
}

fn complex(rng: &mut Rng, n: usize) -> Vec<[f64; 2]> {
    (0..n).map(|_| [value(rng), value(rng)]).collect()
}

fn string(rng: &mut Rng) -> String {
    const PIECES: [&str; 12] = [
        "", "a", "ξ₁", "<", "&amp;", "\"", "'", "</svg>", " ", "—", "\u{202E}", "1e-3 %",
    ];
    (0..rng.below(4))
        .map(|_| PIECES[rng.below(PIECES.len())])
        .collect()
}

/// A length that mostly agrees with `n`.
fn len_like(rng: &mut Rng, n: usize) -> usize {
    if rng.uniform() < 0.95 {
        n
    } else {
        rng.below(n + 2)
    }
}

fn values_about(rng: &mut Rng, n: usize) -> Vec<f64> {
    let k = len_like(rng, n);
    values(rng, k)
}

fn complex_about(rng: &mut Rng, n: usize) -> Vec<[f64; 2]> {
    let k = len_like(rng, n);
    complex(rng, k)
}

fn random_report(seed: u64) -> Report {
    let mut rng = Rng::new(seed);
    let studies = (0..1 + rng.below(2))
        .map(|_| {
            let representative = (rng.uniform() < 0.8).then(|| {
                let samples = [0, 1, 2, 17, 1500, 3000][rng.below(6)];
                let nf = rng.below(40);
                let ndof = rng.below(4);
                Representative {
                    noise_fraction: value(&mut rng),
                    dt_s: [1.0 / 64.0, 0.0, -1.0, f64::NAN, 1e-9][rng.below(5)],
                    hit_floor: rng.below(4),
                    force: values(&mut rng, samples),
                    accelerations: (0..ndof).map(|_| values(&mut rng, samples)).collect(),
                    hankel_singular_values: values_about(&mut rng, 30),
                    order: rng.below(40),
                    modes: (0..rng.below(3))
                        .map(|_| ModeShape {
                            frequency_hz: value(&mut rng),
                            damping_ratio: value(&mut rng),
                            shape: complex(&mut rng, ndof),
                            truth: (rng.uniform() < 0.5).then(|| complex(&mut rng, ndof)),
                        })
                        .collect(),
                    stabilization: (0..rng.below(60))
                        .map(|_| StabilizationPoint {
                            order: rng.below(50),
                            frequency_hz: value(&mut rng),
                            damping_ratio: value(&mut rng),
                            status: [
                                Stability::New,
                                Stability::Frequency,
                                Stability::Damping,
                                Stability::Stable,
                            ][rng.below(4)],
                        })
                        .collect(),
                    frf: (0..rng.below(3))
                        .map(|_| Frf {
                            output: string(&mut rng),
                            frequency_hz: values(&mut rng, nf),
                            measured: complex_about(&mut rng, nf),
                            identified: complex(&mut rng, nf),
                            truth: (rng.uniform() < 0.5).then(|| complex(&mut rng, nf)),
                            reference: None,
                            coherence: None,
                        })
                        .collect(),
                    tables: (0..rng.below(3))
                        .map(|_| ComparisonTable {
                            title: string(&mut rng),
                            unit: string(&mut rng),
                            rows: (0..rng.below(4))
                                .map(|_| ComparisonRow {
                                    label: string(&mut rng),
                                    truth: value(&mut rng),
                                    identified: value(&mut rng),
                                    std: None,
                                })
                                .collect(),
                        })
                        .collect(),
                    warnings: (0..rng.below(2)).map(|_| string(&mut rng)).collect(),
                    hit_quality: vec![],
                }
            });
            let npanels = rng.below(4);
            let panels = (0..npanels)
                .map(|_| {
                    let n = rng.below(6);
                    let levels: Vec<f64> = (0..n)
                        .map(|_| match rng.below(5) {
                            0 => 0.0,
                            1 => value(&mut rng),
                            _ => [0.001, 0.01, 0.03, 0.1, 0.5][rng.below(5)],
                        })
                        .collect();
                    Panel {
                        axis_value: (rng.uniform() < 0.5).then(|| string(&mut rng)),
                        trials: (0..len_like(&mut rng, n)).map(|_| rng.below(300)).collect(),
                        failure_rate: values_about(&mut rng, n),
                        failure_reasons: (0..rng.below(4))
                            .map(|_| FailureCount {
                                noise_level: levels
                                    .get(rng.below(n.max(1)))
                                    .copied()
                                    .unwrap_or(0.2),
                                reason: string(&mut rng),
                                count: rng.below(50),
                            })
                            .collect(),
                        quantities: (0..rng.below(5))
                            .map(|_| Quantity {
                                key: ["f1_rel", "damping_mkr_err", "damping_rayleigh_err", "x", ""]
                                    [rng.below(5)]
                                .into(),
                                label: string(&mut rng),
                                unit: string(&mut rng),
                                group: string(&mut rng),
                                median: values_about(&mut rng, n),
                                p5: values(&mut rng, n),
                                p95: values(&mut rng, n),
                                bound: (rng.uniform() < 0.3).then(|| values(&mut rng, n)),
                                scale: [None, Some(Scale::Log), Some(Scale::Linear)][rng.below(3)],
                            })
                            .collect(),
                        noise_levels: levels,
                    }
                })
                .collect();
            Study {
                name: string(&mut rng),
                description: string(&mut rng),
                seed: rng.next_u64(),
                setup: (0..rng.below(3))
                    .map(|_| SetupRow {
                        label: string(&mut rng),
                        value: string(&mut rng),
                    })
                    .collect(),
                representative,
                accuracy: Accuracy {
                    axis_name: (rng.uniform() < 0.5).then(|| string(&mut rng)),
                    panels,
                    efficiency: (0..rng.below(4))
                        .map(|_| EfficiencyRow {
                            noise_level: value(&mut rng),
                            estimator: string(&mut rng),
                            quantity: string(&mut rng),
                            efficiency: value(&mut rng),
                            se: (rng.uniform() < 0.5).then(|| value(&mut rng)),
                        })
                        .collect(),
                    routes: (0..rng.below(3))
                        .map(|_| {
                            let mut errors = || RouteErrors {
                                trials: rng.below(30),
                                median: value(&mut rng),
                                rms: value(&mut rng),
                                efficiency: value(&mut rng),
                                median_se: (rng.uniform() < 0.5).then(|| value(&mut rng)),
                                efficiency_se: (rng.uniform() < 0.5).then(|| value(&mut rng)),
                            };
                            let (time, frf) = (errors(), errors());
                            RouteRow {
                                noise_level: value(&mut rng),
                                quantity: string(&mut rng),
                                time,
                                frf,
                            }
                        })
                        .collect(),
                },
            }
        })
        .collect();
    Report {
        title: string(&mut rng),
        frameid_version: string(&mut rng),
        command: string(&mut rng),
        studies,
    }
}

#[test]
fn random_reports_never_panic() {
    let (mut ok, mut refused) = (0, 0);
    for seed in 0..250 {
        let report = random_report(seed);
        match reports::render(&report) {
            Ok(html) => {
                ok += 1;
                let doc = parse(&html);
                assert!(doc.errors.is_empty(), "seed {seed}: {:?}", doc.errors);
                assert_eq!(doc.select(&sel("script")).count(), 0);
                for svg in doc.select(&sel("svg")) {
                    assert!(svg.select(&sel("title")).next().is_some(), "seed {seed}");
                    // Every coordinate is a number: nothing NaN reached the SVG.
                    for el in svg.descendants().filter_map(scraper::ElementRef::wrap) {
                        for (name, v) in el.value().attrs() {
                            if ["x", "y", "cx", "cy", "x1", "x2", "y1", "y2", "points"]
                                .contains(&name)
                            {
                                assert!(
                                    !v.contains("NaN") && !v.contains("inf"),
                                    "seed {seed}: {name}={v}"
                                );
                            }
                        }
                    }
                }
            }
            Err(ReportError::Inconsistent { .. }) => refused += 1,
            Err(e) => panic!("seed {seed}: unexpected error {e}"),
        }
    }
    assert!(ok > 150, "{ok} rendered, {refused} refused");
    assert!(refused > 0, "the generator also makes inconsistent reports");
}
