//! The simulator against independent oracles: closed-form modal
//! superposition, the brute-force internal-grid computation, and the
//! frequency response of the model.

mod common;

use std::f64::consts::PI;

use approx::assert_relative_eq;
use common::{paper_case1, three_dof};
use nalgebra::DMatrix;
use num_complex::Complex64;
use rustfft::FftPlanner;
use sim::analyzer::kaiser_lowpass;
use sim::model::undamped_modes;
use sim::response::{AnalyzerEngine, HeldEngine};
use sim::{
    Acquisition, AnalyzerSettings, CampaignSettings, DoubleHit, HammerSettings, Model,
    NoiseSettings, Pulse, Sampling, Simulator,
};

fn sdof() -> Model {
    let m = DMatrix::from_element(1, 1, 0.8);
    let k = DMatrix::from_element(1, 1, 400.0);
    // xi = c / (2 sqrt(k m)) = 0.4 / (2 * 17.889) = 0.01118.
    let c = DMatrix::from_element(1, 1, 0.4);
    Model::new(m, k, c).unwrap()
}

/// Closed-form modal data of a proportionally damped model: for each mode
/// (lambda, phi_j (phi_j^T b) with mass-normalized phi). Independent of the
/// simulator's state space: undamped modes plus xi from phi^T R phi.
fn modal_terms(model: &Model, input: usize) -> Vec<(Complex64, Vec<f64>)> {
    let (w2, phi) = undamped_modes(&model.mass, &model.stiffness);
    (0..model.dofs())
        .map(|j| {
            let w = w2[j].sqrt();
            let col = phi.column(j);
            let c_modal = (col.transpose() * &model.damping * col)[(0, 0)];
            let xi = c_modal / (2.0 * w);
            let lambda = Complex64::new(-xi * w, w * (1.0 - xi * xi).sqrt());
            let coef: Vec<f64> = col.iter().map(|p| p * col[input]).collect();
            (lambda, coef)
        })
        .collect()
}

/// Acceleration of every DOF at time t after the end of a half-sine pulse:
/// y(t) = sum_j phi_j (phi_j^T b) Im(lambda^2 e^{lambda (t - t0)} P I(lambda) G(lambda)) / w_d
/// with I(lambda) = int_0^tau e^{-lambda s} sin(pi s / tau) ds
///               = w (1 + e^{-lambda tau}) / (lambda^2 + w^2), w = pi / tau,
/// and G the gain of the measurement chain on e^{lambda t}.
fn modal_free_response(
    terms: &[(Complex64, Vec<f64>)],
    p: &Pulse,
    t: f64,
    gain: &dyn Fn(Complex64) -> Complex64,
) -> Vec<f64> {
    let n = terms[0].1.len();
    let w = PI / p.duration_s;
    let mut y = vec![0.0; n];
    for (lambda, coef) in terms {
        let l = *lambda;
        let integral = w * (1.0 + (-l * p.duration_s).exp()) / (l * l + w * w);
        let z = l * l * (l * (t - p.start_s)).exp() * p.peak_n * integral * gain(l) / l.im;
        for i in 0..n {
            y[i] += coef[i] * z.im;
        }
    }
    y
}

/// Butterworth gain from its pole product formula (independent of the
/// simulator's state-space realization).
fn butterworth_gain(order: usize, cutoff_hz: f64, s: Complex64) -> Complex64 {
    let wc = 2.0 * PI * cutoff_hz;
    (1..=order).fold(Complex64::new(1.0, 0.0), |acc, k| {
        let p = Complex64::from_polar(wc, PI * (2 * k + order - 1) as f64 / (2 * order) as f64);
        acc * (-p) / (s - p)
    })
}

fn pulse(start_s: f64, peak_n: f64) -> Pulse {
    Pulse {
        start_s,
        duration_s: 0.003,
        peak_n,
    }
}

fn analyzer_engine(model: &Model, input: usize, samples: usize) -> AnalyzerEngine {
    let design = AnalyzerSettings::default().design(64.0).unwrap();
    AnalyzerEngine::new(model, input, 0.003, 1.0 / 64.0, samples, &design)
}

