//! A realistic synthetic report (2-DOF frames after the paper's section 4)
//! and helpers to inspect the rendered HTML.
#![allow(dead_code)]

use reports::{
    Accuracy, ComparisonRow, ComparisonTable, EfficiencyRow, FailureCount, Frf, ModeShape, Panel,
    Quantity, Report, Representative, SetupRow, Stability, StabilizationPoint, Study,
};
use scraper::{ElementRef, Html, Selector};

/// SplitMix64: small, seeded, good enough for test data.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Roughly standard normal (sum of uniforms).
    pub fn normal(&mut self) -> f64 {
        (0..12).map(|_| self.uniform()).sum::<f64>() - 6.0
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.uniform() * n as f64) as usize % n.max(1)
    }
}

pub const NOISE_LEVELS: [f64; 5] = [0.0, 0.001, 0.01, 0.03, 0.1];
pub const SAMPLES: usize = 2048;
pub const DT: f64 = 1.0 / 64.0;

/// A 2-DOF frame of the fixtures: a `testkit` frame and the Rayleigh
/// coefficients its damping was built with (shown in the set-up table, and
/// giving the modal damping ratios `alpha / (2 w) + beta w / 2`).
#[derive(Clone)]
pub struct Frame {
    pub frame: testkit::ShearFrame,
    pub alpha: f64,
    pub beta: f64,
}

/// The paper's case 1.
pub fn case1() -> Frame {
    let (alpha, beta) = testkit::PAPER_CASE1_RAYLEIGH;
    Frame {
        frame: testkit::paper_case1(),
        alpha,
        beta,
    }
}

/// The paper's case 2.
pub fn case2() -> Frame {
    let (alpha, beta) = testkit::PAPER_CASE2_RAYLEIGH;
    Frame {
        frame: testkit::paper_case2(),
        alpha,
        beta,
    }
}

fn array(m: &impl std::ops::Index<(usize, usize), Output = f64>) -> [[f64; 2]; 2] {
    [[m[(0, 0)], m[(0, 1)]], [m[(1, 0)], m[(1, 1)]]]
}

impl Frame {
    pub fn m(&self) -> [[f64; 2]; 2] {
        array(&self.frame.mass)
    }

    pub fn k(&self) -> [[f64; 2]; 2] {
        array(&self.frame.stiffness)
    }

    pub fn damping(&self) -> [[f64; 2]; 2] {
        array(&self.frame.damping)
    }

    /// Undamped natural frequencies (Hz), ascending, their Rayleigh damping
    /// ratios, and mode shapes scaled to a largest component of 1.
    pub fn modes(&self) -> Vec<(f64, f64, [f64; 2])> {
        self.frame
            .undamped_modes()
            .into_iter()
            .map(|(f, phi)| {
                let w = 2.0 * std::f64::consts::PI * f;
                let xi = self.alpha / (2.0 * w) + self.beta * w / 2.0;
                (f, xi, [phi[0], phi[1]])
            })
            .collect()
    }

    /// Accelerance `[re, im]` of both floors to a force at floor 1 at `f`
    /// Hz, with K and the damping scaled by `scale_k` and `scale_r`.
    pub fn frf(&self, f: f64, scale_k: f64, scale_r: f64) -> [[f64; 2]; 2] {
        let scaled = testkit::ShearFrame::new(
            self.frame.mass.clone(),
            &self.frame.stiffness * scale_k,
            &self.frame.damping * scale_r,
        );
        let h = scaled.accelerance(0, f);
        [[h[0].re, h[0].im], [h[1].re, h[1].im]]
    }
}

/// A relative-error quantity `[key, label, group]` whose median grows as
/// `floor + slope * level`.
fn quantity(
    [key, label, group]: [&str; 3],
    levels: &[f64],
    floor: f64,
    slope: f64,
    with_bound: bool,
) -> Quantity {
    let median: Vec<f64> = levels.iter().map(|l| floor + slope * l).collect();
    Quantity {
        key: key.into(),
        label: label.into(),
        unit: String::new(),
        group: group.into(),
        p5: median.iter().map(|m| 0.35 * m).collect(),
        p95: median.iter().map(|m| 2.8 * m).collect(),
        bound: with_bound.then(|| median.iter().map(|m| 0.8 * m).collect()),
        median,
        scale: None,
    }
}