#[test]
fn analyzer_response_matches_modal_superposition_through_the_chain() {
    for (model, input) in [(paper_case1(), 0), (three_dof(0.2, 2e-5), 1), (sdof(), 0)] {
        let samples = 512;
        let engine = analyzer_engine(&model, input, samples);
        let design = AnalyzerSettings::default().design(64.0).unwrap();
        let taps = kaiser_lowpass(
            design.internal_rate_hz,
            design.passband_hz,
            design.stopband_hz,
            100.0,
        );
        let half = (taps.len() / 2) as i64;
        let ti = 1.0 / design.internal_rate_hz;
        let gain = |l: Complex64| {
            let fir: Complex64 = taps
                .iter()
                .enumerate()
                .map(|(k, &h)| h * (l * ((k as i64 - half) as f64 * ti)).exp())
                .sum();
            fir * butterworth_gain(design.analog_order, design.analog_cutoff_hz, l)
        };
        let p = pulse(0.5123, 15.0);
        let rec = engine.response(&[p]);
        let terms = modal_terms(&model, input);
        let scale = rec[1..]
            .iter()
            .flatten()
            .fold(0.0f64, |a, v| a.max(v.abs()));
        // After the pulse, the FIR window (0.46 s) and the analog filter's
        // transient (decays as e^{-1232 t}) have passed, the record is the
        // filtered modal free response. The two computations differ only by
        // rounding in matrix exponentials and sums: 1e-9 of the peak.
        let mut worst = 0.0f64;
        for n in 70..samples {
            let t = n as f64 / 64.0;
            let y = modal_free_response(&terms, &p, t, &gain);
            for (i, yi) in y.iter().enumerate() {
                worst = worst.max((rec[i + 1][n] - yi).abs() / scale);
            }
            // The force channel is the filtered pulse: nothing left here.
            assert!(rec[0][n].abs() < 1e-9 * 15.0, "force at {n}: {}", rec[0][n]);
        }
        assert!(
            worst < 1e-9,
            "{} DOF: worst relative deviation {worst:e}",
            model.dofs()
        );
    }
}

#[test]
fn held_response_matches_modal_superposition_of_the_staircase() {
    for (model, input) in [(sdof(), 0), (paper_case1(), 1), (three_dof(0.1, 1e-5), 2)] {
        let dt = 1.0 / 64.0;
        let samples = 400;
        let engine = HeldEngine::new(&model, input, dt, samples);
        let p = pulse(0.2001, 30.0);
        let rec = engine.response(&[p]);
        let terms = modal_terms(&model, input);
        // Staircase force u_m on [m dt, (m+1) dt): for k > m the modal
        // response is sum_m u_m e^{lambda (k - m) dt} (1 - e^{-lambda dt}) / lambda
        // through the acceleration kernel lambda^2 Im(.) / w_d.
        let scale = rec[1..]
            .iter()
            .flatten()
            .fold(0.0f64, |a, v| a.max(v.abs()));
        let last_force = rec[0].iter().rposition(|&u| u != 0.0).unwrap();
        for k in (last_force + 1)..samples {
            let mut y = vec![0.0; model.dofs()];
            for (lambda, coef) in &terms {
                let l = *lambda;
                let mut acc = Complex64::new(0.0, 0.0);
                for (m, &u) in rec[0].iter().enumerate().take(last_force + 1) {
                    acc += u * (l * ((k - m) as f64 * dt)).exp() * (1.0 - (-l * dt).exp()) / l;
                }
                let z = l * l * acc / l.im;
                for i in 0..y.len() {
                    y[i] += coef[i] * z.im;
                }
            }
            for (i, yi) in y.iter().enumerate() {
                // Matrix exponential versus closed form: rounding only.
                assert!(
                    (rec[i + 1][k] - yi).abs() < 1e-10 * scale,
                    "{} DOF, sample {k}, DOF {i}: {} vs {yi}",
                    model.dofs(),
                    rec[i + 1][k]
                );
            }
        }
        // The held force has the pulse's impulse.
        let impulse: f64 = rec[0].iter().sum::<f64>() * dt;
        assert_relative_eq!(impulse, p.impulse_ns(), max_relative = 1e-12);
    }
}