pub fn panel(axis_value: Option<&str>, levels: &[f64], severity: f64) -> Panel {
    let n = levels.len();
    let failure_rate: Vec<f64> = levels
        .iter()
        .map(|l| (severity * (l - 0.02)).clamp(0.0, 1.0))
        .collect();
    let trials = vec![200; n];
    let mut failure_reasons = vec![];
    for (l, r) in levels.iter().zip(&failure_rate) {
        let failed = (r * 200.0).round() as usize;
        if failed > 0 {
            failure_reasons.push(FailureCount {
                noise_level: *l,
                reason: "order selection: no singular value gap".into(),
                count: failed - failed / 3,
            });
            failure_reasons.push(FailureCount {
                noise_level: *l,
                reason: "MKR: mass matrix not positive definite".into(),
                count: failed / 3,
            });
        }
    }
    let mut stiffness = quantity(
        ["stiffness_fro", "‖K̂ − K‖ / ‖K‖", "matrices"],
        levels,
        1e-12,
        0.4 * severity,
        false,
    );
    // Exact identification at zero noise: a 5th percentile of exactly 0.
    stiffness.p5[0] = 0.0;
    Panel {
        axis_value: axis_value.map(Into::into),
        noise_levels: levels.to_vec(),
        trials,
        failure_rate,
        failure_reasons,
        quantities: vec![
            quantity(
                ["f1_rel", "f₁ relative error", "frequency"],
                levels,
                1e-13,
                0.02 * severity,
                true,
            ),
            quantity(
                ["f2_rel", "f₂ relative error", "frequency"],
                levels,
                2e-13,
                0.01 * severity,
                true,
            ),
            quantity(
                ["xi1_rel", "ξ₁ relative error", "damping ratio"],
                levels,
                1e-10,
                1.5 * severity,
                true,
            ),
            quantity(
                ["xi2_rel", "ξ₂ relative error", "damping ratio"],
                levels,
                3e-10,
                2.5 * severity,
                false,
            ),
            quantity(
                ["mac1", "1 − MAC, mode 1", "mode shape"],
                levels,
                1e-15,
                0.05 * severity,
                false,
            ),
            Quantity {
                key: "mpc1".into(),
                label: "MPC, mode 1".into(),
                unit: "-".into(),
                group: "mode shape".into(),
                median: levels.iter().map(|l| 1.0 - 0.3 * l).collect(),
                p5: levels.iter().map(|l| 1.0 - 0.8 * l).collect(),
                p95: levels.iter().map(|l| 1.0 - 0.05 * l).collect(),
                bound: None,
                scale: None,
            },
            quantity(
                ["mass_fro", "‖M̂ − M‖ / ‖M‖", "matrices"],
                levels,
                1e-12,
                0.5 * severity,
                false,
            ),
            stiffness,
            quantity(
                ["damping_mkr_err", "MKR ‖R̂ − R‖ / ‖R‖", "damping matrices"],
                levels,
                0.8,
                900.0 * severity,
                false,
            ),
            quantity(
                [
                    "damping_rayleigh_err",
                    "Rayleigh ‖R̂ − R‖ / ‖R‖",
                    "damping matrices",
                ],
                levels,
                1e-9,
                3.0 * severity,
                true,
            ),
        ],
    }
}

fn efficiency(levels: &[f64]) -> Vec<EfficiencyRow> {
    let mut rows = vec![];
    for (quantity, base) in [("f₁", 0.95), ("ξ₁", 0.8)] {
        for (i, &l) in levels.iter().enumerate().filter(|(_, l)| **l > 0.0) {
            rows.push(EfficiencyRow {
                noise_level: l,
                estimator: "ERA/DC".into(),
                quantity: quantity.into(),
                efficiency: base - 0.05 * i as f64,
                se: None,
            });
        }
    }
    rows
}