#[test]
fn sdof_free_decay_has_the_closed_form_frequency_and_envelope() {
    // Free decay of m x'' + c x' + k x = 0: acceleration peaks decay as
    // e^{-xi w t} and oscillate at w_d = w sqrt(1 - xi^2).
    let model = sdof();
    let (m, k, c) = (0.8f64, 400.0f64, 0.4f64);
    let w = (k / m).sqrt();
    let xi = c / (2.0 * (k * m).sqrt());
    let dt = 1.0 / 256.0;
    let engine = HeldEngine::new(&model, 0, dt, 4096);
    let rec = engine.response(&[pulse(0.0, 50.0)]);
    let y = &rec[1];
    // Successive positive peaks (parabolic interpolation) give the damped
    // period and the logarithmic decrement.
    let peaks: Vec<(f64, f64)> = (2..y.len() - 1)
        .filter(|&i| y[i] > y[i - 1] && y[i] >= y[i + 1] && y[i] > 0.0)
        .map(|i| {
            let (a, b, cc) = (y[i - 1], y[i], y[i + 1]);
            let off = 0.5 * (a - cc) / (a - 2.0 * b + cc);
            ((i as f64 + off) * dt, b - 0.25 * (a - cc) * off)
        })
        .collect();
    let n = peaks.len() - 1;
    let period = (peaks[n].0 - peaks[0].0) / n as f64;
    let decrement = (peaks[0].1 / peaks[n].1).ln() / n as f64;
    // Peak interpolation on 57 samples per period: ~1e-4 relative.
    assert_relative_eq!(
        period,
        2.0 * PI / (w * (1.0 - xi * xi).sqrt()),
        max_relative = 2e-4
    );
    assert_relative_eq!(
        decrement,
        2.0 * PI * xi / (1.0 - xi * xi).sqrt(),
        max_relative = 2e-3
    );
}

#[test]
fn fast_analyzer_path_equals_the_brute_force_oracle() {
    let model = paper_case1();
    let engine = analyzer_engine(&model, 0, 256);
    // A pulse on the grid, off the grid, straddling grid points, and a
    // double hit whose responses overlap.
    for pulses in [
        vec![pulse(0.5, 10.0)],
        vec![pulse(0.50731, 12.5)],
        vec![pulse(0.01, 8.0)],
        vec![pulse(0.6003, 9.0), pulse(0.6063, 4.0)],
    ] {
        let fast = engine.response(&pulses);
        let oracle = engine.reference_response(&pulses);
        for (a, b) in fast.iter().zip(&oracle) {
            let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (x, y) in a.iter().zip(b) {
                // Same arithmetic regrouped (G = C sum h_k Phi^k versus the
                // explicit FIR sum): rounding only.
                assert!((x - y).abs() <= 1e-11 * scale, "{x} vs {y}");
            }
        }
    }
}

/// H1 estimate sum(Y U*) / sum(|U|^2) over hits at DFT bin k.
fn h1(records: &[Vec<Vec<f64>>], out: usize) -> Vec<Complex64> {
    let n = records[0][0].len();
    let mut planner = FftPlanner::new();
    let fft = planner.plan_fft_forward(n);
    let spectrum = |x: &[f64]| {
        let mut buf: Vec<Complex64> = x.iter().map(|&v| Complex64::new(v, 0.0)).collect();
        fft.process(&mut buf);
        buf
    };
    let mut num = vec![Complex64::new(0.0, 0.0); n];
    let mut den = vec![0.0; n];
    for rec in records {
        let u = spectrum(&rec[0]);
        let y = spectrum(&rec[out]);
        for k in 0..n {
            num[k] += y[k] * u[k].conj();
            den[k] += u[k].norm_sqr();
        }
    }
    num.iter().zip(&den).map(|(a, b)| a / b).collect()
}

fn model_frf(model: &Model, input: usize, out: usize, s: Complex64) -> Complex64 {
    let sys = model.state_space(input);
    let n = sys.a.nrows();
    let to_c = |m: &DMatrix<f64>| m.map(|v| Complex64::new(v, 0.0));
    let x = (DMatrix::<Complex64>::identity(n, n) * s - to_c(&sys.a))
        .lu()
        .solve(&to_c(&sys.b))
        .unwrap();
    (to_c(&sys.c) * x)[(out, 0)] + sys.d[(out, 0)]
}

#[test]
fn analyzer_chain_preserves_the_input_output_relation() {
    // Damping high enough (xi ~ 2 %) that 8192 samples at 64 Hz (128 s)
    // hold the whole decay (e^{-xi w T} < 1e-12), so the DFT relation
    // Y = H U holds without leakage for these band-limited records.
    let model = three_dof(0.6, 6e-4);
    let settings = CampaignSettings {
        hits: 3,
        hammer: HammerSettings {
            floor: 1,
            duration_s: 0.003,
            peak_n: 20.0,
            peak_variation: 0.1,
            start_jitter_s: 1.0 / 64.0,
            double_hit: None,
        },
        sampling: Sampling {
            sample_rate_hz: 64.0,
            samples: 8192,
            pretrigger_samples: 32,
        },
        acquisition: Acquisition::Analyzer(AnalyzerSettings::default()),
        noise: NoiseSettings::default(),
        invert_force_polarity: false,
        excitation: Default::default(),
        rig: Default::default(),
    };
    let sim = Simulator::new(model.clone(), settings).unwrap();
    let campaign = sim.simulate(7);
    let records: Vec<Vec<Vec<f64>>> = campaign
        .hits
        .iter()
        .map(|h| {
            let mut r = vec![h.force.clone()];
            r.extend(h.accelerations.iter().cloned());
            r
        })
        .collect();
    let n = 8192;
    for out in 1..=3 {
        let h = h1(&records, out);
        let mut worst = 0.0f64;
        for (k, hk) in h.iter().enumerate().take(n / 2).skip(1) {
            let f = k as f64 * 64.0 / n as f64;
            if f > 0.8 * 32.0 {
                break;
            }
            let truth = model_frf(&model, 0, out - 1, Complex64::new(0.0, 2.0 * PI * f));
            // Aliased content comes from above the band, where an
            // acceleration FRF is about its feedthrough D: measure the
            // error against |H| + |D| so it stays meaningful near zeros of H.
            // Aliased content at f comes from k * 64 Hz +- f: measure the
            // error against |H| there too, so it stays meaningful near
            // zeros of H(f).
            let alias = (1..=8)
                .flat_map(|k| [64.0 * k as f64 - f, 64.0 * k as f64 + f])
                .map(|fa| model_frf(&model, 0, out - 1, Complex64::new(0.0, 2.0 * PI * fa)).norm())
                .fold(0.0f64, f64::max);
            worst = worst.max((hk - truth).norm() / (truth.norm() + alias));
        }
        // Both channels pass the same filters, so their ripple cancels. What
        // remains is aliasing: each alias band k * 64 Hz +- f (|k| = 1..8,
        // below the 512 Hz analog cut-off) leaks through the FIR stop band
        // at <= 1e-5 of its level; 1e-4 bounds their sum (measured 2.2e-5).
        assert!(
            worst < 1e-4,
            "output {out}: worst relative FRF error {worst:e}"
        );
    }
}

#[test]
fn held_records_follow_the_zoh_frequency_response() {
    let model = three_dof(0.6, 6e-4);
    let dt = 1.0 / 64.0;
    let n = 8192;
    let engine = HeldEngine::new(&model, 0, dt, n);
    let records = vec![
        engine.response(&[pulse(0.5, 20.0)]),
        engine.response(&[pulse(0.9037, 14.0)]),
    ];
    let sys = model.state_space(0);
    // ZOH discretization by eigen-free series: Phi = exp(A dt), Gamma from the
    // augmented exponential; evaluate C (zI - Phi)^-1 Gamma + D.
    let ns = sys.a.nrows();
    let mut aug = DMatrix::zeros(ns + 1, ns + 1);
    aug.view_mut((0, 0), (ns, ns)).copy_from(&sys.a);
    aug.view_mut((0, ns), (ns, 1)).copy_from(&sys.b);
    let e = (aug * dt).exp();
    let to_c = |m: DMatrix<f64>| m.map(|v| Complex64::new(v, 0.0));
    let phi = to_c(e.view((0, 0), (ns, ns)).into_owned());
    let gamma = to_c(e.view((0, ns), (ns, 1)).into_owned());
    for out in 1..=3 {
        let h = h1(&records, out);
        for (k, hk) in h.iter().enumerate().take(n / 2).skip(1) {
            let z = Complex64::from_polar(1.0, 2.0 * PI * k as f64 / n as f64);
            let x = (DMatrix::<Complex64>::identity(ns, ns) * z - &phi)
                .lu()
                .solve(&gamma)
                .unwrap();
            let truth = (to_c(sys.c.clone()) * x)[(out - 1, 0)] + sys.d[(out - 1, 0)];
            // Exact discrete relation; only leakage below e^{-43} and rounding.
            assert!(
                ((hk - truth) / truth).norm() < 1e-8,
                "bin {k}: {hk} vs {truth}"
            );
        }
    }
}