pub fn representative(
    frame: &Frame,
    noise: f64,
    with_truth: bool,
    samples: usize,
    seed: u64,
) -> Representative {
    let mut rng = Rng::new(seed);
    let modes = frame.modes();
    let pretrigger = 32.min(samples / 4);
    let force: Vec<f64> = (0..samples)
        .map(|i| {
            let pulse = match i.checked_sub(pretrigger) {
                Some(0) => 1.72,
                Some(1) => 0.31,
                _ => 0.0,
            };
            pulse + noise * 0.05 * rng.normal()
        })
        .collect();
    let accelerations: Vec<Vec<f64>> = (0..2)
        .map(|floor| {
            (0..samples)
                .map(|i| {
                    let Some(k) = i.checked_sub(pretrigger) else {
                        return noise * 2.0 * rng.normal();
                    };
                    let t = k as f64 * DT;
                    let mut y = if k == 0 {
                        3.64 * 1.72 * (1 - floor) as f64
                    } else {
                        0.0
                    };
                    for (f, xi, phi) in &modes {
                        let w = 2.0 * std::f64::consts::PI * f;
                        let wd = w * (1.0 - xi * xi).sqrt();
                        y += 6.0 * phi[0] * phi[floor] * (-xi * w * t).exp() * (wd * t).sin();
                    }
                    y + noise * 2.0 * rng.normal()
                })
                .collect()
        })
        .collect();
    let mut hankel = vec![2.1e3, 1.4e3, 41.0, 27.0];
    for i in 0..96 {
        hankel.push(10f64.powf(-1.0 - 13.0 * i as f64 / 95.0) * (1.0 + 100.0 * noise));
    }
    let mode_shapes: Vec<ModeShape> = modes
        .iter()
        .map(|(f, xi, phi)| {
            let shape = [
                [phi[0] * (1.0 + 0.002 * rng.normal()), 0.004 * rng.normal()],
                [phi[1] * (1.0 + 0.002 * rng.normal()), 0.004 * rng.normal()],
            ];
            let shape = shape
                .iter()
                .map(|c| if c[0].abs() > 0.999 { [1.0, 0.0] } else { *c })
                .collect();
            ModeShape {
                frequency_hz: f * (1.0 + 0.002 * rng.normal()),
                damping_ratio: xi * (1.0 + 0.05 * rng.normal()),
                shape,
                truth: with_truth.then(|| phi.iter().map(|&v| [v, 0.0]).collect()),
            }
        })
        .collect();
    let mut stabilization = vec![];
    for order in (2..=40).step_by(2) {
        for (m, (f, xi, _)) in modes.iter().enumerate() {
            if order < 2 * (m + 1) {
                continue;
            }
            let status = match order - 2 * (m + 1) {
                0 => Stability::New,
                2 => Stability::Frequency,
                4 => Stability::Damping,
                _ => Stability::Stable,
            };
            stabilization.push(StabilizationPoint {
                order,
                frequency_hz: f * (1.0 + 0.001 * rng.normal()),
                damping_ratio: xi * (1.0 + 0.02 * rng.normal()),
                status,
            });
        }
        let spurious = (order / 2).saturating_sub(modes.iter().filter(|(_, _, _)| true).count());
        for _ in 0..spurious {
            stabilization.push(StabilizationPoint {
                order,
                frequency_hz: 0.5 + 31.0 * rng.uniform(),
                damping_ratio: 0.2 * rng.uniform(),
                status: if rng.uniform() < 0.8 {
                    Stability::New
                } else {
                    Stability::Frequency
                },
            });
        }
    }
    let freqs: Vec<f64> = (0..513).map(|i| i as f64 * 32.0 / 512.0).collect();
    let frf: Vec<Frf> = (0..2)
        .map(|out| {
            let truth: Vec<[f64; 2]> = freqs.iter().map(|&f| frame.frf(f, 1.0, 1.0)[out]).collect();
            let identified: Vec<[f64; 2]> = freqs
                .iter()
                .map(|&f| frame.frf(f, 1.003, 1.2)[out])
                .collect();
            let measured: Vec<[f64; 2]> = truth
                .iter()
                .map(|c| {
                    let e = 0.02 + noise;
                    [
                        c[0] * (1.0 + e * rng.normal()) + 0.01 * e * rng.normal(),
                        c[1] * (1.0 + e * rng.normal()),
                    ]
                })
                .collect();
            Frf {
                output: format!("floor {}", out + 1),
                frequency_hz: freqs.clone(),
                measured,
                identified,
                truth: with_truth.then_some(truth),
                reference: None,
                coherence: None,
            }
        })
        .collect();
    let r = frame.damping();
    let tables = vec![
        ComparisonTable {
            title: "Natural frequencies".into(),
            unit: "Hz".into(),
            rows: modes
                .iter()
                .zip(&mode_shapes)
                .enumerate()
                .map(|(i, ((f, _, _), m))| ComparisonRow {
                    label: format!("f{}", i + 1),
                    truth: *f,
                    identified: m.frequency_hz,
                    std: None,
                })
                .collect(),
        },
        ComparisonTable {
            title: "Damping ratios".into(),
            unit: "-".into(),
            rows: modes
                .iter()
                .zip(&mode_shapes)
                .enumerate()
                .map(|(i, ((_, xi, _), m))| ComparisonRow {
                    label: format!("ξ{}", i + 1),
                    truth: *xi,
                    identified: m.damping_ratio,
                    std: None,
                })
                .collect(),
        },
        matrix_table("Mass matrix M", "kg", frame.m(), [1.0012, 1.2, 0.9991]),
        matrix_table(
            "Stiffness matrix K",
            "N/m",
            frame.k(),
            [1.0021, 0.9987, 1.0004],
        ),
        matrix_table(
            "Damping matrix R, MKR (eq. 30)",
            "kg/s",
            r,
            [97.0, 330.0, 77.0],
        ),
        matrix_table(
            "Damping matrix R, Rayleigh (eq. 16–19)",
            "kg/s",
            r,
            [1.08, 0.91, 1.05],
        ),
        ComparisonTable {
            title: "Lumped-mass check".into(),
            unit: "kg".into(),
            rows: vec![ComparisonRow {
                label: "M12 of a lumped-mass model".into(),
                truth: 0.0,
                identified: 0.0153,
                std: None,
            }],
        },
    ];
    Representative {
        noise_fraction: noise,
        dt_s: DT,
        hit_floor: 1,
        force,
        accelerations,
        hankel_singular_values: hankel,
        order: 4,
        modes: mode_shapes,
        stabilization,
        frf,
        tables,
        warnings: vec![],
        hit_quality: vec![],
    }
}