fn campaign_settings(noise: NoiseSettings) -> CampaignSettings {
    CampaignSettings {
        hits: 4,
        hammer: HammerSettings {
            floor: 1,
            duration_s: 0.003,
            peak_n: 15.0,
            peak_variation: 0.15,
            start_jitter_s: 1.0 / 64.0,
            double_hit: None,
        },
        sampling: Sampling {
            samples: 1024,
            ..Sampling::default()
        },
        acquisition: Acquisition::Analyzer(AnalyzerSettings::default()),
        noise,
        invert_force_polarity: false,
        excitation: Default::default(),
        rig: Default::default(),
    }
}

#[test]
fn requested_noise_fraction_is_recovered_from_the_records() {
    let fraction = 0.02;
    let noisy = Simulator::new(
        paper_case1(),
        campaign_settings(NoiseSettings {
            fraction,
            ..Default::default()
        }),
    )
    .unwrap();
    let clean = Simulator::new(paper_case1(), campaign_settings(NoiseSettings::default())).unwrap();
    let (a, b) = (noisy.simulate(11), clean.simulate(11));
    for (hn, hc) in a.hits.iter().zip(&b.hits) {
        // Same seed: same pulses whatever the noise level.
        assert_eq!(hn.pulses, hc.pulses);
        let mut pairs = vec![(&hn.force, &hc.force)];
        pairs.extend(hn.accelerations.iter().zip(&hc.accelerations));
        for (x, c) in pairs {
            let noise: Vec<f64> = x.iter().zip(c).map(|(p, q)| p - q).collect();
            let ratio = sim::noise::rms(&noise) / sim::noise::rms(c);
            // 1024 Gaussian samples: the RMS estimate has relative standard
            // deviation 1 / sqrt(2 * 1024) = 2.2 %; 4 sigma = 9 %.
            assert_relative_eq!(ratio, fraction, max_relative = 0.09);
        }
    }
}

#[test]
fn same_seed_gives_identical_campaigns_and_different_seeds_differ() {
    let sim = Simulator::new(
        paper_case1(),
        campaign_settings(NoiseSettings {
            fraction: 0.01,
            ..Default::default()
        }),
    )
    .unwrap();
    let a = sim.simulate(42);
    let b = sim.simulate(42);
    assert_eq!(a, b);
    let c = sim.simulate(43);
    assert_ne!(a.hits[0].force, c.hits[0].force);
    assert_ne!(a.hits[0].pulses, c.hits[0].pulses);
}

#[test]
fn double_hit_adds_a_delayed_weaker_pulse() {
    let mut settings = campaign_settings(NoiseSettings::default());
    settings.acquisition = Acquisition::Held;
    settings.hammer.double_hit = Some(DoubleHit {
        delay_s: 0.05,
        ratio: 0.4,
    });
    let sim = Simulator::new(paper_case1(), settings).unwrap();
    let c = sim.simulate(3);
    for hit in &c.hits {
        assert_eq!(hit.pulses.len(), 2);
        assert_relative_eq!(
            hit.pulses[1].peak_n,
            0.4 * hit.pulses[0].peak_n,
            max_relative = 1e-15
        );
        // Held force: two separate bursts of samples.
        let nonzero: Vec<usize> = hit
            .force
            .iter()
            .enumerate()
            .filter(|(_, v)| **v != 0.0)
            .map(|(i, _)| i)
            .collect();
        assert!(
            nonzero.windows(2).any(|w| w[1] - w[0] > 1),
            "two distinct bursts: {nonzero:?}"
        );
    }
}

#[test]
fn inverted_polarity_flips_only_the_force() {
    let mut settings = campaign_settings(NoiseSettings::default());
    let plain = Simulator::new(paper_case1(), settings.clone())
        .unwrap()
        .simulate(5);
    settings.invert_force_polarity = true;
    let flipped = Simulator::new(paper_case1(), settings).unwrap().simulate(5);
    for (a, b) in plain.hits.iter().zip(&flipped.hits) {
        assert!(a.force.iter().zip(&b.force).all(|(x, y)| *x == -*y));
        assert_eq!(a.accelerations, b.accelerations);
    }
}