fn matrix_table(title: &str, unit: &str, m: [[f64; 2]; 2], factor: [f64; 3]) -> ComparisonTable {
    let entries = [
        ("11", m[0][0], factor[0]),
        ("12", m[0][1], factor[1]),
        ("22", m[1][1], factor[2]),
    ];
    ComparisonTable {
        title: title.into(),
        unit: unit.into(),
        rows: entries
            .iter()
            .map(|(ij, v, f)| ComparisonRow {
                label: format!("{}{}", &title[..1], ij),
                truth: *v,
                identified: v * f,
                std: None,
            })
            .collect(),
    }
}

fn setup(frame: &Frame, levels: &[f64]) -> Vec<SetupRow> {
    let (m, k) = (frame.m(), frame.k());
    let row = |l: &str, v: String| SetupRow {
        label: l.into(),
        value: v,
    };
    vec![
        row("Structure", "two-storey shear frame, given M and K".into()),
        row(
            "Mass M [kg]",
            format!("[[{}, {}], [{}, {}]]", m[0][0], m[0][1], m[1][0], m[1][1]),
        ),
        row(
            "Stiffness K [N/m]",
            format!("[[{}, {}], [{}, {}]]", k[0][0], k[0][1], k[1][0], k[1][1]),
        ),
        row(
            "Damping",
            format!("Rayleigh, α = {} 1/s, β = {} s", frame.alpha, frame.beta),
        ),
        row("Hits", "10 at floor 1, half-sine 3 ms, 15 N ± 10 %".into()),
        row(
            "Sampling",
            "64 Hz, 2048 samples (32 s), 32 pre-trigger samples".into(),
        ),
        row(
            "Acquisition",
            "analyzer: anti-alias filtered, band-limited records".into(),
        ),
        row(
            "Intersample assumption",
            "band-limited (impulse invariance)".into(),
        ),
        row(
            "Noise levels",
            levels
                .iter()
                .map(|l| format!("{} %", l * 100.0))
                .collect::<Vec<_>>()
                .join(", "),
        ),
        row("Trials per level", "200".into()),
    ]
}

/// The default synthetic report: three studies, one with a second axis.
pub fn report() -> Report {
    report_with_samples(SAMPLES)
}

pub fn report_with_samples(samples: usize) -> Report {
    let levels = NOISE_LEVELS.to_vec();
    let study1 = Study {
        name: "paper-case1".into(),
        description:
            "Paper case 1: bare two-storey frame, identified M and K with Rayleigh damping as truth"
                .into(),
        seed: 20110525,
        setup: setup(&case1(), &levels),
        representative: Some(representative(&case1(), 0.01, true, samples, 1)),
        accuracy: Accuracy {
            axis_name: None,
            panels: vec![panel(None, &levels, 1.0)],
            efficiency: efficiency(&levels),
            routes: vec![],
        },
    };
    let study2 = Study {
        name: "frame-added-mass".into(),
        description: "Section-4 frame, bare and with one more aluminium block on floor 1".into(),
        seed: 7,
        setup: setup(&case2(), &levels),
        representative: Some(representative(&case2(), 0.01, true, samples, 2)),
        accuracy: Accuracy {
            axis_name: Some("added mass on floor 1".into()),
            panels: vec![
                panel(Some("0 kg"), &levels, 1.0),
                panel(Some("1.09 kg"), &levels, 1.6),
            ],
            efficiency: vec![],
            routes: vec![],
        },
    };
    let levels3 = vec![0.0, 0.005, 0.01, 0.02, 0.05];
    let mut rep3 = representative(&case2(), 0.02, false, samples, 3);
    rep3.warnings = vec![
        "Driving-point residues are negative: the force polarity was inverted and has been flipped.".into(),
    ];
    let study3 = Study {
        name: "paper-case2".into(),
        description: "Paper case 2: added mass on floor 1; stiffness implied by eq. 64".into(),
        seed: 3,
        setup: setup(&case2(), &levels3),
        representative: Some(rep3),
        accuracy: Accuracy {
            axis_name: None,
            panels: vec![panel(None, &levels3, 2.0)],
            efficiency: vec![],
            routes: vec![],
        },
    };
    Report {
        title: "frameid: identification accuracy against noise".into(),
        frameid_version: "0.1.0".into(),
        command: "frameid study scenarios/paper-case1.toml scenarios/frame-added-mass.toml scenarios/paper-case2.toml --out report.html".into(),
        studies: vec![study1, study2, study3],
    }
}

// ---- HTML inspection helpers ----

pub fn sel(s: &str) -> Selector {
    Selector::parse(s).unwrap_or_else(|e| panic!("bad selector {s}: {e:?}"))
}

pub fn parse(html: &str) -> Html {
    Html::parse_document(html)
}

pub fn text(e: ElementRef<'_>) -> String {
    e.text().collect::<String>().trim().to_string()
}

/// Vertices of an SVG `points` attribute.
pub fn vertices(e: ElementRef<'_>) -> Vec<(i32, i32)> {
    e.value()
        .attr("points")
        .unwrap_or("")
        .split_whitespace()
        .filter_map(|p| {
            let (x, y) = p.split_once(',')?;
            Some((x.parse().ok()?, y.parse().ok()?))
        })
        .collect()
}

/// Direct children elements of a group (markers are one element each).
pub fn child_elements(e: ElementRef<'_>) -> Vec<ElementRef<'_>> {
    e.children().filter_map(ElementRef::wrap).collect()
}
